"""Axle cornering stiffnesses C_f, C_r and the tyres' friction from the whole log (filter error).

Model: the bicycle model (docs/conventions.md; mass, a, b, I_z are the user's) with saturating
axles, F_y = F_peak tanh(C alpha / F_peak), F_peak = mu F_z (the axle's static
load). An extended Kalman filter of that model, driven by the logged steer angle and speed, predicts
the (offset- and roll-corrected) yaw rate and lateral acceleration one sample ahead, and C_f, C_r and
mu are chosen to minimise its innovations (the filter-error method of flight-test identification).
Unlike an open-loop simulation, the filter cannot drift away from a car at its limit, so every
sample enters: transients, quasi-steady corners and driving at the friction limit. A race lap or a
handling track pins the stiffnesses down where ordinary quasi-steady cornering is rare. Where a log
carries ``beta_ref`` or ``vy_ref``, the reference lateral velocity is a third measured output.

The log is cut into pieces of ``PIECE`` s, filtered side by side from v_y = 0 with a wide
covariance, their first ``SETTLE`` s not scored; the spread between pieces (jackknife) widens the
intervals beyond what the residual noise alone claims. A log that never nears the limit leaves mu
open: it is then refused and the stiffnesses come from the linear model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from vsegen.harness.identify.estimates import (
    Z95,
    Estimate,
    Refusal,
    Selection,
    fit_with_jackknife,
    interval,
    select,
)
from vsegen.harness.logs.table import Log, runs
from vsegen.harness.physics import segments
from vsegen.model.bicycle import GRAVITY

SETTLE = 1.0
"""s of each piece not scored (the filter's start from v_y = 0)."""
PIECE = 20.0
"""s: stretches are filtered in pieces of this length (shorter remainders of at least 2 s too)."""
FORCE_NOISE = 0.005
"""Process noise of each axle's lateral force: this share of its static load, per square root of a
second (road, load transfer and tyre effects the model leaves out)."""
REFERENCE_NOISE = 0.05
"""m/s: noise of a reference lateral velocity (an INS or optical sensor, with its lever arm)."""
MIN_YAW_EXCITATION = 0.02
"""rad/s: standard deviation of the yaw rate needed to separate C_f from C_r."""
MAX_RELATIVE_HALF_WIDTH = 0.2
"""A parameter whose 95 % interval is wider than +-20 % of its value is reported as not identified."""
STIFFNESS_RANGE = (0.2, 5.0)
"""The fitted stiffnesses stay within these factors of the base file's."""
NEAR_LIMIT = 0.8
"""mu is claimed only where the logs' lateral acceleration (``segments.SMOOTHING`` means) reaches this share of
mu g: below, the fitted saturation only bends the curve where the tyres are still far from their
peak, and a smooth tanh bends earlier than a real tyre (a dry-road car driven to 0.6 g 'shows' mu 0.75)."""
FRICTION_RANGE = (0.1, 3.0)
"""The fitted friction coefficient stays within these bounds; at the upper one the log never met the limit."""
LINEAR = 1e3
"""Friction coefficient that stands for 'never saturates' (the linear bicycle model)."""
NAMES = ("cornering_stiffness_front", "cornering_stiffness_rear")


def axle_loads(vehicle: Mapping[str, float]) -> tuple[float, float]:
    """Static vertical loads (N) of the front and rear axle."""
    m, a, b = vehicle["mass"], vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    return m * GRAVITY * b / (a + b), m * GRAVITY * a / (a + b)


def cornering_stiffness(logs: Sequence[Log], vehicle: Mapping[str, float], quantities: Mapping[str, float],
                        ) -> list[Estimate | Refusal]:
    """C_f and C_r (N/rad, both tyres of an axle) and the friction coefficient of the axles' peak
    force (``tyre_friction``), each with a 95 % interval, or why not."""
    driving = select(logs, _driving)
    yaw = driving.column("r")
    if driving.seconds < 5.0 or (len(yaw) and yaw.std() < MIN_YAW_EXCITATION):
        why = (f"no steering at speed (v_x > {segments.MIN_SPEED:g} m/s): {driving.seconds:.1f} s, yaw-rate "
               f"spread {yaw.std() if len(yaw) else 0.0:.3f} rad/s (needs 5 s and {MIN_YAW_EXCITATION} rad/s)")
        return [Refusal(name, why) for name in (*NAMES, "tyre_friction")]
    pieces = _pieces(driving, quantities)
    nominal = np.array([vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"]])
    source = "the reference lateral velocity" if pieces["vy_ref"] is not None else "no reference"
    support = f"{driving.support} (filter error, {source})"
    low, high = np.log(STIFFNESS_RANGE)
    bounds = ([low, low, np.log(FRICTION_RANGE[0])], [high, high, np.log(FRICTION_RANGE[1])])
    p, cov = fit_with_jackknife(_residual(vehicle, nominal, pieces, quantities, None), np.zeros(3),
                                pieces["groups"], bounds)
    mu, mu_sd = float(np.exp(p[2])), float(np.exp(p[2]) * np.sqrt(cov[2, 2]))
    window = round(segments.SMOOTHING / driving.logs[0].sample_time)
    peak = max(float(np.abs(segments.smoothed(np.nan_to_num(log["ay"]), window)[mask]).max())
               for log, mask in zip(driving.logs, driving.masks) if mask.any())
    if Z95 * mu_sd <= MAX_RELATIVE_HALF_WIDTH * mu and peak >= NEAR_LIMIT * mu * GRAVITY:
        friction: Estimate | Refusal = interval("tyre_friction", mu, mu_sd, "-", support)
    else:
        friction = Refusal("tyre_friction", f"the logs do not reach the tyres' limit (|a_y| up to {peak:.1f} "
                                            f"m/s^2 for mu {mu:.2f} +-{100 * Z95 * mu_sd / mu:.0f} % (95 %)); "
                                            "the linear model is fitted")
        p, cov = fit_with_jackknife(_residual(vehicle, nominal, pieces, quantities, LINEAR), p[:2],
                                    pieces["groups"], (bounds[0][:2], bounds[1][:2]))
    return [*(_stiffness(name, nominal[i], p[i], cov[i, i], support) for i, name in enumerate(NAMES)), friction]


def _stiffness(name: str, nominal: float, log_ratio: float, variance: float, support: str) -> Estimate | Refusal:
    value = nominal * np.exp(log_ratio)
    sd = value * np.sqrt(variance)  # delta method on the log-parameter
    if Z95 * sd > MAX_RELATIVE_HALF_WIDTH * value:
        return Refusal(name, f"the logs do not pin it down: {value:.0f} N/rad +-{100 * Z95 * sd / value:.0f} % "
                             f"(95 %); drive steer steps or sine steering at 60..100 km/h")
    return interval(name, value, sd, "N/rad", support)


def _residual(vehicle, nominal: np.ndarray, pieces: dict, quantities: Mapping[str, float], mu: float | None):
    """Normalised innovations of the pieces as a function of log(C / nominal) (and log mu when
    ``mu`` is None)."""
    def residual(p: np.ndarray) -> np.ndarray:
        cf, cr = nominal * np.exp(p[:2])
        return innovations(vehicle, cf, cr, float(np.exp(p[2])) if mu is None else mu, pieces, quantities)

    return residual


def innovations(vehicle: Mapping[str, float], cf: float, cr: float, mu: float, pieces: dict,
                quantities: Mapping[str, float]) -> np.ndarray:
    """The extended Kalman filter's prior innovations of a_y, r (and v_y_ref) over the scored samples
    of ``pieces``, each divided by its sensor's noise. State [v_y, r]; prediction over one sample
    with the inputs of that sample (linearly implicit trapezoidal rule); the filter runs over all
    pieces at once (columns)."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    load_f, load_r = axle_loads(vehicle)
    peak_f, peak_r = mu * load_f, mu * load_r
    dt, delta, speed, yaw, lateral, vy_ref = (pieces[k] for k in ("dt", "delta", "vx", "r", "ay", "vy_ref"))
    noise_r, noise_ay = quantities["gyro_noise"], quantities["ay_noise"]
    qf, qr = (FORCE_NOISE * load_f) ** 2 * dt, (FORCE_NOISE * load_r) ** 2 * dt
    q11 = qf / m**2 + qr / m**2
    q12 = qf * a / (m * iz) - qr * b / (m * iz)
    q22 = qf * (a / iz) ** 2 + qr * (b / iz) ** 2
    vy, r = np.zeros(delta.shape[1]), yaw[0].copy()
    p11, p12, p22 = np.full_like(vy, 1.0), np.zeros_like(vy), np.full_like(vy, 1e-3)
    out = np.empty((3 if vy_ref is not None else 2, *delta.shape))

    def forces(u, d):
        tf = np.tanh(cf * (d - (vy + a * r) / u) / peak_f)
        tr = np.tanh(-cr * (vy - b * r) / (u * peak_r))
        # forces and -dF/dv_y of each axle
        return peak_f * tf, peak_r * tr, cf * (1 - tf * tf) / u, cr * (1 - tr * tr) / u

    for k in range(delta.shape[0]):
        u, d = speed[k], delta[k]
        ff, fr, kf, kr = forces(u, d)
        rows = [((lateral[k] - (ff + fr) / m), -(kf + kr) / m, (b * kr - a * kf) / m, noise_ay),
                (yaw[k] - r, 0.0, 1.0, noise_r)]
        if vy_ref is not None:
            rows.append((vy_ref[k] - vy, 1.0, 0.0, REFERENCE_NOISE))
        vy0, r0 = vy, r
        for i, (e, h1, h2, noise) in enumerate(rows):   # sequential scalar updates (independent sensors)
            out[i, k] = e / noise
            e = e - h1 * (vy - vy0) - h2 * (r - r0)     # the part the earlier sensors left
            ph1, ph2 = p11 * h1 + p12 * h2, p12 * h1 + p22 * h2
            s = h1 * ph1 + h2 * ph2 + noise**2
            g1, g2 = ph1 / s, ph2 / s
            vy, r = vy + g1 * e, r + g2 * e
            p11, p12, p22 = p11 - g1 * ph1, p12 - g1 * ph2, p22 - g2 * ph2
        ff, fr, kf, kr = forces(u, d)
        j11, j12 = -(kf + kr) / m, (b * kr - a * kf) / m - u
        j21, j22 = (b * kr - a * kf) / iz, -(a * a * kf + b * b * kr) / iz
        # linearly implicit trapezoidal step: x+ = x + T (I - T J / 2)^-1 f(x), second order, stable
        h11, h12, h21, h22 = 1 - 0.5 * dt * j11, -0.5 * dt * j12, -0.5 * dt * j21, 1 - 0.5 * dt * j22
        det = h11 * h22 - h12 * h21
        i11, i12, i21, i22 = h22 / det, -h12 / det, -h21 / det, h11 / det
        f1, f2 = (ff + fr) / m - u * r, (a * ff - b * fr) / iz
        vy, r = vy + dt * (i11 * f1 + i12 * f2), r + dt * (i21 * f1 + i22 * f2)
        # its transition matrix (I - T J / 2)^-1 (I + T J / 2) propagates the covariance
        e11, e12, e21, e22 = 1 + 0.5 * dt * j11, 0.5 * dt * j12, 0.5 * dt * j21, 1 + 0.5 * dt * j22
        f11, f12 = i11 * e11 + i12 * e21, i11 * e12 + i12 * e22
        f21, f22 = i21 * e11 + i22 * e21, i21 * e12 + i22 * e22
        t11, t12 = f11 * p11 + f12 * p12, f11 * p12 + f12 * p22
        t21, t22 = f21 * p11 + f22 * p12, f21 * p12 + f22 * p22
        p11, p12, p22 = t11 * f11 + t12 * f12 + q11, t11 * f21 + t12 * f22 + q12, t21 * f21 + t22 * f22 + q22
    return np.concatenate([channel[pieces["scored"]] for channel in out])


def _driving(log: Log) -> np.ndarray:
    """Samples at speed with every input finite, in runs of at least 2 s."""
    ok = segments.finite(log, ("delta", "vx", "ay", "r")) & (np.nan_to_num(log["vx"]) > segments.MIN_SPEED)
    return segments.long_runs(ok, int(round(2.0 / log.sample_time)))


def reference_lateral_velocity(log: Log) -> np.ndarray | None:
    """The log's reference lateral velocity at the CG: ``vy_ref``, else v_x tan(beta_ref), else None."""
    if "vy_ref" in log:
        return log["vy_ref"]
    if "beta_ref" in log:
        return log["vx"] * np.tan(log["beta_ref"])
    return None


def _pieces(driving: Selection, quantities: Mapping[str, float]) -> dict:
    """The driving stretches cut into pieces of PIECE s, as columns of equally long arrays (a short
    piece padded by repeating its last sample, unscored), with the corrected sensor signals, the
    scored samples and each residual's jackknife group (its piece). ``vy_ref`` is None unless every
    log has a reference."""
    k = quantities["roll_gradient"]
    dt = driving.logs[0].sample_time
    length = int(round(PIECE / dt))
    referenced = all(reference_lateral_velocity(log) is not None for log in driving.logs)
    columns: dict[str, list] = {"delta": [], "vx": [], "r": [], "ay": [], "vy_ref": [], "scored": []}
    for log, mask in zip(driving.logs, driving.masks):
        signals = {"delta": log["delta"], "vx": log["vx"], "r": log["r"] - quantities["gyro_offset"],
                   "ay": (log["ay"] - quantities["ay_offset"]) / (1.0 + GRAVITY * k)}
        if referenced:
            signals["vy_ref"] = reference_lateral_velocity(log)
        for run in runs(mask & _finite_reference(log, referenced)):
            for start in range(run.start, run.stop, length):
                stop = min(start + length, run.stop)
                if stop - start < int(round(2.0 / dt)):
                    continue
                for name, values in signals.items():
                    columns[name].append(np.pad(values[start:stop], (0, length - (stop - start)), mode="edge"))
                scored = np.arange(length) >= int(round(SETTLE / dt))
                scored[stop - start:] = False
                columns["scored"].append(scored)
    out = {name: np.stack(values, axis=1) if values else None for name, values in columns.items()}
    count = out["delta"].shape[1]
    piece = np.broadcast_to(np.arange(count), out["scored"].shape)[out["scored"]]
    out["groups"] = np.tile(piece, 3 if referenced else 2)   # one block of residuals per sensor
    out["dt"] = dt
    return out


def _finite_reference(log: Log, referenced: bool) -> np.ndarray:
    if not referenced:
        return np.ones(len(log), dtype=bool)
    return np.isfinite(reference_lateral_velocity(log))
