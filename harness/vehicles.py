"""Loading vehicle files from disk (the I/O half of model.params)."""

from __future__ import annotations

from pathlib import Path

from harness.paths import VEHICLES
from model.params import ParameterError, VehicleConfig, parse_vehicle


def load_vehicle(path: Path | str) -> VehicleConfig:
    """Read and validate a vehicle TOML file; ParameterError (one line) on any problem."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read vehicle file: {exc.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ParameterError(f"{path}:1: not a text file: expected UTF-8 TOML") from None
    return parse_vehicle(text, str(path), path.stem)


def shipped_vehicles() -> list[Path]:
    """The vehicle files in the repository's vehicles/ folder."""
    return sorted(VEHICLES.glob("*.toml"))
