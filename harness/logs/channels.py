"""Channel maps: which logger channel holds which log column, in which unit.

A channel map is a TOML file with one table per log column (docs/conventions.md):

    [columns.delta]
    channel = "SteerWhlAng"   # the logger's channel name
    unit = "deg"              # from UNITS; converted to the column's SI unit
    factor = 0.0625           # optional, applied first (e.g. 1 / steering ratio)
    group = 3                 # optional (MDF4): the channel group, where the name repeats
    message = "ESP_21"        # optional (MDF4): or the group by its acquisition name (a CAN message)

A column the map does not name is read from a channel of its own name, in SI units. Units must
match the column's kind (an angle for delta, a speed for vx, ...): a map that gives km/h for the
yaw rate is refused in one line. The time column ``t`` of a CSV log may be mapped too (its name
and unit: s, ms or us); an MDF4 file's channels carry their own time stamps.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from vsegen.harness.logs.table import LogError
from vsegen.harness.project.files import read_user_text
from vsegen.model import signals

UNITS: dict[str, tuple[str, float]] = {
    "rad": ("angle", 1.0), "deg": ("angle", math.pi / 180.0),
    "m/s": ("speed", 1.0), "km/h": ("speed", 1.0 / 3.6), "mph": ("speed", 0.44704),
    "rad/s": ("angular rate", 1.0), "deg/s": ("angular rate", math.pi / 180.0),
    "rpm": ("angular rate", 2.0 * math.pi / 60.0),
    "m/s^2": ("acceleration", 1.0), "g": ("acceleration", 9.80665),
    "N*m": ("moment", 1.0), "-": ("ratio", 1.0),
    "s": ("time", 1.0), "ms": ("time", 1e-3), "us": ("time", 1e-6),
}
"""The unit vocabulary: name -> (kind, factor to the kind's SI unit)."""
SI_KIND = {"rad": "angle", "m/s": "speed", "rad/s": "angular rate", "m/s^2": "acceleration",
           "N*m": "moment", "-": "ratio", "s": "time"}
ALIASES = {"kph": "km/h", "km/hr": "km/h", "°": "deg", "°/s": "deg/s", "deg/sec": "deg/s", "rad/sec": "rad/s",
           "m/s²": "m/s^2", "m/s2": "m/s^2", "m/(s^2)": "m/s^2", "Nm": "N*m", "N.m": "N*m", "sec": "s", "1/min": "rpm"}
"""Other spellings of the vocabulary's units that loggers write into MDF4 files."""
COLUMNS = {signals.TIME.name: signals.TIME.unit, **signals.LOG_COLUMN_UNITS}
"""Every column a map may name, with its SI unit: time, the inputs and the ground truth."""


@dataclass(frozen=True)
class Column:
    """Where one log column comes from."""

    name: str
    channel: str
    scale: float
    """Multiplies the channel's values: factor x the unit's factor to SI."""
    unit: str = ""
    """The unit the map declares (the column's SI unit when it names none)."""
    group: int | None = None
    """MDF4: the channel group to read the channel from (where its name repeats)."""
    message: str | None = None
    """MDF4: the channel group by its acquisition name (e.g. the CAN message)."""


@dataclass(frozen=True)
class ChannelMap:
    columns: dict[str, Column]
    source: str = "<default>"

    def column(self, name: str) -> Column:
        """The map's entry for ``name``, or a channel of that name in SI units."""
        return self.columns.get(name, Column(name, name, 1.0, COLUMNS.get(name, "")))


def read_channel_map(path: Path | None) -> ChannelMap:
    """The channel map in ``path`` (None: every column from a channel of its own name, SI units);
    LogError with one line (file, line, key, expected) on a mistake."""
    if path is None:
        return ChannelMap({})
    text = read_user_text(path, LogError, "channel map (TOML)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise LogError(f"{path}: not valid TOML: {exc}") from None
    unknown = set(data) - {"columns"}
    if unknown:
        raise LogError(f"{path}: unknown table [{sorted(unknown)[0]}]: expected only [columns.<name>] tables")
    columns = {}
    for name, entry in data.get("columns", {}).items():
        where = f"{path}:{_line(text, name)}: [columns.{name}]"
        if name not in COLUMNS:
            raise LogError(f"{where}: unknown column: expected one of {', '.join(COLUMNS)}")
        if not isinstance(entry, dict) or not isinstance(entry.get("channel"), str) or not entry["channel"]:
            raise LogError(f"{where} channel: expected the logger's channel name as a string")
        extra = set(entry) - {"channel", "unit", "factor", "group", "message"}
        if extra:
            raise LogError(f"{where} {sorted(extra)[0]}: unknown key: expected channel, unit, factor, group, message")
        group, message = entry.get("group"), entry.get("message")
        if group is not None and (isinstance(group, bool) or not isinstance(group, int) or group < 0):
            raise LogError(f"{where} group = {group!r}: expected the channel group's index (a whole number >= 0)")
        if message is not None and (not isinstance(message, str) or not message):
            raise LogError(f"{where} message = {message!r}: expected the channel group's acquisition name")
        unit = entry.get("unit", COLUMNS[name])
        if unit not in UNITS:
            raise LogError(f"{where} unit = {unit!r}: expected one of {', '.join(UNITS)}")
        kind, to_si = UNITS[unit]
        if kind != SI_KIND[COLUMNS[name]]:
            raise LogError(f"{where} unit = {unit!r}: expected a unit of {SI_KIND[COLUMNS[name]]} "
                           f"(the column is in {COLUMNS[name]})")
        factor = entry.get("factor", 1.0)
        if isinstance(factor, bool) or not isinstance(factor, (int, float)) or not math.isfinite(factor) \
                or factor == 0:
            raise LogError(f"{where} factor = {factor!r}: expected a finite non-zero number")
        columns[name] = Column(name, entry["channel"], float(factor) * to_si, unit, group, message)
    return ChannelMap(columns, str(path))


def _line(text: str, name: str) -> int:
    for number, line in enumerate(text.splitlines(), start=1):
        if line.strip().replace(" ", "") == f"[columns.{name}]":
            return number
    return 1


def file_unit_conflict(column: Column, written: str) -> str | None:
    """The unit a logger wrote for ``column``'s channel (``written``, e.g. MDF4 metadata), when it
    is a unit of the vocabulary other than the one the map declares (None otherwise: they agree,
    or the file's unit cannot be judged)."""
    unit = ALIASES.get(written.strip(), written.strip())
    if unit in UNITS and column.unit in UNITS and UNITS[unit] != UNITS[column.unit]:
        return unit
    return None
