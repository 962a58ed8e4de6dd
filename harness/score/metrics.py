"""Accuracy of estimates against ground truth, in the format of seed 000's Table 3.

e = estimate - truth over the samples that have ground truth; max |e|, mean |e| and RMSE.
Reports show beta and r in degrees (deg, deg/s), vx and vy in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import SPIN_SIDESLIP, Log, LogError

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
    estimates must share."""

    def __init__(self, log_source: str, estimates_source: str, samples: int):
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
        if self.seen != self.samples:
            raise LogError(f"{self.estimates_source}: {self.seen} samples: expected the {self.samples} time stamps "
                           f"of {self.log_source}")
        units = {name: unit for name, _, unit, _ in SIGNALS}
        return [Score(name, units[name], n, peak, total / n, float(np.sqrt(square / n)))
                for name, (n, peak, total, square) in self.sums.items() if n]


SILENT_LIMIT = np.deg2rad(2.0)
"""rad: a sideslip error beyond this must be flagged by the status ("never silently wrong")."""
SILENT_DURATION = 0.5
"""s: the longest an error beyond :data:`SILENT_LIMIT` may last with status 0."""


def silent_error_time(log: Log, estimates: Log, limit: float = SILENT_LIMIT) -> tuple[float, float]:
    """(longest stretch, its start) in s of consecutive samples with |beta - beta_ref| > ``limit``
    (rad) and status 0, before the car spins (|beta_ref| > 15 deg from then on is not scored): the
    "never silently wrong" rule asks this to stay within :data:`SILENT_DURATION`. A sample with a
    non-finite estimate counts as wrong."""
    spun = np.maximum.accumulate(np.abs(log["beta_ref"]) > SPIN_SIDESLIP)
    return longest_silent_stretch(log["t"], estimates["beta"] - log["beta_ref"], estimates["status"], spun, limit)


def longest_silent_stretch(t: np.ndarray, error: np.ndarray, status: np.ndarray, excluded: np.ndarray,
                           limit: float = SILENT_LIMIT) -> tuple[float, float]:
    """(longest stretch, its start) in s of consecutive samples at times ``t`` where |``error``|
    exceeds ``limit`` (or is not finite) with ``status`` 0, the ``excluded`` samples left out."""
    silent = (~(np.abs(error) <= limit)) & (status == 0) & ~excluded
    longest, start, run_start = 0.0, float("nan"), None
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    for k, bad in enumerate(np.append(silent, False)):
        if bad and run_start is None:
            run_start = k
        elif not bad and run_start is not None:
            length = t[k - 1] - t[run_start] + step
            if length > longest:
                longest, start = length, float(t[run_start])
            run_start = None
    return longest, start


def score_case(config, case, seed: int, names: tuple[str, ...]) -> tuple[dict, dict[str, list[Score]]]:
    """(the run's notes, per estimator its scores against the truth) of scenario ``case``
    (``harness.sim.scenarios.Case``) with sensor-noise ``seed``, each estimator's generated C run over
    the log: one job of a Monte-Carlo sweep on the cluster (workers need only vsegen installed)."""
    log = case.simulate(config, 1.0 / config.sample_time, seed)
    return dict(log.notes), {name: score(log, run_estimator(config, name, log)) for name in names}
