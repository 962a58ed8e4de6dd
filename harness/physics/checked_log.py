"""Opening a user's log the way every command does: through its channel map (and DBC), its units
judged from physics on its first ten minutes, and the lines to say about it."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from vsegen.harness.logs.sources import open_log
from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import LogError
from vsegen.harness.physics.units import check_units_of_head
from vsegen.model.params import VehicleConfig


def open_checked_log(path: Path, channels: Path | None, sample_time: float | Callable[[], float],
                     window: tuple[float | None, float | None] = (None, None), dbc: Path | None = None,
                     config: VehicleConfig | None = None) -> tuple[LogSource, list[str]]:
    """``harness.logs.sources.open_log``, and with a vehicle ``config`` its units judged from physics
    on its first ten minutes (``harness.physics.units``; LogError on a wrong one): (the source, the
    lines to say about it: frozen stretches, a scaled yaw rate, the columns no relation could judge)."""
    source = open_log(path, channels, sample_time, window, dbc)
    notes: list[str] = []
    if config is not None:
        try:
            unchecked = check_units_of_head(source, config.vehicle, config.driven_axle, notes)
        except LogError:
            source.close()
            raise
        notes += [f"units not checked: {', '.join(unchecked)}"] if unchecked else []
    return source, notes
