"""Accuracy of estimates against ground truth, in the format of seed 000's Table 3.

e = estimate - truth over the samples that have ground truth; max |e|, mean |e| and RMSE.
Reports show beta and r in degrees (deg, deg/s), vx and vy in m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.logs import Log, LogError
from harness.run import run_estimator

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
    if len(log) != len(estimates) or not np.allclose(log["t"], estimates["t"], rtol=0, atol=1e-9):
        raise LogError(f"{estimates.source}:2: column 't': expected the same time stamps as "
                       f"{log.source} ({len(log)} samples)")
    if "beta_ref" not in log:
        raise LogError(f"{log.source}:1: missing column 'beta_ref': expected ground truth to score")
    scores = []
    for name, truth, unit, factor in SIGNALS:
        if name in estimates and truth in log:
            e = errors(estimates[name], log[truth]) * factor
            if e.size:
                scores.append(Score(name, unit, e.size, float(np.abs(e).max()),
                                    float(np.abs(e).mean()), float(np.sqrt(np.mean(e * e)))))
    return scores


def score_case(config, case, seed: int, names: tuple[str, ...]) -> tuple[dict, dict[str, list[Score]]]:
    """(the run's notes, per estimator its scores against the truth) of scenario ``case``
    (``harness.scenarios.Case``) with sensor-noise ``seed``, each estimator's generated C run over
    the log: one job of a Monte-Carlo sweep on the cluster (workers need only vsegen installed)."""
    log = case.simulate(config, 1.0 / config.sample_time, seed)
    return dict(log.notes), {name: score(log, run_estimator(config, name, log)) for name in names}
