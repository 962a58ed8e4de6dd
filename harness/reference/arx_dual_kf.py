"""Reference arx_dual_kf (docs/methods.md, seed 004 §2, §3 and §5 defaults):
ARX(2) yaw-rate model, KF1 in companion form on [x_n, x_n-1], KF2 on the ARX parameters with
R_theta = K1^2 R, the E5 safeguards (excitation, low speed, root projection), priors from the
ZOH bicycle model at the first speed (§2.5). NumPy/SciPy only."""

from __future__ import annotations

import math

import numpy as np

from vsegen.harness.reference import blocks

TABLE = "arx_dual_kf"
INPUTS = ("delta", "vx", "r", "mz")


def _theta_names(config):
    extra = ("b_delta",) if config.settings(TABLE)["exogenous"] == "mz_delta" else ()
    return ("a1", "a2", "b_mz", *extra)


def names(config):
    theta = _theta_names(config)
    states = ("x_1", "x_2", *blocks.upper_names("P", ("x_1", "x_2")), *theta,
              *blocks.upper_names("Pt", theta), "mz_prev",
              *(("delta_prev",) if "b_delta" in theta else ()), "low_speed_hold")
    return INPUTS, states, ("r", *theta, "gain", "status")


def _input_scales(config):
    """First-order b_mz = T/I_z and b_delta = T a C_f / I_z (noise scales)."""
    v, T = config.vehicle, config.sample_time
    scales = [T / v["yaw_inertia"]]
    if config.settings(TABLE)["exogenous"] == "mz_delta":
        scales.append(T * v["cg_to_front_axle"] * v["cornering_stiffness_front"] / v["yaw_inertia"])
    return scales


def _prior(config, vx):
    A, B_delta, _, _ = blocks.bicycle(config.vehicle, vx)
    B = np.hstack([B_delta, [[0.0], [1.0 / config.vehicle["yaw_inertia"]]]])
    Phi, Gamma = blocks.discretise("zoh", A, B, config.sample_time)
    theta = [np.trace(Phi), -np.linalg.det(Phi), Gamma[1, 1]]
    if config.settings(TABLE)["exogenous"] == "mz_delta":
        theta.append(Gamma[1, 0])
    return theta


def init(config, u0):
    s = config.settings(TABLE)
    first, holding = blocks.first_sample(config.limits, dict(zip(INPUTS, u0)), s["vx_min"],
                                         s["vx_resume"])
    vx0 = min(max(first["vx"], s["vx_min"]), config.limits["vx_max"])
    theta = _prior(config, vx0)
    P_theta = np.diag([s["ar_initial_variance"]] * 2
                      + [(s["input_initial_factor"] * b) ** 2 for b in _input_scales(config)])
    delta = [first["delta"]] if len(theta) == 4 else []
    R = s["measurement_noise"]
    return np.array([first["r"], first["r"], R, 0.0, R, *theta, *blocks.packed(P_theta), first["mz"],
                     *delta, holding])


def step(config, state, u):
    s = config.settings(TABLE)
    _, state_names, _ = names(config)
    x = dict(zip(state_names, state))
    inputs = dict(zip(INPUTS, u))
    theta_names = _theta_names(config)
    n = len(theta_names)
    _, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                     x["low_speed_hold"] > 0.5)
    low = bool(status & blocks.LOW_SPEED)   # only the parameter filter pauses (E5)
    R, Q = s["measurement_noise"], s["model_noise"]

    # KF1 [B1]-[B6]
    theta = np.array([x[k] for k in theta_names])
    previous = [x["mz_prev"]] + ([x["delta_prev"]] if n == 4 else [])
    phi = np.array([x["x_1"], x["x_2"], *previous])
    prediction = float(phi @ theta)
    A = np.array([[theta[0], theta[1]], [1.0, 0.0]])
    P = blocks.unpacked([x["P_x_1_x_1"], x["P_x_1_x_2"], x["P_x_2_x_2"]], 2)
    P_pred = A @ P @ A.T + np.diag([Q, 0.0])
    s_pred = np.array([prediction, x["x_1"]])
    if ok["r"]:
        h = np.array([[1.0, 0.0]])
        gain = P_pred[0, 0] / (P_pred[0, 0] + R)
        s_new, P_new = blocks.kf_update(s_pred, P_pred, np.array([inputs["r"]]), h,
                                        np.zeros((1, 1)), np.zeros(1), np.array([[R]]))
    else:
        gain, s_new, P_new = 0.0, s_pred, P_pred
    x_n = s_new[0]

    # KF2 [C1]-[C6] with the E5 skips
    P_theta = blocks.unpacked([x[k] for k in blocks.upper_names("Pt", theta_names)], n) + np.diag(
        [s["ar_drift"]] * 2 + [(s["input_drift"] * b) ** 2 for b in _input_scales(config)])
    updated = ok["r"] and ok["vx"] and not low and phi @ P_theta @ phi >= s["excitation_floor"]
    if updated:
        theta, P_theta = blocks.kf_update(theta, P_theta, np.array([x_n]), phi[None, :],
                                          np.zeros((1, 1)), np.zeros(1),
                                          np.array([[gain * gain * R]]))
    a1, a2 = theta[0], theta[1]
    discriminant = a1 * a1 + 4 * a2
    rho = (abs(a1) + math.sqrt(discriminant)) / 2 if discriminant >= 0 else math.sqrt(max(-a2, 0.0))
    if updated and rho > s["stability_radius"]:                               # E5, after (C6)
        scale = s["stability_radius"] / rho
        theta = np.array([a1 * scale, a2 * scale * scale, *theta[2:]])
        status |= blocks.PARAMETERS_PROJECTED

    new = {"x_1": x_n, "x_2": s_new[1], "P_x_1_x_1": P_new[0, 0], "P_x_1_x_2": P_new[0, 1],
           "P_x_2_x_2": P_new[1, 1], **dict(zip(theta_names, theta)),
           **dict(zip(blocks.upper_names("Pt", theta_names), blocks.packed(P_theta))),
           "mz_prev": inputs["mz"] if ok["mz"] else 0.0, "low_speed_hold": 1.0 if low else 0.0}
    if n == 4:
        new["delta_prev"] = inputs["delta"] if ok["delta"] else 0.0
    return (np.array([new[k] for k in state_names]),
            np.array([x_n, *theta, gain, float(status)]))
