"""Shared fixtures: the default vehicle, its text, helpers to write variants of it, the vsegen command
line and a clean slate of the per-process memos."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

os.environ.pop("COLUMNS", None)     # pytest-xdist's workers set 80; the commands' tables honour it

import one_thread  # noqa: F401  (before NumPy loads: one BLAS thread per xdist worker)
import pytest
from click.testing import CliRunner
from locations import DEFAULT_VEHICLE, REPO, REVS

from vsegen.harness.cli import main
from vsegen.harness.jobs.memo import clear_all
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.model.params import VehicleConfig, parse_vehicle


@pytest.fixture(scope="session")
def config():
    return load_vehicle(DEFAULT_VEHICLE)


@pytest.fixture(scope="session")
def revs_lap():
    """The Revs lap as a log (55,001 samples at 100 Hz, with its INS reference columns)."""
    from vsegen.harness.logs.table import read_log

    return read_log(REVS / "lap.csv.gz")


@pytest.fixture(scope="session")
def revs_car() -> VehicleConfig:
    """The Revs car's base vehicle file: mass, geometry and I_z typed in, everything else a guess."""
    return load_vehicle(REVS / "car.toml")


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


@dataclass(frozen=True)
class CliRun:
    """What one vsegen command did: its exit status and its two output streams."""

    exit_code: int
    stdout: str
    stderr: str

    @property
    def output(self) -> str:
        """Both streams, for an assertion message."""
        return self.stdout + self.stderr


class Vsegen:
    """The vsegen command line as the tests run it: ``vsegen("run", ...)`` in this process (click's
    runner: fast, the caches shared; an exception is raised, not turned into an exit status);
    ``vsegen.process(..., cwd=...)`` in a new Python process started in ``cwd`` (what a user's shell
    does: the project is found from the working directory)."""

    def __call__(self, *args: str) -> CliRun:
        result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
        return CliRun(result.exit_code, result.stdout, result.stderr)

    def process(self, *args: str, cwd: Path = REPO, env: dict | None = None) -> CliRun:
        done = subprocess.run([sys.executable, "-m", "vsegen.harness.cli", *map(str, args)], cwd=cwd, env=env,
                              capture_output=True, text=True)
        return CliRun(done.returncode, done.stdout, done.stderr)


@pytest.fixture(scope="session")
def vsegen() -> Vsegen:
    """The vsegen command line (see :class:`Vsegen`)."""
    return Vsegen()
