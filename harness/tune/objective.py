"""The rule by which ``vsegen tune`` ranks candidate settings, so it cannot trade robustness for an
average error.

For one candidate, each training log gives a score (its RMSE, largest or mean |error| of beta
against ``beta_ref``, or of r against ``r_ref``, in rad or rad/s) and, for a sideslip estimator, its
longest *silent* stretch (|beta error| > 2 deg with status 0; ``harness.score.metrics``). Then:

* **rejected** if silent for more than 0.5 s on any log (the "never silently wrong" rule);
* **score** = MEAN_WEIGHT x the mean over the logs + WORST_WEIGHT x the worst log, so one log
  cannot be sacrificed for the others;
* plus a **prior** that keeps the settings near the base values the file started from:
  PRIOR_WEIGHT x the base's score x the mean squared distance of the searched numbers from their
  base values (in decades for a log-scale setting, in half-ranges for a linear one) x
  REFERENCE_LOGS / the number of logs. Little data changes settings little: with one log the
  prior is four times as strong as with four.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vsegen.harness.score.metrics import SILENT_DURATION

MEAN_WEIGHT = 0.5
WORST_WEIGHT = 0.5
PRIOR_WEIGHT = 0.05
REFERENCE_LOGS = 4
REJECTED = math.inf


def combined(scores: Sequence[float]) -> float:
    """The mean and the worst of per-log scores, weighted (inf if any is not finite)."""
    values = np.asarray(scores, dtype=float)
    if values.size == 0 or not np.all(np.isfinite(values)):
        return REJECTED
    return float(MEAN_WEIGHT * np.mean(values) + WORST_WEIGHT * np.max(values))


def silent(stretches: Sequence[float]) -> bool:
    """Whether a longest silent stretch (s) of any log breaks the never-silently-wrong rule."""
    return any(s > SILENT_DURATION for s in stretches)


def distance(point: dict[str, float], base: dict[str, float], scales: dict[str, tuple[float, float, bool]]) -> float:
    """Mean squared distance of ``point`` from ``base`` over the searched numbers; ``scales`` gives
    each number's (low, high, log scale): decades on a log scale, half-ranges on a linear one."""
    if not point:
        return 0.0
    squares = []
    for label, value in point.items():
        low, high, log = scales[label]
        if log:
            reference = base[label] if base[label] > 0 else low
            squares.append((math.log10(value / reference)) ** 2)
        else:
            squares.append((2.0 * (value - base[label]) / (high - low)) ** 2)
    return float(np.mean(squares))


def prior(point_distance: float, base_score: float, logs: int) -> float:
    """The prior's penalty for a candidate at ``point_distance`` (see :func:`distance`)."""
    return PRIOR_WEIGHT * base_score * point_distance * REFERENCE_LOGS / max(logs, 1)


def ranked(scores: Sequence[float], stretches: Sequence[float], point_distance: float, base_score: float) -> float:
    """A candidate's rank value (lower is better; inf when rejected) from its per-log scores and
    silent stretches, its distance from the base and the base's combined score."""
    if silent(stretches):
        return REJECTED
    return combined(scores) + prior(point_distance, base_score, len(scores))
