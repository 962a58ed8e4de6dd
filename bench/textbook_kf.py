"""The textbook baseline of the real-data benchmark: the linear Kalman filter that ships with the
Revs dataset (estimators/matlab_kf/BetaStanfordLinear.m of MBDS/sideslip-angle-vehicle-estimation),
written again here in NumPy.

State [beta, r]; Euler-discretised linear bicycle model at the previous sample's speed; measurements
[a_y, r] with the feed-through of delta; process noise on the steering input only,
Q_d = B_d B_d' sigma_delta^2 (fully correlated between beta and r: an uncertain front-axle force);
measurement noise and sigma_delta from the standard deviations of the high-passed calibration
signals (an equiripple high-pass with stop band to 0.15, pass band from 0.25 of Nyquist), sigma_delta
scaled by 1000 as in the source. Stiffnesses either as the source picks them by hand or fitted by
least squares to the reference slip angles and axle forces of the calibration part in the linear
range.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter, remez

HAND_PICKED = (70000.0, 120000.0)
"""N/rad: the source's C_f, C_r."""
LINEAR_RANGE = 4.0
"""m/s^2: the samples the stiffness fit uses (|a_y| below this)."""
DELTA_NOISE_SCALE = 1000.0
"""The source's factor on the high-passed steering angle's standard deviation."""


def high_pass_std(x: np.ndarray) -> float:
    """Standard deviation of ``x`` after the source's high-pass (the sensor-noise yardstick)."""
    taps = remez(101, [0.0, 0.075, 0.125, 0.5], [0.0, 1.0])
    return float(np.std(lfilter(taps, 1.0, x)))


def noise(log) -> tuple[float, float, float]:
    """(sigma_ay, sigma_r, sigma_delta) from a calibration log."""
    return high_pass_std(log["ay"]), high_pass_std(log["r"]), high_pass_std(log["delta"]) * DELTA_NOISE_SCALE


def fitted_stiffness(log, vehicle) -> tuple[float, float]:
    """(C_f, C_r) by least squares through the origin, F_y = C alpha per axle, over the linear-range
    samples of a log with a reference: slip angles from vy_ref, axle forces from m a_y and I_z r'."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    dt = log.sample_time
    delta, vx, ay, r, vy = (np.asarray(log[k]) for k in ("delta", "vx", "ay", "r", "vy_ref"))
    yaw_acceleration = np.gradient(r, dt)
    alpha_f, alpha_r = delta - (vy + a * r) / vx, -(vy - b * r) / vx
    force_f, force_r = (m * ay * b + iz * yaw_acceleration) / (a + b), (m * ay * a - iz * yaw_acceleration) / (a + b)
    linear = np.abs(ay) < LINEAR_RANGE
    return tuple(float(alpha[linear] @ force[linear] / (alpha[linear] @ alpha[linear]))
                 for alpha, force in ((alpha_f, force_f), (alpha_r, force_r)))


def run(log, vehicle, stiffness: tuple[float, float], sigmas: tuple[float, float, float]) -> np.ndarray:
    """beta (rad) of the textbook KF over ``log``, sample by sample."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    lf, lr = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cf, cr = stiffness
    s_ay, s_r, s_d = sigmas
    dt = log.sample_time
    delta, vx, ay, r = (np.asarray(log[k]) for k in ("delta", "vx", "ay", "r"))
    R = np.diag([s_ay**2, s_r**2])
    x, P = np.zeros(2), np.diag([1e4, 1e4])
    beta = np.zeros(len(vx))
    for i in range(1, len(vx)):
        u = vx[i - 1]
        Ad = np.array([[1 - dt * (cf + cr) / (m * u), -dt * (1 + (lf * cf - lr * cr) / (m * u * u))],
                       [-dt * (lf * cf - lr * cr) / iz, 1 - dt * (lf * lf * cf + lr * lr * cr) / (iz * u)]])
        Bd = dt * np.array([cf / (m * u), lf * cf / iz])
        C = np.array([[-(cf + cr) / m, -(lf * cf - lr * cr) / (m * vx[i])], [0.0, 1.0]])
        D = np.array([cf / m, 0.0])
        x = Ad @ x + Bd * delta[i - 1]
        P = Ad @ P @ Ad.T + np.outer(Bd, Bd) * s_d**2
        S = C @ P @ C.T + R
        K = P @ C.T @ np.linalg.inv(S)
        x = x + K @ (np.array([ay[i], r[i]]) - C @ x - D * delta[i])
        P = (np.eye(2) - K @ C) @ P
        beta[i] = x[0]
    return beta
