"""Reference 2-DOF Kalman filter step of every estimator with a dynamic scheme (kf2dof, switching,
fusion): the linear bicycle model's KF, or with ``tyre_model = "saturating"`` the extended KF of the
bicycle model with tanh-saturating axles (F = mu F_z tanh(C alpha / (mu F_z)), F_z the static axle
load), written from the equations, not from the model's code.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vsegen.harness.reference import blocks
from vsegen.harness.reference.blocks import GRAVITY


def step(settings: Mapping, vehicle: Mapping[str, float], T: float, x, P, delta_prev: float,
         vx_prev: float, delta: float, vx: float, z):
    """Predict with the previous inputs (``vx_prev``, ``vx`` already clamped), update with
    z = [a_y, r]; returns (x+, P+, the prior innovation z - h(x-), the prior's a_y: a_y minus its
    innovation, as the model's ``ay_model``)."""
    Qd = np.array(settings["process_noise"]) * T
    R = np.array(settings["measurement_noise"])
    if settings["tyre_model"] == "saturating":
        shown = settings["friction_floor"] * abs(z[0]) / GRAVITY     # the road carries the measured a_y
        mu = [max(m, shown) for m in settings["tyre_friction"]]
        f, A, _, _ = saturating(vehicle, mu, x, delta_prev, vx_prev)
        Phi, Gamma = blocks.discretise(settings["discretisation"], A, np.eye(2), T)
        x_pred, P_pred = x + Gamma @ f, Phi @ P @ Phi.T + Qd
        _, _, ay, H = saturating(vehicle, mu, x_pred, delta, vx)
        innovation = np.asarray(z) - np.array([ay, x_pred[1]])
        x_new, P_new = blocks.kf_correct(x_pred, P_pred, innovation, H, R)
        return x_new, P_new, innovation, z[0] - innovation[0]
    A, B, _, _ = blocks.bicycle(vehicle, vx_prev)
    Phi, Gamma = blocks.discretise(settings["discretisation"], A, B, T)
    x_pred, P_pred = blocks.kf_predict(x, P, Phi, Gamma, np.array([delta_prev]), Qd)
    _, _, C, D = blocks.bicycle(vehicle, vx)
    innovation = np.asarray(z) - C @ x_pred - D @ np.array([delta])
    x_new, P_new = blocks.kf_correct(x_pred, P_pred, innovation, C, R)
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


def _tanh_axle(C: float, peak: float, alpha: float):
    u = C * alpha / peak
    return peak * np.tanh(u), C / np.cosh(u) ** 2
