"""Which samples of ordinary driving logs excite which parameter.

Every selector returns a boolean mask over a log's samples. Derivatives are taken of signals
smoothed over ``SMOOTHING`` seconds (a centred moving average), so sensor noise does not decide
whether a sample counts as steady. Units SI, signs as in docs/conventions.md.
"""

from __future__ import annotations

import numpy as np

from vsegen.harness.logs.table import Log, runs

MIN_SPEED = 5.0
"""m/s: below this the wheel-speed v_x and the bicycle model are too coarse to identify from."""
SMOOTHING = 0.3
"""s, window of the moving average that decides levels (|delta|, |a_y|)."""
SLOPE_WINDOW = 1.0
"""s, window of the local fit that gives rates (dr/dt, da_y/dt): long enough that sensor noise
(seed 000 Table 2) moves them well below the steadiness limits."""
STRAIGHT_STEER = 0.004
"""rad: |delta| below this counts as driving straight ahead."""
STRAIGHT_LATERAL = 0.4
"""m/s^2: |a_y| below this counts as driving straight ahead."""
CORNERING = 2.0
"""m/s^2: |a_y| above this counts as cornering (roll is then large enough to measure)."""
STEADY_YAW_ACCELERATION = 0.03
"""rad/s^2: |dr/dt| below this counts as quasi-steady."""
STEADY_LATERAL_JERK = 0.3
"""m/s^3: |da_y/dt| below this counts as quasi-steady."""
LINEAR_LATERAL = 4.0
"""m/s^2: |a_y| below this keeps the tyres in their linear range (bicycle-model fits)."""
MIN_RUN = 1.0
"""s: a selection shorter than this (contiguous) is dropped."""


def smoothed(x: np.ndarray, samples: int) -> np.ndarray:
    """Centred moving average over ``samples`` (odd window; edges use the nearest value)."""
    window = max(1, samples | 1)
    padded = np.pad(np.asarray(x, dtype=float), window // 2, mode="edge")
    return np.convolve(padded, np.full(window, 1.0 / window), mode="valid")


def derivative(x: np.ndarray, dt: float, samples: int) -> np.ndarray:
    """d/dt of ``x``: slope of a local quadratic over ``samples`` (Savitzky-Golay)."""
    window = max(5, samples | 1)
    from scipy.signal import savgol_filter  # here: scipy.signal is slow to import

    return savgol_filter(x, min(window, (len(x) - 1) | 1 if len(x) % 2 == 0 else len(x)), 2, deriv=1,
                         delta=dt, mode="interp")


def finite(log: Log, names: tuple[str, ...]) -> np.ndarray:
    """Samples where every named column is finite."""
    return np.all(np.isfinite(log.matrix(names)), axis=1)


def long_runs(mask: np.ndarray, samples: int) -> np.ndarray:
    """``mask`` with its contiguous runs shorter than ``samples`` removed."""
    out = np.zeros_like(mask)
    for run in runs(mask):
        if run.stop - run.start >= samples:
            out[run] = True
    return out


def _window(log: Log) -> int:
    return int(round(SMOOTHING / log.sample_time))


def straight(log: Log) -> np.ndarray:
    """Straight driving at speed: small steer angle and lateral acceleration, for offsets and noise."""
    w = _window(log)
    ok = finite(log, ("delta", "vx", "ax", "ay", "r")) & (np.nan_to_num(log["vx"]) > MIN_SPEED)
    mask = ok & (np.abs(smoothed(np.nan_to_num(log["delta"]), w)) < STRAIGHT_STEER) \
        & (np.abs(smoothed(np.nan_to_num(log["ay"]), w)) < STRAIGHT_LATERAL)
    return long_runs(mask, int(round(MIN_RUN / log.sample_time)))


def steady_cornering(log: Log, low: float = CORNERING, high: float = np.inf) -> np.ndarray:
    """Quasi-steady cornering with low <= |a_y| < high: yaw rate and a_y nearly constant."""
    w, dt = _window(log), log.sample_time
    slope = int(round(SLOPE_WINDOW / dt))
    ok = finite(log, ("delta", "vx", "ay", "r")) & (np.nan_to_num(log["vx"]) > MIN_SPEED)
    ay, r = np.nan_to_num(log["ay"]), np.nan_to_num(log["r"])
    level = np.abs(smoothed(ay, w))
    mask = ok & (level >= low) & (level < high) \
        & (np.abs(derivative(r, dt, slope)) < STEADY_YAW_ACCELERATION) \
        & (np.abs(derivative(ay, dt, slope)) < STEADY_LATERAL_JERK)
    return long_runs(mask, int(round(0.5 / dt)))


def linear_driving(log: Log) -> np.ndarray:
    """Driving at speed with the tyres in their linear range (for the bicycle-model fit)."""
    w = _window(log)
    ok = finite(log, ("delta", "vx", "ay", "r")) & (np.nan_to_num(log["vx"]) > MIN_SPEED)
    mask = ok & (np.abs(smoothed(np.nan_to_num(log["ay"]), w)) < LINEAR_LATERAL)
    return long_runs(mask, int(round(2.0 / log.sample_time)))
