"""Accuracy of estimates against ground truth, in the format of seed 000's Table 3.

e = estimate - truth over the samples that have ground truth; max |e|, mean |e| and RMSE.
Reports show beta and r in degrees (deg, deg/s), vx and vy in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import SPIN_SIDESLIP, Log, LogError, runs

SIGNALS = (  # estimate column, truth column, report unit, factor from SI
    ("beta", "beta_ref", "deg", 180.0 / np.pi),
    ("vx", "vx_ref", "m/s", 1.0),
    ("vy", "vy_ref", "m/s", 1.0),
    ("r", "r_ref", "deg/s", 180.0 / np.pi),
)


@dataclass(frozen=True)
class Score:
    signal: str
    unit: str
    samples: int
    max: float
    mean: float
    rmse: float


def errors(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """e over the samples where both are finite."""
    keep = np.isfinite(estimate) & np.isfinite(truth)
    return estimate[keep] - truth[keep]


def score(log: Log, estimates: Log) -> list[Score]:
    """Scores of every estimated signal that has ground truth in ``log``."""
    scores = ScoreSums(log.source, estimates.source, len(log))
    scores.add(log, estimates)
    return scores.result()


def score_sources(log: LogSource, estimates: LogSource) -> ScoreSums:
    """:func:`score` of a log and its estimates read chunk by chunk (``harness.logs.stream``)."""
    sums = ScoreSums(log.source, estimates.source, log.samples)
    if estimates.samples != log.samples:
        raise LogError(f"{estimates.source}:2: column 't': expected the same time stamps as {log.source} "
                       f"({log.samples} samples; found {estimates.samples})")
    for log_chunk, estimates_chunk in zip(log.chunks(), estimates.chunks()):
        sums.add(log_chunk, estimates_chunk)
    return sums


class ScoreSums:
    """:func:`score` over a log and its estimates read in chunks (:meth:`add` per pair of chunks of
    equal length, in order; :meth:`result` at the end): sums of |e| and e^2 and the largest |e|
    per signal, so memory does not grow with the log. ``samples`` is the log's length, which the
    estimates must share (None: not known ahead, not checked)."""

    def __init__(self, log_source: str, estimates_source: str, samples: int | None = None):
        self.log_source, self.estimates_source, self.samples = log_source, estimates_source, samples
        self.sums: dict[str, list[float]] = {}
        self.seen = 0
        self.first_off_course: float | None = None

    def add(self, log: Log, estimates: Log) -> None:
        """The next chunk of the log and of its estimates."""
        if len(log) != len(estimates) or not np.allclose(log["t"], estimates["t"], rtol=0, atol=1e-9):
            raise LogError(f"{self.estimates_source}:{self.seen + 2}: column 't': expected the same time stamps as "
                           f"{self.log_source} ({self.samples} samples)")
        if "beta_ref" not in log:
            raise LogError(f"{self.log_source}:1: missing column 'beta_ref': expected ground truth to score")
        self.seen += len(log)
        for name, truth, _, factor in SIGNALS:
            if name in estimates and truth in log:
                e = errors(estimates[name], log[truth]) * factor
                sums = self.sums.setdefault(name, [0, 0.0, 0.0, 0.0])
                if e.size:
                    sums[0] += e.size
                    sums[1] = max(sums[1], float(np.abs(e).max()))
                    sums[2] += float(np.abs(e).sum())
                    sums[3] += float(np.dot(e, e))
        if self.first_off_course is None and "off_course" in log and np.any(log["off_course"] > 0):
            self.first_off_course = float(log["t"][np.argmax(log["off_course"] > 0)])

    def result(self) -> list[Score]:
        """The scores; LogError when the estimates were shorter or longer than the log."""
        if self.samples is not None and self.seen != self.samples:
            raise LogError(f"{self.estimates_source}: {self.seen} samples: expected the {self.samples} time stamps "
                           f"of {self.log_source}")
        units = {name: unit for name, _, unit, _ in SIGNALS}
        return [Score(name, units[name], n, peak, total / n, float(np.sqrt(square / n)))
                for name, (n, peak, total, square) in self.sums.items() if n]


SILENT_LIMIT = np.deg2rad(2.0)
"""rad: a sideslip error beyond this must be flagged by the status ("never silently wrong")."""
SILENT_DURATION = 0.5
"""s: the longest an error beyond :data:`SILENT_LIMIT` may last with status 0."""


BETTER_THAN_ZERO = 0.7
"""An unflagged sideslip estimate must score an RMSE within this share of RMS(beta_ref) over the same
samples (or within :data:`ZERO_FLOOR`): else answering beta = 0 would do about as well."""
ZERO_FLOOR = np.deg2rad(0.1)
"""rad: the RMSE every unflagged estimate may have, however straight the driving."""


def worse_than_zero(log: Log, estimates: Log) -> tuple[float, float] | None:
    """None when the run beats answering beta = 0 ("better than zero, or flagged"): its beta RMSE
    is within max(BETTER_THAN_ZERO x RMS(beta_ref), ZERO_FLOOR), or it is within that bound over
    the samples with status 0 (the status covers where it is not). Else (RMSE, bound) in rad over
    those unflagged samples. Samples from a spin on are not scored."""
    kept = ~np.maximum.accumulate(np.abs(log["beta_ref"]) > SPIN_SIDESLIP)
    unflagged = kept & (estimates["status"] == 0)
    for part in (kept, unflagged):
        if not part.any():
            return None
        error = np.nan_to_num(estimates["beta"][part] - log["beta_ref"][part], nan=np.inf)
        rmse = float(np.sqrt(np.mean(error**2)))
        bound = float(max(BETTER_THAN_ZERO * np.sqrt(np.mean(log["beta_ref"][part] ** 2)), ZERO_FLOOR))
        if rmse <= bound:
            return None
    return rmse, bound


def silent_error_time(log: Log, estimates: Log, limit: float = SILENT_LIMIT) -> tuple[float, float]:
    """(longest stretch, its start) in s of consecutive samples with |beta - beta_ref| > ``limit``
    (rad) and status 0, before the car spins (|beta_ref| > 15 deg from then on is not scored): the
    "never silently wrong" rule asks this to stay within :data:`SILENT_DURATION`. A sample with a
    non-finite estimate counts as wrong."""
    stretch = SilentStretch(float(np.median(np.diff(log["t"]))) if len(log) > 1 else 0.0, limit)
    stretch.add(log["t"], estimates["beta"] - log["beta_ref"], estimates["status"], log["beta_ref"])
    return stretch.longest, stretch.start


def longest_silent_stretch(t: np.ndarray, error: np.ndarray, status: np.ndarray, excluded: np.ndarray,
                           limit: float = SILENT_LIMIT) -> tuple[float, float]:
    """(longest stretch, its start) in s of consecutive samples at times ``t`` where |``error``|
    exceeds ``limit`` (or is not finite) with ``status`` 0, the ``excluded`` samples left out."""
    stretch = SilentStretch(float(np.median(np.diff(t))) if len(t) > 1 else 0.0, limit)
    stretch.add(t, error, status, excluded=excluded)
    return stretch.longest, stretch.start


class SilentStretch:
    """The longest stretch of a log, fed in chunks (:meth:`add`, in order), with |error| above
    ``limit`` (rad; or not finite) and status 0: its length ``longest`` (s: last stamp - first
    stamp + ``step``) and ``start`` (s, NaN if none). A stretch may cross chunk boundaries."""

    def __init__(self, step: float, limit: float = SILENT_LIMIT):
        self.step, self.limit = step, limit
        self.longest, self.start = 0.0, float("nan")
        self.open_since: float | None = None
        self.spun = False

    def add(self, t: np.ndarray, error: np.ndarray, status: np.ndarray, reference: np.ndarray | None = None,
            excluded: np.ndarray | None = None) -> None:
        """The next chunk: time stamps (s), errors (rad), status; samples from the first with
        |``reference``| > 15 deg on (a spin, carried across chunks) or ``excluded`` are left out."""
        left_out = np.zeros(len(t), dtype=bool) if excluded is None else np.asarray(excluded, dtype=bool)
        if reference is not None:
            spun = np.maximum.accumulate(np.abs(reference) > SPIN_SIDESLIP) | self.spun
            self.spun = bool(spun[-1]) if len(spun) else self.spun
            left_out = left_out | spun
        silent = (~(np.abs(error) <= self.limit)) & (status == 0) & ~left_out
        for run in runs(silent):
            if run.start > 0 or self.open_since is None:
                self.open_since = float(t[run.start])
            length = float(t[run.stop - 1]) - self.open_since + self.step
            if length > self.longest:
                self.longest, self.start = length, self.open_since
        if not len(silent) or not silent[-1]:
            self.open_since = None
