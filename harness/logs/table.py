"""Logs: the CSV format of docs/conventions.md ("Log format"), for simulated and recorded logs alike.

A :class:`Log` is a set of equally long float columns with a constant sample time. The reader
rejects bad files with :class:`LogError`, one line naming the file, the line, the column and what
was expected. NaN, Inf and single out-of-range samples are accepted in the sensor
columns (estimators hold on them and report INVALID_INPUT), never in ``t``. Unknown columns are
kept as text and ignored. The writer writes to a temporary name and renames on success, so no
partial file is left behind.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vsegen.harness.project.files import read_user_text, write_text_atomic
from vsegen.model import signals

REQUIRED = (signals.TIME.name, *signals.REQUIRED_INPUTS)
"""Required columns: time and the required inputs (model.signals)."""
OPTIONAL_INPUTS = signals.OPTIONAL_INPUTS
ABSENT_MEANS = {e.name: e.absent_value for e in signals.INPUTS if e.absent_value is not None}
"""Optional inputs an estimator may read from a log without them, and the value they then have
(no direct yaw moment applied: mz = 0)."""
TRUTH = tuple(s.name for s in signals.TRUTH)
"""Optional ground truth, used only for scoring (model.signals)."""
SPIN_SIDESLIP = np.deg2rad(15.0)
"""A run whose true |beta| exceeds this (rad) has spun: simulated logs latch it in ``off_course``,
and scores leave spinning runs out of the never-silently-wrong rule."""
UNIT_CHECKS = {e.name: (e.signal.unit, e.unit_check) for e in signals.INPUTS if e.unit_check}
"""Range checks that catch wrong units: a column with more than UNIT_FRACTION of its finite samples
beyond the limit is rejected. Single glitches pass: the estimators reject them per sample."""
UNIT_FRACTION = 0.05
SAMPLE_TIME_JITTER = 1e-3
"""Relative deviation of every time step from the mean step below which a log counts as uniform
and is used as it is."""
MAX_GAP = 0.1
"""s: on the uniform grid of a jittered or gappy log, a tick whose latest sample is older than this
gets NaN in every numeric column (the estimators hold and report INVALID_INPUT; truth is not
scored there); shorter gaps hold the latest sample."""
GRID_DIGITS = 6
"""The step of a resampled log is rounded to whole microseconds (a logger's clock period)."""


class LogError(ValueError):
    """A log file is wrong; the message is one line naming file, line and column."""


@dataclass
class Log:
    """Columns of a log by name, in file order: float arrays for the known columns (docs/signals.md),
    text arrays for unknown ones; all of one length."""

    columns: dict[str, np.ndarray]
    source: str = "<memory>"
    notes: dict[str, str] = field(default_factory=dict)
    """What a simulation reports about its run (e.g. whether it stayed inside the cones)."""

    def __len__(self) -> int:
        return len(self.columns["t"])

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    @property
    def sample_time(self) -> float:
        """Mean time step in s."""
        t = self.columns["t"]
        return float((t[-1] - t[0]) / (len(t) - 1))

    def window(self, start: float | None, stop: float | None) -> Log:
        """The samples with start <= t <= stop (s; None: from the first / to the last); LogError
        when fewer than two remain."""
        if start is None and stop is None:
            return self
        t = self.columns["t"]
        keep = np.ones(len(t), dtype=bool)
        if start is not None:
            keep &= t >= start
        if stop is not None:
            keep &= t <= stop
        if keep.sum() < 2:
            raise LogError(f"{self.source}: time window {start} .. {stop} s holds {int(keep.sum())} sample(s): "
                           f"expected at least 2 inside {float(t[0]):.6g} .. {float(t[-1]):.6g} s")
        return Log({name: column[keep] for name, column in self.columns.items()}, self.source, dict(self.notes))

    def without_truth(self) -> Log:
        """The log without its ground-truth columns (:data:`TRUTH`): what a car without a reference
        sensor records."""
        return Log({k: v for k, v in self.columns.items() if k not in TRUTH}, self.source, dict(self.notes))

    def missing(self, names: tuple[str, ...]) -> list[str]:
        """The ``names`` this log cannot provide (absent and without an ABSENT_MEANS value)."""
        return [n for n in names if n not in self.columns and n not in ABSENT_MEANS]

    def matrix(self, names: tuple[str, ...]) -> np.ndarray:
        """The named columns side by side, shape (samples, len(names)); an absent optional input
        of ABSENT_MEANS is a constant column of its value."""
        samples = len(self.columns["t"])
        return np.column_stack([self.columns[n] if n in self.columns
                                else np.full(samples, ABSENT_MEANS[n]) for n in names]).astype(float)


def write_log(log: Log, path: Path) -> None:
    """Write ``log`` as CSV (17 significant digits, round-trips exactly), atomically."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    names = list(log.columns)
    writer.writerow(names)
    for row in zip(*(log.columns[n] for n in names)):
        writer.writerow([_format(v) for v in row])
    write_text_atomic(Path(path), buffer.getvalue())


def _format(value) -> str:
    if isinstance(value, str):
        return value
    return "nan" if math.isnan(value) else format(float(value), ".17g")


ESTIMATED = ("beta", "vy", "r")
"""Signals an estimates file can be scored on; it must have at least one."""


def read_log(path: Path, required: tuple[str, ...] = REQUIRED, all_numeric: bool = False,
             channels: Mapping[str, tuple[str, float]] | None = None) -> Log:
    """Read and validate a CSV log; raises :class:`LogError` (one line) on any problem. Columns
    not named by docs/conventions.md are kept as text unless ``all_numeric`` (an estimates file:
    every column numeric, and the inputs' unit range checks left out: an estimate is not an input).
    ``channels`` maps a logger's column name to (log column, factor to SI) (``harness.logs.channels``)."""
    source = str(path)
    text = read_user_text(path, LogError, "CSV log")
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or not any(cell.strip() for cell in rows[0]):
        raise LogError(f"{source}:1: empty file: expected a header row with columns {', '.join(required)}")
    logged = [cell.strip() for cell in rows[0]]
    mapped_from = {column: channel for channel, (column, _) in (channels or {}).items()}
    channels = {c: mapped for c, mapped in (channels or {}).items() if c in logged}
    header = [channels[cell][0] if cell in channels else cell for cell in logged]
    for name in header:
        if header.count(name) > 1:
            raise LogError(f"{source}:1: column '{name}' appears twice: expected unique column names")
    absent = [name for name in required if name not in header]
    unmapped = [f"'{mapped_from[n]}' for column '{n}'" for n in absent if mapped_from.get(n, n) != n]
    if unmapped:
        raise LogError(f"{source}:1: missing channel{'s' if len(unmapped) > 1 else ''} {', '.join(unmapped)} "
                       f"(channel map): expected {'them' if len(unmapped) > 1 else 'it'} among the logged columns "
                       f"{', '.join(logged)}")
    if absent:
        names = ", ".join(f"'{n}'" for n in absent)
        raise LogError(f"{source}:1: missing column{'s' if len(absent) > 1 else ''} {names}: expected the columns "
                       f"{', '.join(required)} (found {', '.join(header)})")
    data = [row for row in rows[1:]]
    while data and not any(cell.strip() for cell in data[-1]):
        data.pop()
    if len(data) < 2:
        raise LogError(f"{source}:{len(data) + 2}: only {len(data)} data row(s): expected at least 2")
    known = set(header) if all_numeric else set(REQUIRED) | set(OPTIONAL_INPUTS) | set(TRUTH)
    cells: list[list] = [[] for _ in header]
    for index, row in enumerate(data):
        line = index + 2
        if len(row) != len(header):
            raise LogError(f"{source}:{line}: {len(row)} cells: expected {len(header)} (one per "
                           f"header column; is the file truncated?)")
        for col, cell in enumerate(row):
            name = header[col]
            cells[col].append(_parse(cell, source, line, name) if name in known else cell)
    log = Log({name: np.array(cells[i], dtype=float if name in known else str)
               for i, name in enumerate(header)}, source)
    for name, scale in channels.values():
        log.columns[name] = log.columns[name] * scale
    _check_increasing(log["t"], source)
    log = on_uniform_grid(log)
    if not all_numeric:
        ranges = UnitRanges(source)
        ranges.add(log.columns)
        ranges.check()
    return log


class UnitRanges:
    """The unit range checks (UNIT_CHECKS) of a log, counted over its columns whole or chunk by
    chunk (:meth:`add` in order): a column with more than UNIT_FRACTION of its finite samples
    beyond its limit is refused by :meth:`check` in one line naming the first such row."""

    def __init__(self, source: str):
        self.source = source
        self.seen = 0
        self.finite = dict.fromkeys(UNIT_CHECKS, 0)
        self.beyond = dict.fromkeys(UNIT_CHECKS, 0)
        self.first: dict[str, tuple[int, float]] = {}

    def add(self, columns: Mapping[str, np.ndarray]) -> None:
        """The next rows of the log's columns (any subset; the others are not checked)."""
        for name, (_, check) in UNIT_CHECKS.items():
            if name in columns:
                finite = np.isfinite(columns[name])
                beyond = finite & (np.abs(columns[name]) > check.limit)
                self.finite[name] += int(finite.sum())
                self.beyond[name] += int(beyond.sum())
                if name not in self.first and beyond.any():
                    i = int(np.flatnonzero(beyond)[0])
                    self.first[name] = (self.seen + i, float(columns[name][i]))
        self.seen += len(next(iter(columns.values())))

    def check(self) -> None:
        """LogError (one line) for the first column beyond its unit check."""
        for name, (unit, check) in UNIT_CHECKS.items():
            if self.beyond[name] > UNIT_FRACTION * max(self.finite[name], 1):
                index, value = self.first[name]
                raise LogError(f"{self.source}:{index + 2}: column '{name}' = {value!r}: expected |{name}| <= "
                               f"{check.limit:g} {unit} (a larger value {check.hint}); {self.beyond[name]} of "
                               f"{self.finite[name]} samples are beyond it")


def _parse(cell: str, source: str, line: int, column: str) -> float:
    text = cell.strip()
    try:
        value = float(text)
    except ValueError:
        shown = text if len(text) <= 30 else text[:27] + "..."
        raise LogError(f"{source}:{line}: column '{column}': {shown!r} is not a number: expected a "
                       f"decimal number (write nan for a missing sample)") from None
    if column == "t" and not math.isfinite(value):
        raise LogError(f"{source}:{line}: column 't' = {text}: expected a finite time in s")
    return value


def _check_increasing(t: np.ndarray, source: str) -> None:
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise LogError(f"{source}:{i + 2}: column 't' = {float(t[i])!r} after {float(t[i - 1])!r}: expected "
                       f"strictly increasing time")


def on_uniform_grid(log: Log) -> Log:
    """``log`` itself when its time steps are uniform (within SAMPLE_TIME_JITTER); otherwise the log
    on a uniform grid at its fitted step T (:func:`fitted_step`), taken causally: each tick gets the
    latest sample at or before it, never a later one. The grid lags the fitted clock by the largest
    late jitter, so a sample stamped a little late still lands on its own tick; across gaps longer
    than MAX_GAP the numeric columns are NaN. ``notes`` say what was done and where the gaps are."""
    t = log["t"]
    steps = np.diff(t)
    mean = (t[-1] - t[0]) / (len(t) - 1)
    if np.all(np.abs(steps - mean) <= SAMPLE_TIME_JITTER * mean):
        return log
    nominal, start, residual = fitted_step(t)
    late = float(np.clip(residual.max(), 0.0, 0.49 * nominal))
    ticks = start + late + nominal * np.arange(int(np.floor((t[-1] - start - late) / nominal)) + 1)
    latest, stale = latest_samples(t, ticks)
    columns = {}
    for name, column in log.columns.items():
        values = column[latest]
        if name != "t" and values.dtype.kind == "f":
            values = np.where(stale, np.nan, values)
        columns[name] = values
    columns["t"] = ticks
    jitter = float(residual.max() - residual.min()) / 2
    step = f"{nominal * 1e3:.6g} ms"
    notes = {**log.notes, "resampled": f"time steps not uniform (jitter +-{jitter * 1e3:.3g} ms around a {step} "
                                       f"step): taken causally onto a uniform {step} grid, {len(t)} samples -> "
                                       f"{len(ticks)} ticks"}
    gaps = [(float(ticks[run.start]), float(ticks[run.stop - 1])) for run in runs(stale)]
    if gaps:
        notes["gaps"] = gap_note(gaps)
    return Log(columns, log.source, notes)


def fitted_step(t: np.ndarray) -> tuple[float, float, np.ndarray]:
    """(step T rounded to GRID_DIGITS, start, residuals) of jittered time stamps ``t`` (s): each
    consecutive pair of samples is a whole number of ticks apart (rounded locally, so an error in
    the first guess of T never accumulates over a long log), then T and the start are the least
    squares line through the stamps over their tick numbers; the residuals are each stamp's
    offset from it (its jitter)."""
    steps = np.diff(t)
    nominal = float(np.median(steps))
    for _ in range(3):
        ticks = np.concatenate([[0.0], np.cumsum(np.maximum(np.round(steps / nominal), 1.0))])
        nominal, start = (float(c) for c in np.polyfit(ticks, t, 1))
    nominal = round(nominal, GRID_DIGITS)
    start = float(np.mean(t - nominal * ticks))
    return nominal, start, t - (start + nominal * ticks)


def gap_note(gaps: list[tuple[float, float]]) -> str:
    """The note of the gaps (start, end in s) on a log's grid where the estimators hold."""
    return (f"{len(gaps)} gap(s) longer than {MAX_GAP:g} s, estimators hold there: "
            + ", ".join(f"{a:.3f}..{b:.3f} s" for a, b in gaps[:5]) + (" ..." if len(gaps) > 5 else ""))


def latest_samples(t: np.ndarray, ticks: np.ndarray, tolerance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(index of the latest sample at or before each tick, whether that sample is missing or older
    than MAX_GAP): the causal rule every resampling uses (no look-ahead); a sample stamped within
    ``tolerance`` (s) after a tick counts as at it (a clock's rounding). Indices of ticks before
    the first sample are 0 and stale."""
    latest = np.searchsorted(t, ticks + tolerance, side="right") - 1
    stale = (latest < 0) | (ticks - t[np.maximum(latest, 0)] > MAX_GAP)
    return np.maximum(latest, 0), stale


def runs(mask: np.ndarray) -> list[slice]:
    """The contiguous runs where ``mask`` is true, as slices."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], np.asarray(mask, dtype=np.int8), [0]))))
    return [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]
