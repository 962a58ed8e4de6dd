"""ASAM MDF4 logs (.mf4, .mdf) via asammdf: the mapped channels, each at its own rate, brought
causally onto the estimator's sample grid; estimates written as MDF4."""

from __future__ import annotations

import gc
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np

from vsegen.harness.logs.channels import ChannelMap, file_unit_conflict
from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import (
    OPTIONAL_INPUTS,
    REQUIRED,
    TRUTH,
    Log,
    LogError,
    gap_note,
    latest_samples,
    runs,
)
from vsegen.harness.project.files import write_atomic

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
        raise LogError(f"{path}: missing channel{'s' if len(missing) > 1 else ''} {', '.join(missing)}: expected "
                       f"{'them' if len(missing) > 1 else 'it'} in the file or other channels named in the channel "
                       f"map ({channels.source})")
    start = max(c.start for name, c in found.items() if name in REQUIRED)
    stop = min(c.stop for name, c in found.items() if name in REQUIRED)
    ticks = int(np.floor((stop - start) / sample_time + 1e-9)) + 1
    first_tick, ticks = _window_ticks(start, sample_time, ticks, window)
    if ticks < 2:
        raise LogError(f"{path}: the required channels overlap for {stop - start:.3g} s: expected at least "
                       f"two samples of {sample_time:g} s")
    rates = ", ".join(f"{name} {c.rate:.4g} Hz" for name, c in found.items() if c.rate)
    notes = {"resampled": f"MDF4 channels ({rates}) taken causally onto a uniform {sample_time * 1e3:g} ms grid"}
    source = LogSource(str(path), sample_time, ticks, ("t", *found), lambda rows, names: iter(()), notes)

    def chunks(rows: int, names: tuple[str, ...]) -> Iterator[Log]:
        for channel in found.values():
            channel.rewind()
        gaps = []
        for begin in range(0, ticks, rows):
            t = start + sample_time * (first_tick + np.arange(begin, min(begin + rows, ticks)))
            columns, stale_any = {"t": t}, np.zeros(len(t), dtype=bool)
            for name, channel in found.items():
                if name in names or name in REQUIRED:
                    values, stale = channel.at(t)
                    stale_any |= stale if name in REQUIRED else False
                    if name in names:
                        columns[name] = values
            gaps += [(float(t[run.start]), float(t[run.stop - 1])) for run in runs(stale_any)]
            yield Log(columns, str(path))
        if gaps:
            source.notes["gaps"] = gap_note(_joined(gaps, sample_time))

    source.read_chunks = chunks
    return source


def _window_ticks(start: float, step: float, ticks: int, window: tuple[float | None, float | None]) -> tuple[int, int]:
    """(first tick, number of ticks) of a grid ``start + step * k``, k < ``ticks``, inside ``window``."""
    k = np.arange(ticks)
    inside = np.ones(ticks, dtype=bool)
    if window[0] is not None:
        inside &= start + step * k >= window[0]
    if window[1] is not None:
        inside &= start + step * k <= window[1]
    if not inside.any():
        return 0, 0
    chosen = np.flatnonzero(inside)
    return int(chosen[0]), int(chosen[-1] - chosen[0] + 1)


def _joined(gaps: list[tuple[float, float]], step: float) -> list[tuple[float, float]]:
    """Gaps split at chunk boundaries joined again."""
    joined = [gaps[0]]
    for a, b in gaps[1:]:
        if a - joined[-1][1] <= 1.5 * step:
            joined[-1] = (joined[-1][0], b)
        else:
            joined.append((a, b))
    return joined


class _Channel:
    """One channel read forward in ranges of records, brought onto grid ticks causally."""

    def __init__(self, mdf, group: int, index: int, scale: float, records: int, head: np.ndarray, stop: float):
        self.mdf, self.group, self.index, self.scale, self.records = mdf, group, index, scale, records
        self.start, self.stop = float(head[0]), stop
        self.rate = 1.0 / float(head[1] - head[0]) if len(head) > 1 and head[1] > head[0] else 0.0
        self.rewind()

    def rewind(self) -> None:
        self.offset = 0
        self.t = np.empty(0)
        self.values = np.empty(0)

    def at(self, ticks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(values at ``ticks``, NaN where stale; whether stale); ticks come in increasing order."""
        while (not self.t.size or self.t[-1] < ticks[-1]) and self.offset < self.records:
            signal = self.mdf.get(group=self.group, index=self.index, record_offset=self.offset,
                                  record_count=READ_RECORDS)
            self.offset += len(signal.timestamps)
            self.t = np.concatenate((self.t, np.asarray(signal.timestamps, dtype=float)))
            self.values = np.concatenate((self.values, np.asarray(signal.samples, dtype=float) * self.scale))
        latest, stale = latest_samples(self.t, ticks)
        values = np.where(stale, np.nan, self.values[latest])
        keep = int(latest[-1])
        self.t, self.values = self.t[keep:], self.values[keep:]
        return values, stale


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


def write_mdf(log: Log, path: Path, units: Mapping[str, str]) -> None:
    """Write the numeric columns of ``log`` (estimates) as one MDF4 channel group, each channel with
    its unit from ``units`` ("-" for a ratio or a code), atomically (a temporary file next to
    ``path`` renamed into place)."""
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    mdf.append([Signal(np.asarray(values, dtype=float), log["t"], name=name, unit=units.get(name, ""))
                for name, values in log.columns.items() if name != "t"], common_timebase=True)
    write_atomic(path, lambda tmp: mdf.save(tmp, overwrite=True))
