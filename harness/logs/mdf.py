"""ASAM MDF4 logs (.mf4, .mdf) via asammdf: the mapped channels, each at its own rate, brought
causally onto the estimator's sample grid; estimates written as MDF4."""

from __future__ import annotations

import gc
import sys
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from vsegen.harness.logs.channels import ChannelMap, file_unit_conflict
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
    """The log columns of an MDF4 file on a uniform grid of ``sample_time`` s over the span every
    required channel covers: each tick takes each channel's latest sample at or before it (no
    look-ahead); a channel older than MAX_GAP at a tick gives NaN there (the estimators hold), and
    the notes say where. Every missing required channel is named at once; a channel name found in
    several groups must be chosen by the map's ``group`` or ``message``."""
    mdf = open_mdf(path)
    series, missing = {}, []
    for name in (*REQUIRED[1:], *OPTIONAL_INPUTS, *TRUTH):
        column = channels.column(name)
        if column.channel not in mdf.channels_db:
            if name in REQUIRED:
                missing.append(f"'{column.channel}' for column '{name}'")
            continue
        signal = mdf.get(column.channel, *_occurrence(mdf, path, column, channels.source))
        written = file_unit_conflict(column, str(signal.unit or ""))
        if written:
            raise LogError(f"{path}: channel '{column.channel}' is in {written} (the file's unit), the channel map "
                           f"reads it as {column.unit}: expected unit = \"{written}\" in [columns.{name}] of "
                           f"{channels.source}")
        series[name] = (np.asarray(signal.timestamps, dtype=float),
                        np.asarray(signal.samples, dtype=float) * column.scale)
    if missing:
        raise LogError(f"{path}: missing channel{'s' if len(missing) > 1 else ''} {', '.join(missing)}: expected "
                       f"{'them' if len(missing) > 1 else 'it'} in the file or other channels named in the channel "
                       f"map ({channels.source})")
    start = max(t[0] for name, (t, _) in series.items() if name in REQUIRED)
    stop = min(t[-1] for name, (t, _) in series.items() if name in REQUIRED)
    ticks = start + sample_time * np.arange(int(np.floor((stop - start) / sample_time + 1e-9)) + 1)
    if len(ticks) < 2:
        raise LogError(f"{path}: the required channels overlap for {stop - start:.3g} s: expected at least "
                       f"two samples of {sample_time:g} s")
    columns, gaps = {"t": ticks}, np.zeros(len(ticks), dtype=bool)
    for name, (t, values) in series.items():
        latest, stale = latest_samples(t, ticks)
        columns[name] = np.where(stale, np.nan, values[latest])
        gaps |= stale if name in REQUIRED else False
    rates = ", ".join(f"{name} {1.0 / np.median(np.diff(t)):.4g} Hz" for name, (t, _) in series.items() if len(t) > 1)
    notes = {"resampled": f"MDF4 channels ({rates}) taken causally onto a uniform {sample_time * 1e3:g} ms grid"}
    spans = [(float(ticks[run.start]), float(ticks[run.stop - 1])) for run in runs(gaps)]
    if spans:
        notes["gaps"] = gap_note(spans)
    return Log(columns, str(path), notes)


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
