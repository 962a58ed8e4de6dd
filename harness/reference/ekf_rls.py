"""Reference ekf_rls (docs/methods.md, seed 001 §2, §3 and §5 defaults):
filtered yaw acceleration, axle forces and wheel loads, RLS of the left/right normalised
stiffness (or per axle against the EKF prior's or a kinematic slip angle), the EKF in beta form
(Euler, y = r), the stiffness-rate weight and the integral method re-seeded from the fused beta.
NumPy/SciPy only."""

from __future__ import annotations

import math

import numpy as np

from vsegen.harness.reference import blocks
from vsegen.harness.reference.monitor_block import Checks

TABLE = "ekf_rls"
GRAVITY = blocks.GRAVITY
INPUTS = ("delta", "vx", "ax", "ay", "r")
"""What the method reads; the monitors may add theirs (:func:`input_names`)."""
CHECKS = Checks(consistency=True, linear_range=True)
EKF_P = blocks.upper_names("P", ("beta", "r"))
RLS_P = blocks.upper_names("Prls", ("c0_1", "c0_2"))
STATES = ("beta_ekf", "r_ekf", *EKF_P, "c0_1", "c0_2", *RLS_P, "c_front",
          "c_rear", "r_last", "r_dot", "indicator", "beta", "holding")
OUTPUTS = ("beta", "beta_ekf", "beta_int", "r", "weight", "c_front", "c_rear", "status")
KINEMATIC = ("beta_kin", "ax_f", "ay_f", "r_f", "delta_f", "beta_f")
"""States of the ``kinematic_slip`` regressor: its integral method (re-seeded from the fused beta
only while lambda = 0) and the low-passed a_x, a_y, r, delta and beta_kin."""


def _monitors(config):
    return CHECKS.block(INPUTS, config.settings(TABLE))


def input_names(config) -> tuple[str, ...]:
    return _monitors(config).inputs


def names(config):
    return input_names(config), states(config), OUTPUTS


def states(config) -> tuple[str, ...]:
    s = config.settings(TABLE)
    kinematic = s["stiffness_regressor"] == "kinematic_slip"
    block = _monitors(config)
    return (*STATES, *(KINEMATIC if kinematic else ()), *block.states, *block.segment)


def _loads(v, ax, ay):
    """F_z fl, fr, rl, rr [23], each at least 5 % of m g / 4."""
    m, a, b, h, d = v["mass"], v["cg_to_front_axle"], v["cg_to_rear_axle"], v["cg_height"], v["track_width"]
    L = a + b
    static = np.array([b, b, a, a]) * m * GRAVITY / (2 * L)
    pitch = np.array([-1, -1, 1, 1]) * m * ax * h / (2 * L)
    roll = np.array([-b, b, -a, a]) * m * ay * h / (L * d)
    return np.maximum(static + pitch + roll, 0.05 * m * GRAVITY / 4)


def _c0_nominal(v):
    return (v["cornering_stiffness_front"] + v["cornering_stiffness_rear"]) / (v["mass"] * GRAVITY)


def _axles(regressor, c0_1, c0_2, loads):
    """C_f, C_r: from left/right normalised stiffness [24, 25], or front/rear (per-axle
    regressors)."""
    fl, fr, rl, rr = loads
    if regressor == "literal":
        return c0_1 * fl + c0_2 * fr, c0_1 * rl + c0_2 * rr
    return c0_1 * (fl + fr), c0_2 * (rl + rr)


def _f(v, x, delta, vx, cf, cr):
    """2-DOF model in beta form with small-angle slip angles."""
    m, iz, a, b = v["mass"], v["yaw_inertia"], v["cg_to_front_axle"], v["cg_to_rear_axle"]
    beta, r = x
    fyf = cf * (delta - beta - a * r / vx) * math.cos(delta)
    fyr = cr * (-beta + b * r / vx)
    return np.array([(fyf + fyr) / (m * vx) - r, (a * fyf - b * fyr) / iz])


def _jacobian(v, delta, vx, cf, cr):
    m, iz, a, b = v["mass"], v["yaw_inertia"], v["cg_to_front_axle"], v["cg_to_rear_axle"]
    c = math.cos(delta)
    return np.array([
        [-(cf * c + cr) / (m * vx), (b * cr - a * cf * c) / (m * vx * vx) - 1.0],
        [(b * cr - a * cf * c) / iz, -(a * a * cf * c + b * b * cr) / (iz * vx)],
    ])


def _integral(beta_prev, T, vx, ax, ay, r):
    """One Euler step of the integral method [35, 36]."""
    return beta_prev + T * ((ay * math.cos(beta_prev) - ax * math.sin(beta_prev))
                            / (vx / math.cos(beta_prev)) - r)


def init(config, u0):
    s, v, block = config.settings(TABLE), config.vehicle, _monitors(config)
    first, holding = blocks.first_sample(config.limits, dict(zip(block.inputs, u0)), s["vx_min"],
                                         s["vx_resume"], block.monitored)
    c0 = _c0_nominal(v)
    ay0 = blocks.roll_corrected(first["ay"], s["roll_gradient"])
    if s["stiffness"] == "rls":
        cf, cr = _axles(s["stiffness_regressor"], c0, c0, _loads(v, first["ax"], ay0))
    else:
        cf, cr = v["cornering_stiffness_front"], v["cornering_stiffness_rear"]
    P0 = np.array(s["initial_covariance"])
    p = s["rls_initial_covariance"]
    kinematic = {"beta_kin": 0.0, "ax_f": first["ax"], "ay_f": ay0, "r_f": first["r"],
                 "delta_f": first["delta"], "beta_f": 0.0}
    extra = {**kinematic, **block.initial(first)}
    return np.array([0.0, first["r"], P0[0, 0], P0[0, 1], P0[1, 1], c0, c0, p, 0.0, p, cf, cr,
                     first["r"], 0.0, 0.0, 0.0, holding,
                     *(extra[k] for k in states(config)[len(STATES):])])


def step(config, state, u):
    s, v, T = config.settings(TABLE), config.vehicle, config.sample_time
    names, block = states(config), _monitors(config)
    x = dict(zip(names, state))
    inputs = dict(zip(block.inputs, u))
    active, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                          x["holding"] > 0.5, block.monitored)
    watched, flags = block.watch_inputs(x, inputs, ok, active, T, config.vehicle, config.limits)   # beyond the paper
    if not active:
        held = dict(x, holding=1.0) | watched
        return (np.array([held[k] for k in names]),
                np.array([0.0, 0.0, 0.0, x["r_ekf"], 0.0, x["c_front"], x["c_rear"], float(status)]))
    delta, vx, ax, r = inputs["delta"], inputs["vx"], inputs["ax"], inputs["r"]
    ay = blocks.roll_corrected(inputs["ay"], s["roll_gradient"])
    vx = min(max(vx, s["vx_min"]), config.limits["vx_max"])

    # filtered yaw acceleration s / (tau_d s + 1), Tustin (scipy)
    (b0, b1), (_, a1) = blocks.tustin((1.0, 0.0), (s["derivative_time_constant"], 1.0), T)
    r_dot = b0 * r + b1 * x["r_last"] - a1 * x["r_dot"]

    # the integral method re-seeded from the fused beta [36]; the EKF prior
    beta_int = _integral(x["beta"], T, vx, ax, ay, r)
    xe = np.array([x["beta_ekf"], x["r_ekf"]])
    x_pred = xe + T * _f(v, xe, delta, vx, x["c_front"], x["c_rear"])

    new, y, A, loads = _regression(s, v, T, x, x_pred, delta, vx, ax, ay, r, r_dot)
    new |= watched                          # the input monitors (beyond the paper)
    status |= flags
    X, P, cf, cr = _rls(s, v, T, x, y, A, loads, trusted=flags == 0)

    # EKF with the previous stiffness [13-15]
    Pe = blocks.unpacked([x[k] for k in EKF_P], 2)
    F = np.eye(2) + T * _jacobian(v, delta, vx, x["c_front"], x["c_rear"])
    P_pred = F @ Pe @ F.T + np.array(s["process_noise"]) * T
    innovation = np.array([r - x_pred[1]])
    xe, Pe = blocks.kf_update(x_pred, P_pred, np.array([r]), np.array([[0.0, 1.0]]),
                              np.zeros((1, 1)), np.zeros(1), np.array([[s["measurement_noise"]]]))

    # weight [37], fusion
    rate = max(abs(cf - x["c_front"]) / (T * v["cornering_stiffness_front"]),
               abs(cr - x["c_rear"]) / (T * v["cornering_stiffness_rear"]))
    indicator = x["indicator"] + (1 - math.exp(-T / s["indicator_time_constant"])) * (rate - x["indicator"])
    if s["weighting"] == "stiffness_rate":
        weight = min(max((indicator - s["indicator_low"]) / (s["indicator_high"] - s["indicator_low"]), 0.0), 1.0)
    else:
        weight = 1.0
    beta = (1 - weight) * xe[0] + weight * beta_int
    # beyond the paper: the consistency monitor concerns the output while the EKF carries it; the
    # learned stiffness below its share of the vehicle file's: the tyres past their linear range
    share = s["stiffness_drop_limit"]
    dropped = cf < share * v["cornering_stiffness_front"] or cr < share * v["cornering_stiffness_rear"]
    monitor, judgement, _ = block.judge_model(x, innovation, T, ay, concerns=weight < 0.5, beyond=dropped)
    new |= monitor
    status |= judgement

    new |= {"beta_ekf": xe[0], "r_ekf": xe[1], **dict(zip(EKF_P, blocks.packed(Pe))),
            "c0_1": X[0], "c0_2": X[1], **dict(zip(RLS_P, blocks.packed(P))), "c_front": cf,
            "c_rear": cr, "r_last": r, "r_dot": r_dot, "indicator": indicator, "beta": beta,
            "holding": 0.0}
    return (np.array([new[k] for k in names]),
            np.array([beta, xe[0], beta_int, xe[1], weight, cf, cr, float(status)]))


def _regression(s, v, T, x, x_pred, delta, vx, ax, ay, r, r_dot):
    """The stiffness regression y = A X: forces [21, 22] and loads [23]. Returns (the kinematic-slip
    filters' next values, or {}; y; A; the four wheel loads)."""
    m, iz, a, b = v["mass"], v["yaw_inertia"], v["cg_to_front_axle"], v["cg_to_rear_axle"]
    L = a + b
    new = {}
    regressor = s["stiffness_regressor"]
    if regressor == "kinematic_slip":  # its own integral method; everything low-passed alike
        seeded = s["weighting"] == "stiffness_rate" and x["indicator"] <= s["indicator_low"]
        beta_kin = _integral(x["beta"] if seeded else x["beta_kin"], T, vx, ax, ay, r)
        share = 1.0 - math.exp(-T / s["derivative_time_constant"])
        raw = {"ax_f": ax, "ay_f": ay, "r_f": r, "delta_f": delta, "beta_f": beta_kin}
        new = {"beta_kin": beta_kin, **{k: x[k] + share * (raw[k] - x[k]) for k in raw}}
        beta_s, r_s, delta_s, ay_s = new["beta_f"], new["r_f"], new["delta_f"], new["ay_f"]
        r_dot_s = (new["r_f"] - x["r_f"]) / T
        fl, fr, rl, rr = _loads(v, new["ax_f"], new["ay_f"])
    else:
        beta_s, r_s, delta_s, ay_s, r_dot_s = x_pred[0], x_pred[1], delta, ay, r_dot
        fl, fr, rl, rr = _loads(v, ax, ay)
    fyf = (b * m * ay_s + iz * r_dot_s) / (L * math.cos(delta_s))
    fyr = (a * m * ay_s - iz * r_dot_s) / L
    if regressor == "literal":        # side coefficients (load-proportional split), alpha_eq [18]
        fy = {"fl": fyf * fl / (fl + fr), "fr": fyf * fr / (fl + fr),
              "rl": fyr * rl / (rl + rr), "rr": fyr * rr / (rl + rr)}
        y = np.abs([(fy["fl"] + fy["rl"]) / (fl + rl), (fy["fr"] + fy["rr"]) / (fr + rr)])
        A = abs(delta - L * r / vx) * np.eye(2)
    else:                         # per axle: the EKF prior's (B2) or the kinematic slip angles
        y = np.array([fyf / (fl + fr), fyr / (rl + rr)])
        A = np.diag([delta_s - beta_s - a * r_s / vx, -beta_s + b * r_s / vx])
    return new, y, A, (fl, fr, rl, rr)


def _rls(s, v, T, x, y, A, loads, trusted: bool):
    """RLS [30-33] on excited samples while the input monitors raise nothing (``trusted``; beyond
    the paper), clamped to the stiffness band: (X, P, C_f, C_r)."""
    X = np.array([x["c0_1"], x["c0_2"]])
    P = blocks.unpacked([x[k] for k in RLS_P], 2)
    if trusted and min(abs(A[0, 0]), abs(A[1, 1])) >= s["slip_min"]:
        tau = s["forgetting_factor"] ** (T / 0.001)
        K = P @ A.T @ np.linalg.inv(tau * np.eye(2) + A @ P @ A.T)
        X = X + K @ (y - A @ X)
        P = (np.eye(2) - K @ A) @ P / tau
        P = P * min(1.0, s["rls_covariance_max"] / np.trace(P))
    c0 = _c0_nominal(v)
    X = np.clip(X, s["stiffness_min"] * c0, s["stiffness_max"] * c0)
    if s["stiffness"] == "rls":
        cf, cr = _axles(s["stiffness_regressor"], X[0], X[1], loads)
    else:
        cf, cr = v["cornering_stiffness_front"], v["cornering_stiffness_rear"]
    return X, P, cf, cr
