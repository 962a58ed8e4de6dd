"""Loading vehicle files from disk (the I/O half of model.params)."""

from __future__ import annotations

from pathlib import Path

from harness.files import read_user_text
from harness.paths import VEHICLES
from model.params import ParameterError, VehicleConfig, parse_vehicle


def load_vehicle(path: Path | str) -> VehicleConfig:
    """Read and validate a vehicle TOML file; ParameterError (one line) on any problem."""
    path = Path(path)
    text = read_user_text(path, ParameterError, "vehicle file (TOML)")
    return parse_vehicle(text, str(path), path.stem)


def shipped_vehicles() -> list[Path]:
    """The vehicle files in the repository's vehicles/ folder."""
    return sorted(VEHICLES.glob("*.toml"))
