"""Reference kinematic/dynamic sideslip machinery shared by seed 000's switching and fusion
estimators (docs/methods.md, seed 000 §2.2, §2.3, §2.6, §2.9, §2.10), in NumPy/SciPy."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import scipy.signal

from vsegen.harness.reference import bicycle_kf, blocks

INPUTS = ("delta", "vx", "ay", "r")
"""What the schemes read; an estimator's monitor block may add its monitors' (its ``inputs``)."""
DYN, KIN = 0, 1
KINEMATIC_INPUTS = ("ay", "r")
"""The kinematic integrator's inputs beside the speed (model: kinematic_dynamic.KINEMATIC_INPUTS)."""
GRAVITY = blocks.GRAVITY


def roll_corrected(config, table, ay_measured):
    """Accelerometer reading without the gravity component of body roll (``blocks``)."""
    return blocks.roll_corrected(ay_measured, config.settings(table)["roll_gradient"])


def median_length(config, table) -> int:
    return 2 * round(config.settings(table)["median_span"] / config.sample_time / 2) + 1


def state_names(config, table, block, extra: tuple[str, ...] = ()) -> tuple[str, ...]:
    """The state entries; ``block`` the estimator's monitor block
    (``harness.reference.monitor_block``: its model checks', and last its input checks'), ``extra``
    its own entries (0 at init, kept while holding)."""
    n = median_length(config, table)
    s = config.settings(table)
    return ("ay_m_1", "ay_m_2", "ay_b_1", "ay_b_2",
            *(f"ay_b_hist_{i}" for i in range(1, n)),
            "r_last", "ay_last", "r_rejections", "ay_rejections", "mode", "vy_kin",
            *bicycle_kf.names(s), *bicycle_kf.covariance_names(s), "delta_prev", "vx_prev",
            *block.states, "holding", *extra, *block.segment)


def prefilter(config, table):
    """(b, a) of the Tustin-discretised prefilter (blocks.tustin)."""
    s = config.settings(table)
    return _prefilter(s["prefilter"], s["prefilter_omega"], config.sample_time)


@lru_cache(maxsize=16)
def _prefilter(kind: str, omega: float, T: float):
    if kind == "printed":
        num, den = (10000.0,), (1.0, 200.0, 10000.0)
    else:
        num, den = scipy.signal.bessel(2, omega, analog=True, norm="phase")
    return blocks.tustin(tuple(num), tuple(den), T)


def reference_yaw_rate(config, delta, vx):
    v = config.vehicle
    l = v["cg_to_front_axle"] + v["cg_to_rear_axle"]
    ks = v["mass"] / l**2 * (v["cg_to_rear_axle"] / v["cornering_stiffness_front"]
                             - v["cg_to_front_axle"] / v["cornering_stiffness_rear"])
    return delta * vx / (l * (1 + ks * vx * vx))


def clamp(config, table, vx):
    return min(max(vx, config.settings(table)["vx_min"]), config.limits["vx_max"])


def check(measured, reference, band, last, rejections, timeout):
    """(value, last, rejections, forced) of a reliability check ([E10], A6)."""
    if abs(measured - reference) <= band:
        return measured, measured, 0.0, False
    if rejections + 1 >= timeout:
        return measured, measured, 0.0, True
    return last, last, rejections + 1, False


def init(config, table, block, u0, extra: tuple[str, ...] = ()):
    s = config.settings(table)
    first, holding = blocks.first_sample(config.limits, dict(zip(block.inputs, u0)), s["vx_min"],
                                         s["vx_resume"], block.monitored)
    delta, vx, r = first["delta"], first["vx"], first["r"]
    ay = roll_corrected(config, table, first["ay"])
    b, a = prefilter(config, table)
    ay_b = ay * b.sum() / a.sum()  # DC steady state of the prefilter
    r_ref = reference_yaw_rate(config, delta, clamp(config, table, vx))
    r_last = r if abs(r - r_ref) <= s["yaw_rate_band"] or s["yaw_rate_check"] == "yaw_acceleration" else r_ref
    n = median_length(config, table)
    entries = {"ay_m_1": ay, "ay_m_2": ay, "ay_b_1": ay_b, "ay_b_2": ay_b,
               **{f"ay_b_hist_{i}": ay_b for i in range(1, n)}, "r_last": r_last, "ay_last": ay_b,
               "r_rejections": 0.0, "ay_rejections": 0.0, "mode": DYN, "vy_kin": 0.0,
               **bicycle_kf.initial_entries(s, r), "delta_prev": delta, "vx_prev": vx, **block.initial(first),
               "holding": holding, **dict.fromkeys(extra, 0.0)}
    return np.array([entries[k] for k in state_names(config, table, block, extra)])


def held(config, table, x, inputs, ok):
    """State while holding (§2.10)."""
    s = config.settings(table)
    new = dict(x)
    new.update(vy_kin=0.0, vy=0.0, mode=DYN, holding=1.0,
               **dict(zip(bicycle_kf.covariance_names(s), blocks.packed(bicycle_kf.initial_covariance(s)))))
    new["delta_prev"], new["vx_prev"] = blocks.kept_previous(inputs, ok, x["delta_prev"],
                                                             x["vx_prev"])
    return new


def preprocess(config, table, x, u):
    """Prefilter, checks and median of an active sample (inputs ``u`` by name): (new entries, r_k,
    a_y,f, suspect); the checked a_y,k is the new ``ay_last``."""
    s = config.settings(table)
    delta, vx_raw, ay_raw, r_m = u["delta"], u["vx"], u["ay"], u["r"]
    ay_m = roll_corrected(config, table, ay_raw)
    vx = clamp(config, table, vx_raw)
    b, a = prefilter(config, table)
    ay_b = (b[0] * ay_m + b[1] * x["ay_m_1"] + b[2] * x["ay_m_2"]
            - a[1] * x["ay_b_1"] - a[2] * x["ay_b_2"])
    timeout = max(1, round(s["reference_timeout"] / config.sample_time))
    if s["yaw_rate_check"] == "reference":
        r_ref, band = reference_yaw_rate(config, delta, vx), s["yaw_rate_band"]
    else:
        r_ref = x["r_last"]
        band = s["yaw_rate_jump"] + s["yaw_acceleration_max"] * config.sample_time * (x["r_rejections"] + 1)
    r_k, r_last, r_rej, r_forced = check(r_m, r_ref, band, x["r_last"], x["r_rejections"], timeout)
    _, ay_last, ay_rej, ay_forced = check(ay_b, vx * r_k, s["lateral_acceleration_band"],
                                             x["ay_last"], x["ay_rejections"], timeout)
    n = median_length(config, table)
    history = [ay_b] + [x[f"ay_b_hist_{i}"] for i in range(1, n)]
    new = dict(ay_m_1=ay_m, ay_m_2=x["ay_m_1"], ay_b_1=ay_b, ay_b_2=x["ay_b_1"], r_last=r_last,
               ay_last=ay_last, r_rejections=r_rej, ay_rejections=ay_rej)
    for i in range(1, n):
        new[f"ay_b_hist_{i}"] = history[i - 1]
    return new, r_k, float(np.median(history)), r_forced or ay_forced


def learned_offset(s, T: float, offset: float, ay_f: float, ay: float, r: float, vx: float,
                   allowed: bool = True) -> float:
    """The kinematic offset c (beyond the paper): learned towards a_y - r v_x (the checked
    ``ay``, ``r``) while ``allowed`` and near straight, |a_y,f - c| and |r v_x| below offset_band."""
    band = s["offset_band"]
    if not (allowed and abs(ay_f - offset) < band and abs(r * vx) < band):
        return offset
    return blocks.low_pass(offset, ay - r * vx, T, s["offset_memory"])


def kalman(config, table, x, P, delta_prev, vx_prev, u, r_k, ay_offset: float = 0.0, inputs_frozen: bool = False):
    """The 2-DOF KF (harness.reference.bicycle_kf) from its state ``x`` ([vy, r], and the friction
    scale where it is estimated) and ``P``: predict with the previous inputs, update with
    z = [a_y,m - ay_offset, r_k]; returns (x, P, the prior innovation z - h(x-), the prior's a_y)
    as bicycle_kf.step (``inputs_frozen``: a_y or r frozen)."""
    z = np.array([roll_corrected(config, table, u["ay"]) - ay_offset, r_k])
    return bicycle_kf.step(config.settings(table), config.vehicle, config.sample_time, x, P,
                           delta_prev, clamp(config, table, vx_prev), u["delta"], clamp(config, table, u["vx"]), z,
                           inputs_frozen)


def beta(config, table, vy, vx):
    return math.atan2(vy, clamp(config, table, vx))


def step(config, table, block, state, u, scheme, extra: tuple[str, ...] = ()):
    """One step of a seed-000 estimator: the hold rule; when active, the shared pre-processing
    (§2.2-2.4) and then ``scheme(x, updates, r_k, ay_f, status, u) -> (next state by name,
    output)``, with ``x`` the state by name, ``updates`` the pre-processing's new entries and
    ``status`` including blocks.REFERENCE_SUSPECT, ``u`` the inputs by name. When not active: the
    held state and the output [0, 0, r_last, DYN, status]."""
    s = config.settings(table)
    names = state_names(config, table, block, extra)
    x = dict(zip(names, state))
    inputs = dict(zip(block.inputs, u))
    active, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                          x["holding"] > 0.5, block.monitored)
    watched, flags = block.watch_inputs(x, inputs, ok, active, config.sample_time, config.vehicle, config.limits)
    if not active:
        new = held(config, table, x, inputs, ok) | watched
        return (np.array([new[k] for k in names]),
                np.array([0.0, 0.0, x["r_last"], DYN, status]))
    updates, r_k, ay_f, suspect = preprocess(config, table, x, inputs)
    status += (blocks.REFERENCE_SUSPECT if suspect else 0) + flags
    new, output = scheme(x, updates, r_k, ay_f, status, inputs)
    return np.array([(new | watched)[k] for k in names]), np.array(output)
