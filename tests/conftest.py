"""Shared fixtures: the default vehicle, its text, and a helper to write variants of it."""

from __future__ import annotations

from pathlib import Path

import pytest
from locations import DEFAULT_VEHICLE

from vsegen.harness.jobs.memo import clear_all
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.model.params import VehicleConfig, parse_vehicle


@pytest.fixture(scope="session")
def config():
    return load_vehicle(DEFAULT_VEHICLE)


@pytest.fixture(scope="session")
def vehicle_text() -> str:
    return DEFAULT_VEHICLE.read_text()


@pytest.fixture(scope="session")
def variant(vehicle_text: str):
    """The default vehicle with ``key = value`` set in one table:
    ``variant("estimator.aukf", forgetting_factor=0.97)``; ``text`` starts from other file text."""

    def make(table: str, text: str | None = None, **keys) -> VehicleConfig:
        edited = with_settings(vehicle_text if text is None else text, table, **keys)
        return parse_vehicle(edited, "variant.toml", "c_class")

    return make


@pytest.fixture
def write_vehicle(tmp_path: Path, vehicle_text: str):
    """Write the default vehicle file with ``old`` replaced by ``new``; returns the path."""

    def write(old: str = "", new: str = "", name: str = "variant.toml") -> Path:
        if old and old not in vehicle_text:
            raise AssertionError(f"fixture text not found: {old!r}")
        path = tmp_path / name
        path.write_text(vehicle_text.replace(old, new, 1) if old else vehicle_text)
        return path

    return write


@pytest.fixture
def cleared_memos():
    """Every per-process memo (simulated logs, truth runs, compiled estimators) empty before and
    after the test."""
    clear_all()
    yield
    clear_all()
