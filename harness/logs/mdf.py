"""ASAM MDF4 logs (.mf4, .mdf) via asammdf: the mapped channels, each at its own rate, read in
ranges of records and brought causally onto the estimator's sample grid (``harness.logs.grid``).
Estimates are written as MDF4 by ``harness.outputs.estimates.EstimatesWriter``."""

from __future__ import annotations

import gc
import sys
from pathlib import Path

import numpy as np

from vsegen.harness.logs.channels import ChannelMap, file_unit_conflict
from vsegen.harness.logs.grid import GridChannel, grid_source
from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import (
    OPTIONAL_INPUTS,
    REQUIRED,
    TRUTH,
    Log,
    LogError,
)

SUFFIXES = (".mf4", ".mdf")


def open_mdf(path: Path):
    """The asammdf reader of ``path``, or LogError (one line). A half-built reader of a damaged
    file fails again in its destructor; that noise (a traceback on stderr) is swallowed while it
    is collected here."""
    from asammdf import MDF

    message = None
    hook = sys.unraisablehook
    sys.unraisablehook = lambda unraisable: None
    try:
        try:
            return MDF(path)
        except Exception as exc:  # asammdf raises many types for a bad file
            message = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        gc.collect()
    finally:
        sys.unraisablehook = hook
    raise LogError(f"{path}: not a readable MDF4 file: {message}")


def read_mdf(path: Path, channels: ChannelMap, sample_time: float) -> Log:
    """The log columns of an MDF4 file on a uniform grid of ``sample_time`` s, in memory (see
    :func:`open_mdf_log`); the notes say where the grid has gaps."""
    return open_mdf_log(path, channels, sample_time).read()


READ_RECORDS = 1 << 16
"""Records of a channel read at a time."""


def open_mdf_log(path: Path, channels: ChannelMap, sample_time: float,
                 window: tuple[float | None, float | None] = (None, None)) -> LogSource:
    """The log columns of an MDF4 file as a source of chunks on a uniform grid of ``sample_time``
    s over the span every required channel covers (cut to ``window``, s): each tick takes each
    channel's latest sample at or before it (no look-ahead); a channel older than MAX_GAP at a tick
    gives NaN there (the estimators hold), and the source's notes say where once it has been read.
    Channels are read in ranges of records, so memory does not grow with the log. Every missing
    required channel is named at once; a channel name found in several groups must be chosen by
    the map's ``group`` or ``message``."""
    mdf = open_mdf(path)
    found, missing = {}, []
    for name in (*REQUIRED[1:], *OPTIONAL_INPUTS, *TRUTH):
        column = channels.column(name)
        if column.channel not in mdf.channels_db:
            if name in REQUIRED:
                missing.append(f"'{column.channel}' for column '{name}'")
            continue
        group, index = _occurrence(mdf, path, column, channels.source)
        first = mdf.get(group=group, index=index, record_offset=0, record_count=2)
        written = file_unit_conflict(column, str(first.unit or ""))
        if written:
            raise LogError(f"{path}: channel '{column.channel}' is in {written} (the file's unit), the channel map "
                           f"reads it as {column.unit}: expected unit = \"{written}\" in [columns.{name}] of "
                           f"{channels.source}")
        records = int(mdf.groups[group].channel_group.cycles_nr)
        if records:
            last = mdf.get(group=group, index=index, record_offset=records - 1, record_count=1)
            found[name] = _Channel(mdf, group, index, column.scale, records, np.asarray(first.timestamps, dtype=float),
                                   float(last.timestamps[-1]))
    if missing:
        mdf.close()
        raise LogError(f"{path}: missing channel{'s' if len(missing) > 1 else ''} {', '.join(missing)}: expected "
                       f"{'them' if len(missing) > 1 else 'it'} in the file or other channels named in the channel "
                       f"map ({channels.source})")
    source = grid_source(str(path), found, sample_time, window, "MDF4 channels")
    source.closers.append(mdf.close)
    return source


class _Channel(GridChannel):
    """One MDF4 channel read forward in ranges of READ_RECORDS records."""

    def __init__(self, mdf, group: int, index: int, scale: float, records: int, head: np.ndarray, stop: float):
        self.mdf, self.group, self.index, self.records = mdf, group, index, records
        rate = 1.0 / float(head[1] - head[0]) if len(head) > 1 and head[1] > head[0] else 0.0
        super().__init__(float(head[0]), stop, rate, scale)

    def restart(self) -> None:
        self.offset = 0

    def more(self) -> tuple[np.ndarray, np.ndarray] | None:
        if self.offset >= self.records:
            return None
        signal = self.mdf.get(group=self.group, index=self.index, record_offset=self.offset,
                              record_count=READ_RECORDS)
        self.offset += len(signal.timestamps)
        return signal.timestamps, signal.samples


def _occurrence(mdf, path: Path, column, source: str) -> tuple[int | None, int | None]:
    """(group, index) of ``column``'s channel in ``mdf``: the only one, or the one the map's
    ``group`` or ``message`` names; LogError (one line) when that is ambiguous or absent."""
    found = mdf.channels_db[column.channel]
    if column.group is not None or column.message is not None:
        chosen = [(g, i) for g, i in found if (column.group is None or g == column.group)
                  and (column.message is None or _group_name(mdf, g) == column.message)]
        if len(chosen) != 1:
            wanted = f"group = {column.group}" if column.group is not None else f"message = {column.message!r}"
            raise LogError(f"{path}: channel '{column.channel}' ({wanted} in {source}) is not in exactly one group: "
                           f"expected one of {_groups(mdf, found)}")
        return chosen[0]
    if len(found) > 1:
        raise LogError(f"{path}: channel '{column.channel}' for column '{column.name}' is in {len(found)} groups: "
                       f"expected the channel map to choose one with group = N or message = NAME "
                       f"({_groups(mdf, found)})")
    return found[0]


def _group_name(mdf, group: int) -> str:
    """A channel group's acquisition name (e.g. the CAN message), '' if it has none."""
    channel_group = mdf.groups[group].channel_group
    return str(getattr(channel_group, "acq_name", "") or "")


def _groups(mdf, found) -> str:
    return ", ".join(f"group {g}" + (f" (message {_group_name(mdf, g)!r})" if _group_name(mdf, g) else "")
                     for g, _ in found)
