"""Reference 2-DOF Kalman filter step of every estimator with a dynamic scheme (kf2dof, switching,
fusion): the linear bicycle model's KF, or with ``tyre_model = "saturating"`` the extended KF of the
bicycle model with tanh-saturating axles (F = mu F_z tanh(C alpha / (mu F_z)), F_z the static axle
load), written from the equations, not from the model's code. With ``friction_noise`` > 0 the
extended KF's state has a third entry, the friction scale rho that multiplies both axles' friction
(the floor still holding), a random walk that returns to 1 with ``friction_time``; it is held over
a sample in the prediction of [vy, r].
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from vsegen.harness.reference import blocks
from vsegen.harness.reference.blocks import GRAVITY

FRICTION_SCALE_RANGE = (0.1, 2.0)
"""Where the estimated friction scale is kept (the model's model.tyres.FRICTION_SCALE_RANGE)."""


def estimates_friction(settings: Mapping) -> bool:
    return settings["tyre_model"] == "saturating" and settings["friction_noise"] > 0


def names(settings: Mapping) -> tuple[str, ...]:
    """The KF's state entries: [vy, r] and, where it is estimated, the friction scale."""
    return ("vy", "r", *(("friction",) if estimates_friction(settings) else ()))


def friction_scale(settings: Mapping, x) -> float:
    """The estimated friction scale of the KF's state ``x`` (1 where it is not estimated)."""
    return x[2] if estimates_friction(settings) else 1.0


def covariance_names(settings: Mapping) -> tuple[str, ...]:
    return blocks.upper_names("P", names(settings))


def initial_covariance(settings: Mapping) -> np.ndarray:
    """P_0: initial_covariance, and the friction scale known (variance 0) where it is estimated."""
    n = len(names(settings))
    P0 = np.zeros((n, n))
    P0[:2, :2] = settings["initial_covariance"]
    return P0


def initial_entries(settings: Mapping, r0: float) -> dict[str, float]:
    """vy = 0, r = ``r0``, friction scale 1, P = P_0."""
    return entries(settings, np.array([0.0, r0, 1.0][:len(names(settings))]), initial_covariance(settings))


def entries(settings: Mapping, x, P) -> dict[str, float]:
    """The state entries of ``x`` and ``P``."""
    return {**dict(zip(names(settings), x)), **dict(zip(covariance_names(settings), blocks.packed(P)))}


def state(settings: Mapping, x: Mapping[str, float]):
    """(x, P) from the state entries ``x``."""
    return (np.array([x[k] for k in names(settings)]),
            blocks.unpacked([x[k] for k in covariance_names(settings)], len(names(settings))))


def step(settings: Mapping, vehicle: Mapping[str, float], T: float, x, P, delta_prev: float,
         vx_prev: float, delta: float, vx: float, z, inputs_frozen: bool = False):
    """Predict with the previous inputs (``vx_prev``, ``vx`` already clamped), update with
    z = [a_y, r]; returns (x+, P+, the prior innovation z - h(x-), the prior's a_y: a_y minus its
    innovation, as the model's ``ay_model``). While ``inputs_frozen`` (a_y or r), an estimated
    friction scale keeps its prior."""
    if settings["tyre_model"] == "saturating":
        return _saturating_step(settings, vehicle, T, x, P, delta_prev, vx_prev, delta, vx, z, inputs_frozen)
    A, B, _, _ = blocks.bicycle(vehicle, vx_prev)
    Phi, Gamma = blocks.discretise(settings["discretisation"], A, B, T)
    Qd = process_noise(settings, z[0], T)
    x_pred, P_pred = blocks.kf_predict(x, P, Phi, Gamma, np.array([delta_prev]), Qd)
    _, _, C, D = blocks.bicycle(vehicle, vx)
    innovation = np.asarray(z) - C @ x_pred - D @ np.array([delta])
    x_new, P_new = blocks.kf_correct(x_pred, P_pred, innovation, C, np.array(settings["measurement_noise"]))
    return x_new, P_new, innovation, z[0] - innovation[0]


def process_noise(settings: Mapping, ay: float, T: float):
    """Q_d = Q_c T (1 + (min(|a_y|, 6 m/s^2) / max(process_noise_load, 0.1 m/s^2))^2), the growth
    only where that setting is > 0."""
    load = settings["process_noise_load"]
    growth = 1.0 + (min(abs(ay), 6.0) / max(load, 0.1)) ** 2 if load > 0 else 1.0
    return np.array(settings["process_noise"]) * T * growth


def _saturating_step(settings: Mapping, vehicle: Mapping[str, float], T: float, x, P, delta_prev: float,
                     vx_prev: float, delta: float, vx: float, z, inputs_frozen: bool):
    """The extended KF of the saturating model, with the friction scale as a third state where it
    is estimated."""
    estimated = estimates_friction(settings)
    floor = settings["friction_floor"] * abs(z[0]) / GRAVITY     # the road carries the measured a_y

    def friction(scale):
        """Each axle's mu and dmu/drho (0 where the floor holds it)."""
        scaled = [scale * m for m in settings["tyre_friction"]]
        return ([max(m, floor) for m in scaled],
                [m_file if m >= floor else 0.0 for m, m_file in zip(scaled, settings["tyre_friction"])])

    mu, slope = friction(x[2] if estimated else 1.0)
    f, A, _, _ = saturating(vehicle, mu, x[:2], delta_prev, vx_prev)
    Phi, Gamma = blocks.discretise(settings["discretisation"], A, np.eye(2), T)
    n = len(x)
    F, Qd = np.zeros((n, n)), np.zeros((n, n))
    F[:2, :2], Qd[:2, :2] = Phi, process_noise(settings, z[0], T)
    x_pred = np.array([*(x[:2] + Gamma @ f), *x[2:]])
    if estimated:
        decay = math.exp(-T / settings["friction_time"])
        F[:2, 2] = Gamma @ friction_sensitivity(vehicle, mu, slope, x[:2], delta_prev, vx_prev)[0]
        F[2, 2], Qd[2, 2] = decay, settings["friction_noise"] * T
        x_pred[2] = 1 + (x[2] - 1) * decay
        mu, slope = friction(x_pred[2])
    P_pred = F @ P @ F.T + Qd
    _, _, ay, H = saturating(vehicle, mu, x_pred[:2], delta, vx)
    if estimated:
        H = np.hstack([H, [[friction_sensitivity(vehicle, mu, slope, x_pred[:2], delta, vx)[1]], [0.0]]])
    innovation = np.asarray(z) - np.array([ay, x_pred[1]])
    x_new, P_new = blocks.kf_correct(x_pred, P_pred, innovation, H, np.array(settings["measurement_noise"]))
    if estimated:
        low, high = FRICTION_SCALE_RANGE
        x_new[2] = x_pred[2] if inputs_frozen else min(max(x_new[2], low), high)
    return x_new, P_new, innovation, z[0] - innovation[0]


def saturating(vehicle: Mapping[str, float], mu, x, delta: float, vx: float):
    """(dx/dt, its Jacobian, a_y, the Jacobian of [a_y, r]) of the saturating bicycle model."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    vy, r = x
    load_f, load_r = m * GRAVITY * b / (a + b), m * GRAVITY * a / (a + b)
    Ff, kf = _tanh_axle(vehicle["cornering_stiffness_front"], mu[0] * load_f, delta - (vy + a * r) / vx)
    Fr, kr = _tanh_axle(vehicle["cornering_stiffness_rear"], mu[1] * load_r, -(vy - b * r) / vx)
    dFf = kf * np.array([-1.0 / vx, -a / vx])
    dFr = kr * np.array([-1.0 / vx, b / vx])
    f = np.array([(Ff + Fr) / m - vx * r, (a * Ff - b * Fr) / iz])
    A = np.vstack([(dFf + dFr) / m + np.array([0.0, -vx]), (a * dFf - b * dFr) / iz])
    H = np.vstack([(dFf + dFr) / m, [0.0, 1.0]])
    return f, A, (Ff + Fr) / m, H


def friction_sensitivity(vehicle: Mapping[str, float], mu, slope, x, delta: float, vx: float):
    """(d(dx/dt)/drho, da_y/drho) of the saturating model, each axle's friction ``mu`` moving with
    the friction scale rho at ``slope`` = dmu/drho: dF/dpeak = tanh(u) - u / cosh(u)^2."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    vy, r = x
    load_f, load_r = m * GRAVITY * b / (a + b), m * GRAVITY * a / (a + b)

    def per_scale(C, load, mu_axle, dmu, alpha):
        u = C * alpha / (mu_axle * load)
        return (np.tanh(u) - u / np.cosh(u) ** 2) * load * dmu

    dFf = per_scale(vehicle["cornering_stiffness_front"], load_f, mu[0], slope[0], delta - (vy + a * r) / vx)
    dFr = per_scale(vehicle["cornering_stiffness_rear"], load_r, mu[1], slope[1], -(vy - b * r) / vx)
    return np.array([(dFf + dFr) / m, (a * dFf - b * dFr) / iz]), (dFf + dFr) / m


def _tanh_axle(C: float, peak: float, alpha: float):
    u = C * alpha / peak
    return peak * np.tanh(u), C / np.cosh(u) ** 2
