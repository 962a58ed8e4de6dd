"""Unit sanity from the signals' physics: wrong units that pass the range checks.

In quasi-steady cornering a_y = r v_x (plus the roll share g k a_y, a few tens of percent at most)
and, in the tyres' linear range, delta = l r / v_x (1 + K_s v_x^2) with understeer of order one.
Ratios far from these are a unit or a signal mistake; the factor that explains them names the
likely cause (r in deg/s, v_x in km/h or mph, a_y in g, delta in degrees or as the steering-wheel
angle). Used by the CLI before running an estimator; ``--no-unit-check`` skips it.
"""

from __future__ import annotations

import math

import numpy as np

from vsegen.harness.logs.segments import SLOPE_WINDOW, derivative, smoothed
from vsegen.harness.logs.table import Log, LogError

MIN_SAMPLES = 100
"""Quasi-steady samples needed before judging (about a second at 100 Hz)."""
RELATIVE_RATE = 0.3
"""1/s: r and a_y count as quasi-steady where each changes by less than this share of itself per
second (in whatever unit it was logged, so a wrong unit does not hide the steady stretches; a
sliding or spinning car is not steady)."""
LATERAL_RATIO = (0.75, 1.5)
"""a_y / (r v_x) expected in quasi-steady cornering (roll adds up to ~30 %)."""
STEER_RATIO = (0.7, 3.0)
"""delta / (l r / v_x) expected with |a_y| below 4 m/s^2 (understeer up to 1 + K_s v_x^2 ~ 2)."""
LATERAL_CAUSES = (("column 'r' looks like deg/s", 180 / math.pi), ("column 'vx' looks like km/h", 3.6),
                  ("column 'vx' looks like mph", 2.23694), ("column 'ay' looks like g", 9.80665))
"""(cause, factor by which it shrinks a_y / (r v_x))."""
STEER_CAUSES = (("column 'delta' looks like degrees", 180 / math.pi),
                ("column 'delta' looks like the steering-wheel angle (ratio ~15; map it with factor = 1/ratio)", 15.0),
                ("column 'delta' looks like the steering-wheel angle in degrees", 15.0 * 180 / math.pi))
"""(cause, factor by which it grows delta / (l r / v_x))."""


def check_units(log: Log, wheelbase: float) -> None:
    """Raise LogError (one line: file, column, likely cause) when the log's physics says a unit is
    wrong; say nothing when the log has too little cornering to judge."""
    need = ("delta", "vx", "ay", "r")
    if any(name not in log for name in need):
        return
    delta, vx, ay, r = (np.asarray(log[name], dtype=float) for name in need)
    ok = np.isfinite(delta) & np.isfinite(vx) & np.isfinite(ay) & np.isfinite(r) & (np.abs(vx) > 5.0)
    window = max(5, int(round(SLOPE_WINDOW / log.sample_time)))
    steady = np.ones(len(r), dtype=bool)
    for signal in (r, ay):
        finite = np.where(np.isfinite(signal), signal, 0.0)
        level = np.abs(smoothed(finite, window))
        steady &= np.abs(derivative(finite, log.sample_time, window)) < RELATIVE_RATE * level
    if "mz" in log:  # a direct yaw moment turns the car without the steering
        steady &= np.abs(np.where(np.isfinite(log["mz"]), log["mz"], 0.0)) < 1.0
    turning = ok & steady & (np.abs(r) > 0.03) & (np.abs(r * vx) > 0.5)
    if turning.sum() >= MIN_SAMPLES:
        ratio = float(np.median(ay[turning] / (r[turning] * vx[turning])))
        if not LATERAL_RATIO[0] <= ratio <= LATERAL_RATIO[1]:
            raise LogError(f"{log.source}: a_y / (r v_x) = {ratio:.3g} in cornering: expected about 1; "
                           f"{_cause(ratio, LATERAL_CAUSES, invert=True)} (--no-unit-check to run anyway)")
    linear = turning & (np.abs(ay) < 4.0)
    if linear.sum() >= MIN_SAMPLES:
        ratio = float(np.median(delta[linear] / (wheelbase * r[linear] / vx[linear])))
        if not STEER_RATIO[0] <= ratio <= STEER_RATIO[1]:
            raise LogError(f"{log.source}: delta / (l r / v_x) = {ratio:.3g} in cornering: expected 1 to 2; "
                           f"{_cause(ratio, STEER_CAUSES)} (--no-unit-check to run anyway)")


def _cause(ratio: float, causes, invert: bool = False) -> str:
    """The cause whose factor brings ``ratio`` nearest to 1 (on a log scale)."""
    def miss(factor: float) -> float:
        return abs(math.log(abs(ratio) * (factor if invert else 1 / factor)))
    name, factor = min(causes, key=lambda cause: miss(cause[1]))
    return name if miss(factor) < 0.5 else "a unit or a sign is wrong"
