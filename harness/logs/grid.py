"""Channels recorded at their own rates and times (MDF4 channels, decoded CAN signals) brought
causally onto a uniform grid at the estimator's sample time, chunk by chunk.

The grid starts at the latest first sample of the required channels and ends at the earliest last
one. Each tick takes each channel's latest sample at or before it (no look-ahead); a stamp within
CLOCK_TOLERANCE of a tick counts as at it (a logger's clock rounding, e.g. a BLF's nanoseconds
read back through an absolute time in s). A channel older than MAX_GAP at a tick is NaN there (the
estimators hold), and the source's notes say where, once it has been read.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping

import numpy as np

from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import REQUIRED, Log, LogError, gap_note, latest_samples, runs

CLOCK_TOLERANCE = 1e-4
"""A sample stamped within this fraction of a step after a tick counts as at the tick."""


class GridChannel:
    """A channel read forward in pieces (:meth:`more`), brought onto increasing grid ticks; ``start``
    and ``stop`` are its first and last time stamps (s), ``rate`` its rate (Hz, 0 if unknown), and
    ``scale`` multiplies its values (the channel map's factor to SI)."""

    def __init__(self, start: float, stop: float, rate: float, scale: float):
        self.start, self.stop, self.rate, self.scale = start, stop, rate, scale
        self.rewind()

    def rewind(self) -> None:
        """Back to the first sample."""
        self.t = np.empty(0)
        self.values = np.empty(0)
        self.restart()

    def restart(self) -> None:
        """Subclasses: reading starts again from the first sample."""

    def more(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Subclasses: the next piece (times in s, values), None at the end."""
        raise NotImplementedError

    def at(self, ticks: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
        """(values at ``ticks``, NaN where stale; whether stale)."""
        while not self.t.size or self.t[-1] <= ticks[-1] + tolerance:
            piece = self.more()
            if piece is None:
                break
            self.t = np.concatenate((self.t, np.asarray(piece[0], dtype=float)))
            self.values = np.concatenate((self.values, np.asarray(piece[1], dtype=float) * self.scale))
        latest, stale = latest_samples(self.t, ticks, tolerance)
        values = np.where(stale, np.nan, self.values[latest])
        keep = int(latest[-1])
        self.t, self.values = self.t[keep:], self.values[keep:]
        return values, stale


class SeriesChannel(GridChannel):
    """A channel held in memory: time stamps (s, increasing) and values."""

    def __init__(self, t: np.ndarray, values: np.ndarray, scale: float = 1.0):
        self.series = (np.asarray(t, dtype=float), np.asarray(values, dtype=float))
        rate = 1.0 / float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        super().__init__(float(t[0]), float(t[-1]), rate, scale)

    def restart(self) -> None:
        self.pending = True

    def more(self) -> tuple[np.ndarray, np.ndarray] | None:
        if not self.pending:
            return None
        self.pending = False
        return self.series


def grid_source(source: str, found: Mapping[str, GridChannel], sample_time: float,
                window: tuple[float | None, float | None], what: str) -> LogSource:
    """The log columns ``found`` (column -> channel) on the uniform grid of ``sample_time`` s over
    the span every required channel covers, cut to ``window`` (s), as a source of chunks; ``what``
    names the channels in the note that says so ("MDF4 channels", "CAN signals")."""
    start = max(c.start for name, c in found.items() if name in REQUIRED)
    stop = min(c.stop for name, c in found.items() if name in REQUIRED)
    tolerance = CLOCK_TOLERANCE * sample_time
    ticks = int(np.floor((stop - start + tolerance) / sample_time)) + 1 if stop >= start else 0
    first_tick, ticks = _window_ticks(start, sample_time, ticks, window)
    if ticks < 2:
        raise LogError(f"{source}: the required channels overlap for {max(stop - start, 0.0):.3g} s: expected at "
                       f"least two samples of {sample_time:g} s")
    rates = ", ".join(f"{name} {c.rate:.4g} Hz" for name, c in found.items() if c.rate)
    notes = {"resampled": f"{what} ({rates}) taken causally onto a uniform {sample_time * 1e3:g} ms grid"}

    def chunks(rows: int, names: tuple[str, ...]) -> Iterator[Log]:
        for channel in found.values():
            channel.rewind()
        gaps = []
        for begin in range(0, ticks, rows):
            t = start + sample_time * (first_tick + np.arange(begin, min(begin + rows, ticks)))
            columns, stale_any = {"t": t}, np.zeros(len(t), dtype=bool)
            for name, channel in found.items():
                if name in names or name in REQUIRED:
                    values, stale = channel.at(t, tolerance)
                    stale_any |= stale if name in REQUIRED else False
                    if name in names:
                        columns[name] = values
            gaps += [(float(t[run.start]), float(t[run.stop - 1])) for run in runs(stale_any)]
            yield Log(columns, source)
        if gaps:
            notes["gaps"] = gap_note(_joined(gaps, sample_time))

    return LogSource(source, sample_time, ticks, ("t", *found), chunks, notes)


def _window_ticks(start: float, step: float, ticks: int, window: tuple[float | None, float | None]) -> tuple[int, int]:
    """(first tick, number of ticks) of a grid ``start + step * k``, k < ``ticks``, inside ``window``
    (found arithmetically, then nudged so the test is the grid's own ``start + step * k``)."""
    first, last = 0, ticks - 1
    if window[0] is not None:
        first = max(first, math.ceil((window[0] - start) / step))
        while first > 0 and start + step * (first - 1) >= window[0]:
            first -= 1
        while first <= last and start + step * first < window[0]:
            first += 1
    if window[1] is not None:
        last = min(last, math.floor((window[1] - start) / step))
        while last < ticks - 1 and start + step * (last + 1) <= window[1]:
            last += 1
        while last >= first and start + step * last > window[1]:
            last -= 1
    return (first, last - first + 1) if last >= first else (0, 0)


def _joined(gaps: list[tuple[float, float]], step: float) -> list[tuple[float, float]]:
    """Gaps split at chunk boundaries joined again."""
    joined = [gaps[0]]
    for a, b in gaps[1:]:
        if a - joined[-1][1] <= 1.5 * step:
            joined[-1] = (joined[-1][0], b)
        else:
            joined.append((a, b))
    return joined
