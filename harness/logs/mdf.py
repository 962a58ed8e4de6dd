"""ASAM MDF4 logs (.mf4, .mdf) via asammdf: the mapped channels, each at its own rate, brought
causally onto the estimator's sample grid; estimates written as MDF4."""

from __future__ import annotations

import gc
import sys
from pathlib import Path

import numpy as np

from vsegen.harness.logs.channels import ChannelMap
from vsegen.harness.logs.table import OPTIONAL_INPUTS, REQUIRED, TRUTH, Log, LogError, latest_samples
from vsegen.harness.project.files import write_atomic

SUFFIXES = (".mf4", ".mdf")


def _open(path: Path):
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
    look-ahead); a channel older than MAX_GAP at a tick gives NaN there (the estimators hold)."""
    mdf = _open(path)
    series = {}
    for name in (*REQUIRED[1:], *OPTIONAL_INPUTS, *TRUTH):
        column = channels.column(name)
        if column.channel not in mdf.channels_db:
            if name in REQUIRED:
                raise LogError(f"{path}: missing channel '{column.channel}' for column '{name}': expected it in the "
                               f"file or another channel named in the channel map ({channels.source})")
            continue
        signal = mdf.get(column.channel)
        series[name] = (np.asarray(signal.timestamps, dtype=float),
                        np.asarray(signal.samples, dtype=float) * column.scale)
    start = max(t[0] for name, (t, _) in series.items() if name in REQUIRED)
    stop = min(t[-1] for name, (t, _) in series.items() if name in REQUIRED)
    ticks = start + sample_time * np.arange(int(np.floor((stop - start) / sample_time + 1e-9)) + 1)
    if len(ticks) < 2:
        raise LogError(f"{path}: the required channels overlap for {stop - start:.3g} s: expected at least "
                       f"two samples of {sample_time:g} s")
    columns = {"t": ticks}
    for name, (t, values) in series.items():
        latest, stale = latest_samples(t, ticks)
        columns[name] = np.where(stale, np.nan, values[latest])
    rates = ", ".join(f"{name} {1.0 / np.median(np.diff(t)):.4g} Hz" for name, (t, _) in series.items() if len(t) > 1)
    notes = {"resampled": f"MDF4 channels ({rates}) taken causally onto a uniform {sample_time * 1e3:g} ms grid"}
    return Log(columns, str(path), notes)


def write_mdf(log: Log, path: Path) -> None:
    """Write the numeric columns of ``log`` (estimates) as one MDF4 channel group, atomically (a
    temporary file next to ``path`` renamed into place)."""
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    mdf.append([Signal(np.asarray(values, dtype=float), log["t"], name=name)
                for name, values in log.columns.items() if name != "t"], common_timebase=True)
    write_atomic(path, lambda tmp: mdf.save(tmp, overwrite=True))
