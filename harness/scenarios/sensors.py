"""Sensor model for simulated logs: seed 000 Table 2 white noise (biases compensated, the
default of shared/methods/README.md), optional single-sample gyro outliers; seeded."""

from __future__ import annotations

import numpy as np

GYRO_NOISE = np.deg2rad(1.0)
"""Yaw-rate noise 1 sigma (rad/s)."""
ACCEL_NOISE = 0.3
"""Accelerometer noise 1 sigma (m/s^2)."""
GYRO_OUTLIERS = ((2.0, 0.47), (7.0, 0.84))
"""Seed 000 Fig. 6b: (time s, value rad/s) of single-sample yaw-rate spikes."""


def add_noise(rng: np.random.Generator, ax, ay, r):
    """Measured ax, ay, r: truth plus Gaussian white noise."""
    return (ax + rng.normal(0.0, ACCEL_NOISE, len(ax)),
            ay + rng.normal(0.0, ACCEL_NOISE, len(ay)),
            r + rng.normal(0.0, GYRO_NOISE, len(r)))


def inject_gyro_outliers(t: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``r`` with each outlier replacing the sample nearest its time (if inside the log)."""
    r = r.copy()
    for time, value in GYRO_OUTLIERS:
        if t[0] <= time <= t[-1]:
            r[int(np.argmin(np.abs(t - time)))] = value
    return r
