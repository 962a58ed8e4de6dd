"""Reference switching estimator (shared/methods/000-switch-sideslip.md §2.2-2.10, §5 defaults),
written from the spec in NumPy/SciPy: prefilter, reliability checks with hold-last-valid and
time-out, median filter, threshold switch with hand-off both ways, kinematic integrator, the
2-DOF KF (harness.reference.blocks) and the project's hold rule.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal

from harness.reference import blocks

TABLE = "switching"
INPUTS = ("delta", "vx", "ay", "r")
OUTPUTS = ("beta", "vy", "r", "mode", "status")
DYN, KIN = 0, 1
REFERENCE_SUSPECT = 4


def median_length(config) -> int:
    s = config.settings(TABLE)
    return 2 * round(s["median_span"] / config.sample_time / 2) + 1


def state_names(config) -> tuple[str, ...]:
    n = median_length(config)
    return ("ay_m_1", "ay_m_2", "ay_b_1", "ay_b_2",
            *(f"ay_b_hist_{i}" for i in range(1, n)),
            "r_last", "ay_last", "r_rejections", "ay_rejections", "mode", "vy_kin", "vy", "r",
            "P_vy_vy", "P_vy_r", "P_r_r", "delta_prev", "vx_prev", "ay_prev", "r_prev", "holding")


def names(config):
    """(inputs, states, outputs) names of the flat vectors."""
    return INPUTS, state_names(config), OUTPUTS


def _prefilter(config):
    s = config.settings(TABLE)
    if s["prefilter"] == "printed":
        num, den = [10000.0], [1.0, 200.0, 10000.0]
    else:
        num, den = scipy.signal.bessel(2, s["prefilter_omega"], analog=True, norm="phase")
    bz, az = scipy.signal.bilinear(num, den, fs=1.0 / config.sample_time)
    return bz / az[0], az / az[0]


def _r_ref(config, delta, vx):
    v = config.vehicle
    l = v["cg_to_front_axle"] + v["cg_to_rear_axle"]
    ks = v["mass"] / l**2 * (v["cg_to_rear_axle"] / v["cornering_stiffness_front"]
                             - v["cg_to_front_axle"] / v["cornering_stiffness_rear"])
    return delta * vx / (l * (1 + ks * vx * vx))


def _clamp(config, vx):
    return min(max(vx, config.settings(TABLE)["vx_min"]), config.limits["vx_max"])


def init(config, u0):
    s = config.settings(TABLE)
    ok = {n: blocks.plausible(config.limits, n, v) for n, v in zip(INPUTS, u0)}
    delta, vx, ay, r = (v if ok[n] else d for n, v, d in
                        zip(INPUTS, u0, (0.0, s["vx_min"], 0.0, 0.0)))
    active, _, _ = blocks.hold_rule(config.limits, dict(zip(INPUTS, u0)), s["vx_resume"],
                                    s["vx_resume"], True)
    b, a = _prefilter(config)
    ay_b = ay * b.sum() / a.sum()  # DC steady state of the prefilter
    r_ref = _r_ref(config, delta, _clamp(config, vx))
    r_last = r if abs(r - r_ref) <= s["yaw_rate_band"] else r_ref
    P0 = np.array(s["initial_covariance"])
    n = median_length(config)
    return np.array([ay, ay, ay_b, ay_b, *([ay_b] * (n - 1)), r_last, ay_b, 0.0, 0.0, DYN, 0.0,
                     0.0, r, P0[0, 0], P0[0, 1], P0[1, 1], delta, vx, ay_b, r_last,
                     0.0 if active else 1.0])


def _check(measured, reference, band, last, rejections, timeout):
    """(value, last, rejections, forced) of a reliability check (spec [E10], A6)."""
    if abs(measured - reference) <= band:
        return measured, measured, 0.0, False
    if rejections + 1 >= timeout:
        return measured, measured, 0.0, True
    return last, last, rejections + 1, False


def step(config, state, u):
    s = config.settings(TABLE)
    T = config.sample_time
    names_ = state_names(config)
    x = dict(zip(names_, state))
    n = median_length(config)
    inputs = dict(zip(INPUTS, u))
    active, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                          x["holding"] > 0.5)
    P0 = np.array(s["initial_covariance"])
    if not active:
        new = dict(x)
        new.update(vy_kin=0.0, vy=0.0, mode=DYN, holding=1.0, P_vy_vy=P0[0, 0], P_vy_r=P0[0, 1],
                   P_r_r=P0[1, 1])
        if ok["delta"]:
            new["delta_prev"] = inputs["delta"]
        if ok["vx"]:
            new["vx_prev"] = inputs["vx"]
        return np.array([new[k] for k in names_]), np.array([0.0, 0.0, x["r_last"], DYN, status])

    delta, vx_raw, ay_m, r_m = u
    vx = _clamp(config, vx_raw)
    b, a = _prefilter(config)
    ay_b = (b[0] * ay_m + b[1] * x["ay_m_1"] + b[2] * x["ay_m_2"]
            - a[1] * x["ay_b_1"] - a[2] * x["ay_b_2"])
    timeout = max(1, round(s["reference_timeout"] / T))
    r_k, r_last, r_rej, r_forced = _check(r_m, _r_ref(config, delta, vx), s["yaw_rate_band"],
                                          x["r_last"], x["r_rejections"], timeout)
    ay_k, ay_last, ay_rej, ay_forced = _check(ay_b, vx * r_k, s["lateral_acceleration_band"],
                                              x["ay_last"], x["ay_rejections"], timeout)
    history = [ay_b] + [x[f"ay_b_hist_{i}"] for i in range(1, n)]
    mode = KIN if abs(float(np.median(history))) > s["threshold"] else DYN
    if r_forced or ay_forced:
        status += REFERENCE_SUSPECT
    new = dict(x)
    new.update(ay_m_1=ay_m, ay_m_2=x["ay_m_1"], ay_b_1=ay_b, ay_b_2=x["ay_b_1"],
               r_last=r_last, ay_last=ay_last, r_rejections=r_rej, ay_rejections=ay_rej, mode=mode)
    for i in range(1, n):
        new[f"ay_b_hist_{i}"] = history[i - 1]
    if mode == KIN:
        vy_kin = x["vy"] if x["mode"] == DYN else x["vy_kin"]          # [E25]
        vy_kin += T * (x["ay_prev"] - x["r_prev"] * x["vx_prev"])      # [E14]
        new["vy_kin"] = vy_kin
        beta, vy = math.atan2(vy_kin, vx), vy_kin
    else:
        if x["mode"] == KIN:                                            # [E26]
            xk, P = np.array([x["vy_kin"], x["r_prev"]]), P0.copy()
        else:
            xk = np.array([x["vy"], x["r"]])
            P = np.array([[x["P_vy_vy"], x["P_vy_r"]], [x["P_vy_r"], x["P_r_r"]]])
        A, B, _, _ = blocks.bicycle(config.vehicle, _clamp(config, x["vx_prev"]))
        Phi, Gamma = blocks.discretise(s["discretisation"], A, B, T)
        xk, P = blocks.kf_predict(xk, P, Phi, Gamma, np.array([x["delta_prev"]]),
                                  np.array(s["process_noise"]) * T)
        _, _, C, D = blocks.bicycle(config.vehicle, vx)
        xk, P = blocks.kf_update(xk, P, np.array([ay_m, r_k]), C, D, np.array([delta]),
                                 np.array(s["measurement_noise"]))
        new.update(vy=xk[0], r=xk[1], P_vy_vy=P[0, 0], P_vy_r=P[0, 1], P_r_r=P[1, 1])
        beta, vy = math.atan2(xk[0], vx), xk[0]
    new.update(delta_prev=delta, vx_prev=vx_raw, ay_prev=ay_k, r_prev=r_k, holding=0.0)
    return np.array([new[k] for k in names_]), np.array([beta, vy, r_k, mode, status])
