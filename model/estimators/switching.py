"""switching: seed 000's sideslip estimator, switching between a kinematic and a dynamic scheme.

shared/methods/000-switch-sideslip.md, §2.2-2.10 with the §5 defaults:

* shared pre-processing (the ``select`` kernel): a_y,b = Tustin prefilter(a_y,m) [E6];
  r_ref = delta vx / (l (1 + K_s vx^2)) [E7]; r_k = reliability check of r_m against r_ref with
  half-width yaw_rate_band and hold-last-valid [E9-E10]; a_y,k = check of a_y,b against vx r_k
  [E11]; a_y,f = median of the last N a_y,b [E23]; mode = KIN if |a_y,f| > threshold [E24].
  After reference_timeout of continuous rejection a measurement is accepted again and the status
  bit REFERENCE_SUSPECT is set (A6).
* dynamic scheme (KF, kf2dof's ``dynamic_update`` with this table's KF settings), entered from KIN
  with x = [vy_kin, r_k-1], P = P_0 [E26]; z = [a_y,m raw, r_k] (A3);
* kinematic scheme: vy_kin += T (a_y,k-1 - r_k-1 vx_k-1) [E14], entered from DYN with
  vy_kin = the last KF vy [E25]; the KF is not propagated in KIN;
* beta = atan2(vy, vx) in both (A14); hold rule as kf2dof (model.guard), plus: while holding the
  prefilter, median and reliability buffers are held, vy_kin = vy = 0, P = P_0, mode = DYN.

Only the active scheme is evaluated in the generated C (model.estimator.Schemes).
"""

from __future__ import annotations

import casadi as ca

from model import filters, kalman, status
from model.bicycle import stability_factor
from model.calibration import Parameters, matrix
from model.estimator import Estimator, make_functions, make_schemes
from model.estimators import kf2dof
from model.guard import hold, input_guard
from model.layout import Layout, Signal

NAME = "switching"
DYN, KIN, HOLD = 0, 1, 2

INPUTS = kf2dof.INPUTS
OUTPUTS = Layout((
    Signal("beta", "rad", "sideslip angle at the CG, atan2(vy, vx) of the active scheme"),
    Signal("vy", "m/s", "lateral velocity of the active scheme"),
    Signal("r", "rad/s", "yaw rate after the reliability check"),
    Signal("mode", "-", "0 = dynamic (KF), 1 = kinematic", integer=True),
    Signal("status", "-", "status bits (model.status)", integer=True),
))
SCRATCH = Layout((
    Signal("scheme", "-", "scheme to run: 0 dynamic, 1 kinematic, 2 hold"),
    Signal("r_checked", "rad/s", "reliability-checked yaw rate of this sample"),
    Signal("ay_checked", "m/s^2", "reliability-checked, prefiltered a_y of this sample"),
    Signal("mode_prev", "-", "mode of the previous sample"),
    Signal("status", "-", "status bits of this sample"),
))
_COVARIANCE = kalman.packed_names("P", ("vy", "r"))


def window(params: Parameters) -> int:
    """Median window length N (odd) at the configured sample time."""
    numeric = params.numeric
    return filters.median_window(1.0 / numeric.sample_time, numeric.settings(NAME)["median_span"])


def states(n_median: int) -> Layout:
    return Layout((
        Signal("ay_m_1", "m/s^2", "prefilter input one sample back"),
        Signal("ay_m_2", "m/s^2", "prefilter input two samples back"),
        Signal("ay_b_1", "m/s^2", "prefilter output one sample back"),
        Signal("ay_b_2", "m/s^2", "prefilter output two samples back"),
        *(Signal(f"ay_b_hist_{i}", "m/s^2", f"median buffer: a_y,b {i} samples back")
          for i in range(1, n_median)),
        Signal("r_last", "rad/s", "last accepted yaw rate"),
        Signal("ay_last", "m/s^2", "last accepted a_y,b"),
        Signal("r_rejections", "-", "consecutive yaw-rate rejections"),
        Signal("ay_rejections", "-", "consecutive a_y rejections"),
        Signal("mode", "-", "0 dynamic, 1 kinematic"),
        Signal("vy_kin", "m/s", "kinematic integrator"),
        Signal("vy", "m/s", "KF lateral velocity"),
        Signal("r", "rad/s", "KF yaw rate"),
        *(Signal(n, "SI", "KF covariance entry (upper triangle, row by row)") for n in _COVARIANCE),
        Signal("delta_prev", "rad", "last plausible steer angle"),
        Signal("vx_prev", "m/s", "last plausible speed"),
        Signal("ay_prev", "m/s^2", "checked a_y of the previous sample"),
        Signal("r_prev", "rad/s", "checked yaw rate of the previous sample"),
        Signal("holding", "-", "1 while holding (low speed or invalid input), else 0"),
    ))


def prefilter(params: Parameters) -> filters.Biquad:
    """The configured a_y prefilter, Tustin-discretised at the sample time."""
    settings = params.numeric.settings(NAME)
    design = (filters.printed_prefilter() if settings["prefilter"] == "printed"
              else filters.bessel_prefilter(settings["prefilter_omega"]))
    return filters.tustin_biquad(*design, params.numeric.sample_time)


def reference_yaw_rate(params: Parameters, delta, vx):
    """r_ref = delta vx / (l (1 + K_s vx^2)) [E7]."""
    vehicle = params.config.vehicle
    l = vehicle["cg_to_front_axle"] + vehicle["cg_to_rear_axle"]
    return delta * vx / (l * (1 + stability_factor(vehicle) * vx * vx))


def build(params: Parameters) -> Estimator:
    """The switching estimator ([vehicle], [inputs], [estimator.switching])."""
    config = params.config
    settings = config.settings(NAME)
    T = config.sample_time
    n_median = window(params)
    layout = states(n_median)
    biquad = prefilter(params)
    timeout = max(1, round(params.numeric.settings(NAME)["reference_timeout"] / T))
    vx_min, vx_resume, vx_max = settings["vx_min"], settings["vx_resume"], config.limits["vx_max"]
    P0 = kalman.pack_symmetric(matrix(settings["initial_covariance"]))

    def speed(vx):
        return ca.fmin(ca.fmax(vx, vx_min), vx_max)

    # ---- select: guard, prefilter, reliability checks, median, mode ----------------------------
    state, s = layout.symbols("state")
    inputs, u = INPUTS.symbols("input")
    guard = input_guard(u, config.limits, vx_min, vx_resume, s["holding"])
    ok, active = guard.plausible, guard.active
    ay_m = hold(u["ay"], ok["ay"], s["ay_m_1"])
    ay_b = filters.biquad_step(biquad, ay_m, s["ay_m_1"], s["ay_m_2"], s["ay_b_1"], s["ay_b_2"])
    vx = speed(hold(u["vx"], ok["vx"], vx_min))
    r_m = hold(u["r"], ok["r"], s["r_last"])
    r_ref = reference_yaw_rate(params, hold(u["delta"], ok["delta"], 0), vx)
    r_check = filters.reliability_check(r_m, r_ref, settings["yaw_rate_band"], s["r_last"],
                                        s["r_rejections"], timeout)
    ay_check = filters.reliability_check(ay_b, vx * r_check.value,
                                         settings["lateral_acceleration_band"], s["ay_last"],
                                         s["ay_rejections"], timeout)
    history = [ay_b] + [s[f"ay_b_hist_{i}"] for i in range(1, n_median)]
    ay_f = filters.median(history)
    mode = ca.if_else(ca.fabs(ay_f) > settings["threshold"], KIN, DYN)
    suspect = ca.logic_or(r_check.forced, ay_check.forced)
    code = guard.status + ca.if_else(ca.logic_and(active, suspect), status.REFERENCE_SUSPECT, 0)

    def keep(name, value):
        return ca.if_else(active, value, s[name])

    mid = dict(s)
    mid.update({
        "ay_m_1": keep("ay_m_1", ay_m), "ay_m_2": keep("ay_m_2", s["ay_m_1"]),
        "ay_b_1": keep("ay_b_1", ay_b), "ay_b_2": keep("ay_b_2", s["ay_b_1"]),
        **{f"ay_b_hist_{i}": keep(f"ay_b_hist_{i}", history[i - 1]) for i in range(1, n_median)},
        "r_last": keep("r_last", r_check.last), "ay_last": keep("ay_last", ay_check.last),
        "r_rejections": keep("r_rejections", r_check.rejections),
        "ay_rejections": keep("ay_rejections", ay_check.rejections),
        "mode": ca.if_else(active, mode, DYN),
    })
    scratch = SCRATCH.pack({
        "scheme": ca.if_else(active, mode, HOLD),
        "r_checked": r_check.value, "ay_checked": ay_check.value,
        "mode_prev": s["mode"], "status": code,
    })

    # ---- the three schemes, each from the select's outputs -------------------------------------
    update = kf2dof.dynamic_update(params, NAME)

    def scheme(label, body):
        mid_sym, m = layout.symbols("state_mid")
        scratch_sym, c = SCRATCH.symbols("scratch")
        input_sym, v = INPUTS.symbols("input")
        next_state, output = body(m, c, v)
        return label, mid_sym, scratch_sym, input_sym, next_state, output

    def finish(m, c, v, changes, beta, vy, r, mode_value):
        new = dict(m)
        new.update(changes)
        new["delta_prev"] = v["delta"]
        new["vx_prev"] = v["vx"]
        new["ay_prev"] = c["ay_checked"]
        new["r_prev"] = c["r_checked"]
        new["holding"] = ca.SX(0)
        return layout.pack(new), OUTPUTS.pack({"beta": beta, "vy": vy, "r": r, "mode": mode_value,
                                               "status": c["status"]})

    def dynamic(m, c, v):
        from_kin = c["mode_prev"] == KIN
        x = ca.vertcat(ca.if_else(from_kin, m["vy_kin"], m["vy"]),
                       ca.if_else(from_kin, m["r_prev"], m["r"]))
        P = ca.if_else(from_kin, P0, ca.vertcat(*[m[n] for n in _COVARIANCE]))
        result = update(x=x, P=P, delta_prev=m["delta_prev"], vx_prev=m["vx_prev"],
                        delta=v["delta"], vx=v["vx"], ay=v["ay"], r_meas=c["r_checked"],
                        **({"params": params.symbols} if params.calibratable else {}))
        vy_new = result["x_next"][0]
        changes = {"vy": vy_new, "r": result["x_next"][1],
                   **{n: result["P_next"][i] for i, n in enumerate(_COVARIANCE)}}
        return finish(m, c, v, changes, result["beta"], vy_new, c["r_checked"], DYN)

    def kinematic(m, c, v):
        start = ca.if_else(c["mode_prev"] == DYN, m["vy"], m["vy_kin"])
        vy_kin = start + T * (m["ay_prev"] - m["r_prev"] * m["vx_prev"])
        beta = ca.atan2(vy_kin, speed(v["vx"]))
        return finish(m, c, v, {"vy_kin": vy_kin}, beta, vy_kin, c["r_checked"], KIN)

    def holding(m, c, v):
        plausible = input_guard(v, config.limits, vx_min, vx_resume, ca.SX(1)).plausible
        new = dict(m)
        new.update({"vy_kin": ca.SX(0), "vy": ca.SX(0), "mode": ca.SX(DYN), "holding": ca.SX(1),
                    **{n: P0[i] for i, n in enumerate(_COVARIANCE)},
                    "delta_prev": hold(v["delta"], plausible["delta"], m["delta_prev"]),
                    "vx_prev": hold(v["vx"], plausible["vx"], m["vx_prev"])})
        return layout.pack(new), OUTPUTS.pack({"beta": ca.SX(0), "vy": ca.SX(0), "r": m["r_last"],
                                               "mode": ca.SX(DYN), "status": c["status"]})

    schemes, next_state, output = make_schemes(
        NAME, layout, SCRATCH, state, inputs, layout.pack(mid), scratch,
        [scheme("dynamic", dynamic), scheme("kinematic", kinematic), scheme("hold", holding)],
        params)

    # ---- initialisation (§2.9) -----------------------------------------------------------------
    first = input_guard(u, config.limits, vx_resume, vx_resume, ca.SX(1))
    ay0 = hold(u["ay"], first.plausible["ay"], 0)
    r0 = hold(u["r"], first.plausible["r"], 0)
    delta0 = hold(u["delta"], first.plausible["delta"], 0)
    vx0 = hold(u["vx"], first.plausible["vx"], vx_min)
    r_ref0 = reference_yaw_rate(params, delta0, speed(vx0))
    r_last0 = ca.if_else(ca.fabs(r0 - r_ref0) <= settings["yaw_rate_band"], r0, r_ref0)
    init_state = layout.pack({
        "ay_m_1": ay0, "ay_m_2": ay0, "ay_b_1": ay0 * biquad.dc_gain, "ay_b_2": ay0 * biquad.dc_gain,
        **{f"ay_b_hist_{i}": ay0 * biquad.dc_gain for i in range(1, n_median)},
        "r_last": r_last0, "ay_last": ay0 * biquad.dc_gain, "r_rejections": ca.SX(0),
        "ay_rejections": ca.SX(0), "mode": ca.SX(DYN), "vy_kin": ca.SX(0), "vy": ca.SX(0),
        "r": r0, **{n: P0[i] for i, n in enumerate(_COVARIANCE)},
        "delta_prev": delta0, "vx_prev": vx0, "ay_prev": ay0 * biquad.dc_gain, "r_prev": r_last0,
        "holding": ca.if_else(first.active, 0, 1),
    })
    init, step = make_functions(NAME, INPUTS, layout, OUTPUTS, inputs, state, init_state,
                                next_state, output, params)
    notes = {**kf2dof.zoh_note(params, NAME), "median_window": f"{n_median} samples",
             "prefilter": f"{params.numeric.settings(NAME)['prefilter']}, Tustin: n = "
                          f"[{biquad.n0:.6g}, {biquad.n1:.6g}, {biquad.n2:.6g}], d = "
                          f"[1, {biquad.d1:.6g}, {biquad.d2:.6g}]"}
    return Estimator(NAME, "sideslip by switching between a kinematic and a KF scheme (seed 000)",
                     INPUTS, layout, OUTPUTS, init, step, params, notes, schemes)

