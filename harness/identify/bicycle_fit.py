"""Axle cornering stiffnesses C_f, C_r from the yaw transients of steer inputs (output error).

The linear bicycle model (docs/conventions.md; mass, a, b, I_z are the user's) is simulated over
each stretch of linear-range driving with the logged steer angle and speed, and C_f, C_r are chosen
so that its yaw rate and lateral acceleration match the (offset- and roll-corrected) sensors; where
a log carries ``beta_ref`` (or ``vy_ref``) the sideslip angle is matched too. Each stretch starts from the
steady state of its first sample, and its first ``SETTLE`` seconds are not scored.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from vsegen.harness.identify.estimates import Z95, Estimate, Refusal, Selection, fit, interval, select
from vsegen.harness.logs import segments
from vsegen.harness.logs.table import Log, runs
from vsegen.model.bicycle import GRAVITY, stability_factor

SETTLE = 0.5
"""s of each stretch not scored (the start-up of the simulated model)."""
MIN_YAW_EXCITATION = 0.02
"""rad/s: standard deviation of the yaw rate over the stretches needed to separate C_f from C_r."""
MAX_RELATIVE_HALF_WIDTH = 0.2
"""A stiffness whose 95 % interval is wider than +-20 % of its value is reported as not identified."""
BETA_REF_NOISE = 0.002
"""rad: weight of the beta_ref residuals (a test-track optical sensor's noise)."""


def simulate(vehicle: Mapping[str, float], cf: float, cr: float, delta: np.ndarray,
             vx: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, a_y, beta) of the linear bicycle model driven by ``delta`` and ``vx`` (trapezoidal rule
    per sample, which stays stable for any stiffness), from the steady state of sample 0."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    n = len(delta)
    vy, r = _steady_state(m, a, b, cf, cr, delta[0], vx[0])
    out_r, out_ay, out_beta = np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        u, d = vx[k], delta[k]
        a11, a12 = -(cf + cr) / (m * u), (b * cr - a * cf) / (m * u) - u
        a21, a22 = (b * cr - a * cf) / (iz * u), -(a * a * cf + b * b * cr) / (iz * u)
        b1, b2 = cf / m, a * cf / iz
        out_r[k] = r
        out_ay[k] = (a11 * vy + (a12 + u) * r + b1 * d)
        out_beta[k] = np.arctan2(vy, u)
        # (I - A dt/2) x+ = (I + A dt/2) x + B dt (d + d+)/2 with d+ ~ d (zero-order hold)
        h = 0.5 * dt
        rhs1 = vy + h * (a11 * vy + a12 * r) + dt * b1 * d
        rhs2 = r + h * (a21 * vy + a22 * r) + dt * b2 * d
        m11, m12, m21, m22 = 1 - h * a11, -h * a12, -h * a21, 1 - h * a22
        det = m11 * m22 - m12 * m21
        vy, r = (m22 * rhs1 - m12 * rhs2) / det, (m11 * rhs2 - m21 * rhs1) / det
    return out_r, out_ay, out_beta


def _steady_state(m, a, b, cf, cr, delta, vx) -> tuple[float, float]:
    l = a + b
    ks = stability_factor({"mass": m, "cg_to_front_axle": a, "cg_to_rear_axle": b,
                           "cornering_stiffness_front": cf, "cornering_stiffness_rear": cr})
    r = vx * delta / (l * (1 + ks * vx * vx))
    # rear axle: F_yr = m a_y a / l = C_r alpha_r, alpha_r = -(vy - b r)/vx
    alpha_r = m * vx * r * a / (l * cr)
    return b * r - alpha_r * vx, r


def cornering_stiffness(logs: Sequence[Log], vehicle: Mapping[str, float], quantities: Mapping[str, float],
                        ) -> list[Estimate | Refusal]:
    """C_f and C_r (N/rad, both tyres of an axle) with 95 % intervals, or why not."""
    names = ("cornering_stiffness_front", "cornering_stiffness_rear")
    linear = select(logs, segments.linear_driving)
    yaw = linear.column("r")
    if linear.seconds < 5.0 or (len(yaw) and yaw.std() < MIN_YAW_EXCITATION):
        why = (f"no steer transients in the linear range (|a_y| < {segments.LINEAR_LATERAL:g} m/s^2, "
               f"v_x > {segments.MIN_SPEED:g} m/s): {linear.seconds:.1f} s, yaw-rate spread "
               f"{yaw.std() if len(yaw) else 0.0:.3f} rad/s (needs 5 s and {MIN_YAW_EXCITATION} rad/s)")
        return [Refusal(name, why) for name in names]
    stretches = _stretches(linear, quantities)
    with_reference = any("beta_ref" in log or "vy_ref" in log for log in logs)
    nominal = np.array([vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"]])

    p, cov = _fit_log_stiffness(vehicle, nominal, stretches, quantities)
    if len(stretches) >= 3:
        # leave-one-stretch-out jackknife: the spread between stretches also covers model error
        # (load transfer, tyre non-linearity), which the residual noise alone does not show
        others = np.array([_fit_log_stiffness(vehicle, nominal, stretches[:i] + stretches[i + 1:], quantities)[0]
                           for i in range(len(stretches))])
        n = len(stretches)
        jackknife = (n - 1) / n * ((others - others.mean(axis=0)) ** 2).sum(axis=0)
        cov = np.diag(np.maximum(np.diag(cov), jackknife))
    support = linear.support + (" (with the beta reference)" if with_reference else "")
    out: list[Estimate | Refusal] = []
    for i, name in enumerate(names):
        value = nominal[i] * np.exp(p[i])
        sd = value * np.sqrt(cov[i, i])  # delta method on the log-parameter
        if Z95 * sd > MAX_RELATIVE_HALF_WIDTH * value:
            out.append(Refusal(name, f"the logs do not pin it down: {value:.0f} N/rad +-"
                                     f"{100 * Z95 * sd / value:.0f} % (95 %); drive steer steps or "
                                     f"sine steering at 60..100 km/h"))
        else:
            out.append(interval(name, value, sd, "N/rad", support))
    return out


def _fit_log_stiffness(vehicle, nominal: np.ndarray, stretches: list[dict],
                       quantities: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(log(C / nominal) for [C_f, C_r], covariance) fitted over ``stretches``."""

    def residual(p: np.ndarray) -> np.ndarray:
        cf, cr = nominal * np.exp(p)
        parts = []
        for s in stretches:
            r, ay, beta = simulate(vehicle, cf, cr, s["delta"], s["vx"], s["dt"])
            keep = slice(s["settle"], None)
            parts.append((r[keep] - s["r"][keep]) / quantities["gyro_noise"])
            parts.append((ay[keep] - s["ay"][keep]) / quantities["ay_noise"])
            if s["beta_ref"] is not None:
                parts.append((beta[keep] - s["beta_ref"][keep]) / BETA_REF_NOISE)
        return np.concatenate(parts)

    return fit(residual, np.zeros(2))


def _reference_sideslip(log: Log, run: slice) -> np.ndarray | None:
    """The log's reference sideslip angle over ``run``: ``beta_ref``, else atan2(vy_ref, v_x) from
    a GNSS/INS lateral velocity, else None."""
    if "beta_ref" in log:
        return log["beta_ref"][run]
    if "vy_ref" in log:
        return np.arctan2(log["vy_ref"][run], log["vx"][run])
    return None


def _stretches(linear: Selection, quantities: Mapping[str, float]) -> list[dict]:
    """The contiguous linear-range stretches with corrected sensor signals."""
    out = []
    k = quantities["roll_gradient"]
    for log, mask in zip(linear.logs, linear.masks):
        dt = log.sample_time
        for run in runs(mask):
            ay_measured = log["ay"][run] - quantities["ay_offset"]
            out.append({
                "dt": dt, "settle": int(round(SETTLE / dt)),
                "delta": log["delta"][run], "vx": log["vx"][run],
                "r": log["r"][run] - quantities["gyro_offset"],
                "ay": ay_measured / (1.0 + GRAVITY * k),
                "beta_ref": _reference_sideslip(log, run),
            })
    return out
