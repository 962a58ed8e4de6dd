"""Any log a user names, as a source of chunks: CSV (plain or compressed), MDF4, or a raw CAN log
(BLF, ASC, bus-logging MDF4) with the car's DBC, each through the channel map."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import LogError

LOG_SUFFIXES = (".csv", ".csv.gz", ".csv.bz2", ".csv.xz", ".mf4", ".mdf", ".blf", ".asc")
"""The file names a folder of logs is searched for."""


def open_log(path: Path, channels: Path | None, sample_time: float | Callable[[], float],
             window: tuple[float | None, float | None] = (None, None), dbc: Path | None = None) -> LogSource:
    """``path`` through the channel map file ``channels`` (None: the columns by their own names, SI),
    cut to ``window`` (s). MDF4 channels and CAN signals go onto a grid of ``sample_time`` s (a
    number, or a function giving it, called only for them). ``dbc`` decodes the raw CAN logs (BLF,
    ASC, and MDF4 files that hold CAN frames); other logs are read as they are, so one campaign can
    mix them. LogError (one line) on any mistake, e.g. a BLF without ``dbc``."""
    from vsegen.harness.logs.can import FRAME_SUFFIXES, holds_can_frames, open_can_log
    from vsegen.harness.logs.channels import read_channel_map
    from vsegen.harness.logs.mdf import SUFFIXES, open_mdf_log
    from vsegen.harness.logs.stream import open_csv_log

    path = Path(path)
    mapping = read_channel_map(channels)
    if path.suffix.lower() in FRAME_SUFFIXES and dbc is None:
        raise LogError(f"{path}: a raw CAN log ({path.suffix}): expected --dbc CAR.dbc to decode its frames")
    if dbc is not None and (path.suffix.lower() in FRAME_SUFFIXES or
                            path.suffix.lower() in SUFFIXES and holds_can_frames(path)):
        return open_can_log(path, dbc, mapping, sample_time() if callable(sample_time) else sample_time, window)
    if path.suffix.lower() in SUFFIXES:
        return open_mdf_log(path, mapping, sample_time() if callable(sample_time) else sample_time, window)
    return open_csv_log(path, {c.channel: (c.name, c.scale) for c in mapping.columns.values()}, window=window)
