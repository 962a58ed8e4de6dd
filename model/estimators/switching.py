"""switching: seed 000's sideslip estimator, switching between a kinematic and a dynamic scheme.

docs/methods.md, seed 000, §2.2-2.10 with the §5 defaults:

* shared pre-processing (model.estimators.kinematic_dynamic, the ``select`` kernel): prefilter [E6],
  reliability checks of r against r_ref [E7-E10] and of a_y,b against vx r [E11] with
  hold-last-valid and a time-out (A6, status REFERENCE_SUSPECT), median a_y,f [E23];
  mode = KIN if |a_y,f| > threshold [E24] (options beyond the paper: hysteresis, A7, a
  threshold adapted to the lateral acceleration the road has carried, A10, and a bound on the
  kinematic dwell, kinematic_max_dwell);
* dynamic scheme (KF, kf2dof's ``dynamic_update`` with this table's KF settings), entered from KIN
  with x = [vy_kin, r_k-1], P = P_0 [E26]; z = [a_y,m raw, r_k] (A3);
* kinematic scheme: vy_kin += T (a_y,k-1 - r_k-1 vx_k-1) [E14], entered from DYN with
  vy_kin = the last KF vy [E25]; the KF is not propagated in KIN;
* beta = atan2(vy, vx) in both (A14); hold rule (§2.10) in kinematic_dynamic.KinematicDynamic.held.

Only the active scheme is evaluated in the generated C (model.estimator.Schemes).
"""

from __future__ import annotations

from dataclasses import replace

import casadi as ca

from vsegen.model import signals, status
from vsegen.model.bicycle import sideslip
from vsegen.model.calibration import Parameters
from vsegen.model.estimator import (
    BEYOND_LINEAR,
    KF_MEASUREMENT_NOISE,
    LOW_FRICTION,
    ROLL_GRADIENT,
    TYRE_FRICTION,
    CheckSegment,
    Definition,
    Estimator,
    Tunable,
    make_functions,
    make_schemes,
)
from vsegen.model.estimators import kf2dof, kinematic_offset
from vsegen.model.estimators.kinematic_dynamic import (
    DYN,
    KIN,
    KINEMATIC_DYNAMIC_FIELDS,
    KINEMATIC_INPUTS,
    YAW_RATE_CHECK_TUNABLES,
    KinematicDynamic,
)
from vsegen.model.estimators.kinematic_dynamic import STATUS_BITS as KINEMATIC_DYNAMIC_STATUS
from vsegen.model.input_checks import frozen
from vsegen.model.layout import Layout
from vsegen.model.monitor_block import Checks
from vsegen.model.schema import KF_FIELDS, LOW_SPEED_RULES, EstimatorSchema, below, fraction, nonnegative, positive
from vsegen.model.signals import Signal
from vsegen.model.status import KINEMATIC_DWELL_LIMITED

NAME = "switching"

CHECKS = Checks(kf2dof.METHOD_INPUTS)
"""Beyond the paper: the monitor block (model.monitor_block): the input monitors."""
SCHEMA = EstimatorSchema(
    fields=(*KF_FIELDS, *KINEMATIC_DYNAMIC_FIELDS,
            nonnegative("hysteresis", "m/s^2", "beyond the paper (A7): enter the kinematic "
                        "scheme above threshold + hysteresis, leave it below threshold - "
                        "hysteresis; 0 = the paper's single threshold", default=0.0),
            nonnegative("adaptive_memory", "s", "beyond the paper (A10): time constant of the "
                        "memory of the peak |a_y,f| the road has carried; the threshold rises to "
                        "adaptive_fraction times that peak, at most adaptive_max; 0 = off "
                        "(the paper's fixed threshold)", default=0.0),
            fraction("adaptive_fraction", "share of the remembered peak |a_y,f| used as the "
                     "threshold (adaptive_memory > 0 only)", default=0.8),
            positive("adaptive_max", "m/s^2", "upper bound of the adaptive threshold "
                     "(adaptive_memory > 0 only)", default=2.5),
            *kinematic_offset.FIELDS,
            nonnegative("kinematic_max_dwell", "s", "beyond the paper: longest stay in the kinematic "
                        "scheme while |a_y,f| stays above the threshold; then the dynamic scheme takes "
                        "over (status KINEMATIC_DWELL_LIMITED) until |a_y,f| falls below it; 0 = "
                        "unbounded (the paper)", default=0.0),
            *CHECKS.fields),
    rules=(*LOW_SPEED_RULES, below("hysteresis", "threshold", "a number >= 0", "m/s^2")))
HOLD = 2
PEAK = Signal("ay_peak", "m/s^2", "remembered peak |a_y,f| (adaptive threshold)")
DWELL = Signal("kin_samples", "-", "samples in the kinematic scheme since |a_y,f| last fell below the "
                                   "threshold (kinematic_max_dwell)")


def _dwell_bounded(settings) -> bool:
    """Whether the kinematic dwell is bounded (``kinematic_max_dwell`` > 0: its counter exists)."""
    return settings["kinematic_max_dwell"] > 0.0


def extra_states(settings) -> tuple[Signal, ...]:
    """switching's own state entries: the remembered peak (adaptive threshold on), the kinematic
    dwell counter (kinematic_max_dwell > 0) and the learned offset (offset_memory > 0)."""
    return (*((PEAK,) if settings["adaptive_memory"] > 0.0 else ()),
            *((DWELL,) if _dwell_bounded(settings) else ()),
            *kinematic_offset.states(settings))


OUTPUTS = Layout((
    Signal("beta", "rad", "sideslip angle at the CG, atan2(vy, vx) of the active scheme"),
    Signal("vy", "m/s", "lateral velocity of the active scheme"),
    Signal("r", "rad/s", "yaw rate after the reliability check"),
    Signal("mode", "-", "0 = dynamic (KF), 1 = kinematic", integer=True),
    signals.STATUS,
))
SCRATCH = Layout((
    Signal("scheme", "-", "scheme to run: 0 dynamic, 1 kinematic, 2 hold"),
    Signal("r_checked", "rad/s", "reliability-checked yaw rate of this sample"),
    Signal("r_prev", "rad/s", "checked yaw rate of the previous sample"),
    Signal("ay_prev", "m/s^2", "checked a_y of the previous sample"),
    Signal("mode_prev", "-", "mode of the previous sample"),
    Signal("status", "-", "status bits of this sample"),
))
KF_INPUTS_FROZEN = Signal("kf_inputs_frozen", "-", "1 while a_y or r is frozen: the KF's friction scale keeps its "
                          "prior")


def scratch_layout(seed: KinematicDynamic) -> Layout:
    """SCRATCH, and whether the KF's inputs are frozen where it estimates the friction."""
    return Layout((*SCRATCH.signals, *((KF_INPUTS_FROZEN,) if seed.kf.estimates_friction else ())))


def remembered_peak(seed: KinematicDynamic, ay_filtered, previous_peak):
    """M_k = max(|a_y,f|, M_k-1 exp(-T / adaptive_memory)): the largest lateral acceleration the
    road has recently carried (a lower bound of mu g)."""
    decay = ca.exp(-seed.T / seed.settings["adaptive_memory"])
    return ca.fmax(ca.fabs(ay_filtered), previous_peak * decay)


def switching_threshold(seed: KinematicDynamic, mode_prev, peak=None):
    """a_yT [E24]. Beyond the paper, both off by default: with ``hysteresis`` h > 0 (A7), a_yT + h
    to enter the kinematic scheme and a_yT - h to leave it; with the adaptive threshold (A10),
    a_yT is raised to min(adaptive_fraction M_k, adaptive_max) when that is larger."""
    settings = seed.settings
    threshold, h = settings["threshold"], settings["hysteresis"]
    if peak is not None:
        threshold = ca.fmax(threshold, ca.fmin(settings["adaptive_fraction"] * peak,
                                               settings["adaptive_max"]))
    if isinstance(h, float) and h == 0.0:
        return threshold
    return threshold + ca.if_else(mode_prev == KIN, -h, h)


def wanted_scheme(seed: KinematicDynamic, pre, mode_prev, peak=None):
    """KIN while |a_y,f| is above the threshold, else DYN; beyond the paper, DYN while a_y or r,
    the integrator's inputs, is frozen (the KF only weighs them as measurements)."""
    mode = ca.if_else(ca.fabs(pre.ay_filtered) > switching_threshold(seed, mode_prev, peak), KIN, DYN)
    if frozen.enabled(seed.params.numeric.settings(NAME), KINEMATIC_INPUTS):
        mode = ca.if_else(pre.kinematic_inputs_frozen, DYN, mode)
    return mode


def dwell_limited(seed: KinematicDynamic, candidate, samples):
    """(mode, new kin_samples, limited) of the kinematic dwell bound: the kinematic scheme may run
    for kinematic_max_dwell seconds while |a_y,f| stays above the threshold (``candidate`` KIN);
    then the dynamic scheme takes over until ``candidate`` is DYN again, which resets the count (a
    held sample keeps it: resetting it there would let the integrator restart from the KF's reset
    state for a whole dwell). n > max_dwell / T - 1/2 counts whole samples, robust to rounding in
    float builds."""
    limited = ca.logic_and(candidate == KIN, samples > seed.settings["kinematic_max_dwell"] / seed.T - 0.5)
    mode = ca.if_else(limited, DYN, candidate)
    new_samples = (candidate == KIN) * (samples + (mode == KIN))
    return mode, new_samples, limited


def build(params: Parameters) -> Estimator:
    """The switching estimator ([vehicle], [inputs], [estimator.switching]): the select (pre-processing
    and the choice of scheme), then only the chosen scheme runs."""
    seed = KinematicDynamic(params, NAME, CHECKS, extra_states(params.numeric.settings(NAME)))
    layout = seed.layout
    state, s = layout.symbols("state")
    inputs, u = seed.inputs.symbols("input")
    mid, scratch, checks = _select(seed, s, u)
    schemes, next_state, out = make_schemes(
        NAME, layout, scratch_layout(seed), state, inputs, layout.pack(mid), scratch, _schemes(params, seed), params,
        checks)
    init, step = make_functions(NAME, seed.inputs, layout, OUTPUTS, inputs, state,
                                seed.initial_state(u), next_state, out, params, checks)
    return Estimator(NAME, "sideslip by switching between a kinematic and a KF scheme (seed 000)",
                     seed.inputs, layout, OUTPUTS, init, replace(schemes, step=step), params, seed.notes())


def _select(seed: KinematicDynamic, s: dict, u: dict) -> tuple[dict, ca.SX, CheckSegment | None]:
    """(state entries after the select, the packed SCRATCH, the input checks' segment):
    pre-processing, the remembered peak, the scheme wanted and its dwell bound, the learned offset."""
    T = seed.T
    pre = seed.preprocess(s, u)
    active = pre.guard.active
    extra = {}
    peak = None
    if PEAK in seed.extra:
        peak = remembered_peak(seed, pre.ay_filtered, s["ay_peak"])
        extra["ay_peak"] = ca.if_else(active, peak, s["ay_peak"])
    mode = wanted_scheme(seed, pre, s["mode"], peak)
    status = pre.status
    if DWELL in seed.extra:
        mode, samples, limited = dwell_limited(seed, mode, s["kin_samples"])
        extra["kin_samples"] = ca.if_else(active, samples, s["kin_samples"])
        status = status + ca.if_else(ca.logic_and(active, limited), KINEMATIC_DWELL_LIMITED, 0)
    scheme = ca.if_else(active, mode, HOLD)
    if kinematic_offset.OFFSET in seed.extra:    # learned in near-straight dynamic driving
        extra["kin_offset"] = kinematic_offset.update(seed.settings, T, s["kin_offset"], pre, u["vx"],
                                                      scheme == DYN)
    mid = {**s, **pre.updates, **extra, "mode": ca.if_else(active, mode, DYN)}
    layout = scratch_layout(seed)
    frozen_inputs = {KF_INPUTS_FROZEN.name: pre.kinematic_inputs_frozen} if KF_INPUTS_FROZEN in layout.signals else {}
    scratch = layout.pack({"scheme": scheme, "r_checked": pre.r_checked, "r_prev": s["r_last"],
                           "ay_prev": s["ay_last"], "mode_prev": s["mode"], "status": status, **frozen_inputs})
    return mid, scratch, pre.checks


def _output(beta, vy, r, mode_value, code):
    return OUTPUTS.pack({"beta": beta, "vy": vy, "r": r, "mode": mode_value, "status": code})


def _schemes(params: Parameters, seed: KinematicDynamic) -> list:
    """The three schemes (dynamic, kinematic, hold), each a function of the select's state entries,
    its SCRATCH and the inputs (``model.estimator.make_schemes``)."""
    layout, T = seed.layout, seed.T
    update = kf2dof.dynamic_update(params, NAME)

    def scheme(label, body):
        mid_sym, m = layout.symbols("state_mid")
        scratch_sym, c = scratch_layout(seed).symbols("scratch")
        input_sym, v = seed.inputs.symbols("input")
        next_state, output = body(m, c, v)
        return label, mid_sym, scratch_sym, input_sym, layout.pack(next_state), output

    def dynamic(m, c, v):
        from_kin = c["mode_prev"] == KIN
        x = ca.vertcat(ca.if_else(from_kin, m["vy_kin"], m["vy"]),
                       ca.if_else(from_kin, c["r_prev"], m["r"]), *[m[n] for n in seed.kf.names[2:]])
        P = ca.if_else(from_kin, seed.kf.P0, seed.kf.P(m))
        result = update(x=x, P=P, delta_prev=m["delta_prev"], vx_prev=m["vx_prev"],
                        delta=v["delta"], vx=v["vx"],
                        ay=seed.roll_corrected(v["ay"])
                        - kinematic_offset.sensor_part(seed.settings, m.get("kin_offset", 0)),
                        r_meas=c["r_checked"],
                        **seed.kf.learning(c.get(KF_INPUTS_FROZEN.name)),
                        **params.keyword())
        vy = result["x_next"][0]
        changes = seed.kf.entries(result["x_next"], result["P_next"])
        return (seed.advanced(m, v, changes),
                _output(result["beta"], vy, c["r_checked"], DYN, c["status"]))

    def kinematic(m, c, v):
        start = ca.if_else(c["mode_prev"] == DYN, m["vy"], m["vy_kin"])
        vy_kin = start + T * (c["ay_prev"] - c["r_prev"] * m["vx_prev"] - m.get("kin_offset", 0))
        return (seed.advanced(m, v, {"vy_kin": vy_kin}),
                _output(sideslip(vy_kin, seed.speed(v["vx"])), vy_kin, c["r_checked"], KIN,
                        c["status"]))

    def held(m, c, v):
        return seed.held(m, v), _output(ca.SX(0), ca.SX(0), m["r_last"], ca.SX(DYN), c["status"])

    return [scheme("dynamic", dynamic), scheme("kinematic", kinematic), scheme("hold", held)]


DEFINITIONS = (Definition(
    name=NAME, build=build, schema=SCHEMA,
    tunable={**kf2dof.KF_TUNABLES,
             "threshold": Tunable(0.5, 4.0, log=False, regime=LOW_FRICTION),
             "hysteresis": Tunable(0.0, 1.0, log=False, regime=LOW_FRICTION),
             "kinematic_max_dwell": Tunable(0.2, 3.0, when=_dwell_bounded, regime=BEYOND_LINEAR),
             **YAW_RATE_CHECK_TUNABLES, "lateral_acceleration_band": Tunable(1.0, 8.0, regime=LOW_FRICTION)},
    status_bits=(*KINEMATIC_DYNAMIC_STATUS, status.KINEMATIC_DWELL_LIMITED, *CHECKS.status_bits),
    monitors=CHECKS.block,
    derived={**ROLL_GRADIENT, **KF_MEASUREMENT_NOISE, **TYRE_FRICTION}),)
