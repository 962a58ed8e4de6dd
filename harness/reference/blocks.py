"""Reference building blocks in plain NumPy/SciPy: the bicycle model, discretisation, the Kalman
filter and the shared input-hold rule (docs/methods.md: the common rule; seed 000 §2.5, §2.10).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import lru_cache

import numpy as np
import scipy.linalg
import scipy.signal

GRAVITY = 9.81
"""m/s^2, as in the model."""
LOW_SPEED = 1
INVALID_INPUT = 2
REFERENCE_SUSPECT = 4
PARAMETERS_PROJECTED = 8
COVARIANCE_REPAIRED = 16
FILTER_RESTARTED = 32
KINEMATIC_DWELL_LIMITED = 64
MODEL_INCONSISTENT = 128
BEYOND_LINEAR_RANGE = 256
DEAD_RECKONING = 1024
INPUT_FROZEN = 2048
SCHEMES_DISAGREE = 4096
LATERAL_INCONSISTENT = 8192
STEERING_OFFSET = 16384
YAW_RATE_MISMATCH = 32768
"""The status bits the references raise, written here once (docs/signals.md); a test compares them
with the model's."""
LIMIT_OF = {"delta": "delta_max", "vx": "vx_max", "ax": "ax_max", "ay": "ay_max", "r": "r_max",
            "mz": "mz_max", "omega_fl": "omega_max", "omega_fr": "omega_max",
            "omega_rl": "omega_max", "omega_rr": "omega_max"}


def bicycle(vehicle: Mapping[str, float], vx: float):
    """A(vx), B, C(vx), D of the linear 2-DOF model, positive stiffness, x = [vy, r], y = [ay, r]."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cf, cr = vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"]
    A = np.array([
        [-(cf + cr) / (m * vx), (b * cr - a * cf) / (m * vx) - vx],
        [(b * cr - a * cf) / (iz * vx), -(a * a * cf + b * b * cr) / (iz * vx)],
    ])
    B = np.array([[cf / m], [a * cf / iz]])
    C = np.array([
        [-(cf + cr) / (m * vx), (b * cr - a * cf) / (m * vx)],
        [0.0, 1.0],
    ])
    D = np.array([[cf / m], [0.0]])
    return A, B, C, D


def discretise(method: str, A: np.ndarray, B: np.ndarray, T: float):
    """Phi, Gamma: "euler", "tustin" (bilinear) or "zoh" (augmented matrix exponential)."""
    n = A.shape[0]
    if method == "euler":
        return np.eye(n) + A * T, B * T
    if method == "tustin":
        left = np.eye(n) - A * T / 2
        return np.linalg.solve(left, np.eye(n) + A * T / 2), np.linalg.solve(left, B * T)
    if method == "zoh":
        augmented = np.zeros((n + B.shape[1], n + B.shape[1]))
        augmented[:n, :n] = A
        augmented[:n, n:] = B
        E = scipy.linalg.expm(augmented * T)
        return E[:n, :n], E[:n, n:]
    raise ValueError(method)


@lru_cache(maxsize=64)
def tustin(num: tuple[float, ...], den: tuple[float, ...], T: float) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of the analog filter num(s)/den(s) discretised by Tustin at sample time T
    (scipy.signal.bilinear), normalised so a[0] = 1; memoised, since a filter designed once per
    configuration is asked for at every step."""
    bz, az = scipy.signal.bilinear(num, den, fs=1.0 / T)
    bz, az = bz / az[0], az / az[0]
    bz.flags.writeable = az.flags.writeable = False
    return bz, az


def whole_samples(duration: float, T: float) -> int:
    """A duration (s) in whole samples of T (model.filters.whole_samples)."""
    return math.floor(duration / T + 0.5)


def held_flag(left: float, raised: bool, duration: float, T: float) -> tuple[float, bool]:
    """(samples left, flag): a flag held ``duration`` s after it was last raised
    (model.filters.held_flag, on an active sample)."""
    return (float(whole_samples(duration, T)) if raised else max(left - 1, 0.0)), raised or left > 0


def low_pass(previous: float, value: float, T: float, time_constant: float) -> float:
    """One step of the first-order low-pass y_k = y_k-1 + (1 - exp(-T / tau)) (x_k - y_k-1)."""
    return previous + (1.0 - math.exp(-T / time_constant)) * (value - previous)


def learned_mean(previous: float, taken: float, value: float, T: float, time_constant: float) -> tuple[float, float]:
    """One sampled step of a learned mean (model.filters.learned_mean): gain max(1 / (n + 1),
    1 - exp(-T / tau)) over the n samples taken so far, n counted up to tau / T in whole samples.
    Returns (mean, samples taken)."""
    gain = max(1.0 / (taken + 1.0), 1.0 - math.exp(-T / time_constant))
    return previous + gain * (value - previous), min(taken + 1.0, float(whole_samples(time_constant, T)))


def learned_check(x, settings, T: float, entry: str, value: float, sampled: bool, time_key: str,
                  limit_key: str) -> tuple[dict, bool]:
    """(new entries, raised) of a check on a learned mean (model.filters.learned_check): ``entry``
    of ``x`` learns ``value`` where ``sampled`` (time constant setting ``time_key``; its runs counted
    in ``entry``_samples); raised where |mean| > setting ``limit_key`` once it has taken
    learned_after of runs, or its time constant's if fewer."""
    count, time_constant = f"{entry}_samples", settings[time_key]
    mean, taken = x[entry], x[count]
    if sampled:
        mean, taken = learned_mean(mean, taken, value, T, time_constant)
    judged = taken >= min(whole_samples(settings["learned_after"], T), whole_samples(time_constant, T))
    return {entry: mean, count: taken}, judged and abs(mean) > settings[limit_key]


def kf_predict(x, P, Phi, Gamma, u, Qd):
    return Phi @ x + Gamma @ u, Phi @ P @ Phi.T + Qd


def kf_update(x, P, z, C, D, u, R):
    """Joseph-form measurement update of z = C x + D u + v."""
    return kf_correct(x, P, z - C @ x - D @ u, C, R)


def kf_correct(x, P, innovation, H, R):
    """Joseph-form update from an innovation whose measurement has the Jacobian H."""
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    I_KH = np.eye(len(x)) - K @ H
    return x + K @ innovation, I_KH @ P @ I_KH.T + K @ R @ K.T


def upper_names(prefix: str, names: tuple[str, ...]) -> tuple[str, ...]:
    """Names of a symmetric matrix's stored entries, upper triangle row by row."""
    return tuple(f"{prefix}_{names[i]}_{names[j]}" for i in range(len(names))
                 for j in range(i, len(names)))


def packed(P: np.ndarray) -> list[float]:
    """The upper triangle of P, row by row."""
    n = P.shape[0]
    return [P[i, j] for i in range(n) for j in range(i, n)]


def unpacked(values, n: int) -> np.ndarray:
    """The symmetric n x n matrix whose upper triangle (row by row) is ``values``."""
    P = np.zeros((n, n))
    entries = iter(values)
    for i in range(n):
        for j in range(i, n):
            P[i, j] = P[j, i] = next(entries)
    return P


def residual_mean(previous, innovation, settings, T):
    """The consistency monitor's m_k = a m_k-1 + (1 - a) mean_i(min(nu_i^2 / sigma_i^2, 100)), a =
    exp(-T / residual_window), sigma = sensor_noise (model.consistency); 0 when it is off."""
    window = settings["residual_window"]
    if window == 0.0:
        return 0.0
    sigma = np.array(settings["sensor_noise"], dtype=float)
    ratio = float(np.mean(np.minimum(np.asarray(innovation, dtype=float) ** 2 / sigma ** 2, 100.0)))
    keep = np.exp(-T / window)
    return keep * previous + (1 - keep) * ratio


MONITOR_STATES = ("residual", "residual_hold_left")
"""The consistency monitor's state entries (model.consistency.STATES)."""


def beyond_linear_range(ay: float, settings, ay_model: float | None = None, friction_scale: float = 1.0) -> bool:
    """Whether |``ay``| (the logged a_y, m/s^2), or |``ay_model``| (the filter's prior a_y, where
    it has one), exceeds the setting ``linear_range`` (0 = never) times the filter's estimated
    ``friction_scale`` (1 where it has none)."""
    seen = abs(ay) if ay_model is None else max(abs(ay), abs(ay_model))
    return settings["linear_range"] > 0 and seen > settings["linear_range"] * friction_scale


def residual_monitor(x, innovation, settings, T):
    """(new monitor entries, suspect, first) of the consistency monitor: the mean (residual_mean),
    the flag raised above residual_limit and held residual_hold seconds after, and whether the
    mean first exceeded the limit on this sample."""
    mean = residual_mean(x["residual"], innovation, settings, T)
    now, before = mean > settings["residual_limit"], x["residual"] > settings["residual_limit"]
    left, suspect = held_flag(x["residual_hold_left"], now, settings["residual_hold"], T)
    return {"residual": mean, "residual_hold_left": left}, suspect, now and not before


def roll_corrected(ay_measured, roll_gradient):
    """Accelerometer reading without the gravity component of body roll: a_y,m = a_y (1 + g k)
    to first order for roll phi = k a_y (k = roll_gradient; 0 = none)."""
    return ay_measured * (1.0 / (1.0 + GRAVITY * roll_gradient))


def plausible(limits: Mapping[str, float], name: str, value: float) -> bool:
    """Finite and within its [inputs] limit."""
    return math.isfinite(value) and abs(value) <= limits[LIMIT_OF[name]]


def hold_rule(limits, inputs: Mapping[str, float], vx_min: float, vx_resume: float, held_before: bool,
              monitored: tuple[str, ...] = ()):
    """(active, status, plausible-by-name) per the project's low-speed / invalid-input rule; the
    ``monitored`` inputs (read only by an input monitor) are judged but do not hold."""
    ok = {name: plausible(limits, name, value) for name, value in inputs.items()}
    valid = all(flag for name, flag in ok.items() if name not in monitored)
    vx = inputs["vx"]
    low = ok["vx"] and (vx < vx_min or (held_before and vx < vx_resume))
    status = (0 if valid else INVALID_INPUT) | (LOW_SPEED if low else 0)
    return valid and not low, status, ok


def first_sample(limits, inputs: Mapping[str, float], vx_min: float, vx_resume: float,
                 monitored: tuple[str, ...] = ()):
    """(inputs with each implausible one replaced by 0, or vx by vx_min; initial holding flag):
    an estimator starts active only if every input (but the ``monitored``) is plausible and
    vx >= vx_resume."""
    active, _, ok = hold_rule(limits, inputs, vx_resume, vx_resume, True, monitored)
    values = {n: v if ok[n] else (vx_min if n == "vx" else 0.0) for n, v in inputs.items()}
    return values, 0.0 if active else 1.0


def kept_previous(inputs: Mapping[str, float], ok: Mapping[str, bool], delta_prev: float,
                  vx_prev: float) -> tuple[float, float]:
    """(delta_prev, vx_prev) after a sample: the new value where plausible, else the old one."""
    return (inputs["delta"] if ok["delta"] else delta_prev, inputs["vx"] if ok["vx"] else vx_prev)
