"""fusion: the comparison method of seed 000 (§4.4, a reconstructed stand-in for its ref. [14]).

Both schemes run at every sample on the shared seed-000 pre-processing: the KF (kf2dof's
``dynamic_update``, this table's settings) and the kinematic integrator with an integral correction
towards the KF, vy_kin += T (a_y,k-1 - r_k-1 vx_k-1) + T k_c (vy_KF,k-1 - vy_kin,k-1). The output
is the weighted fusion beta = w beta_kin + (1 - w) beta_KF (and likewise vy), with
w = clamp(|a_y,f| / (2 a_yT), 0, 1). Hold rule as the switching estimator. Beyond the paper, as
switching: the learned kinematic offset c (model.estimators.kinematic_offset; the integrator takes
a_y - r v_x - c, the KF a_y - offset_sensor_share c).
"""

from __future__ import annotations

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
    Definition,
    Estimator,
    Tunable,
    make_guarded,
)
from vsegen.model.estimators import kf2dof, kinematic_offset
from vsegen.model.estimators.kinematic_dynamic import (
    KINEMATIC_DYNAMIC_FIELDS,
    KINEMATIC_INPUTS,
    YAW_RATE_CHECK_TUNABLES,
    KinematicDynamic,
)
from vsegen.model.estimators.kinematic_dynamic import STATUS_BITS as KINEMATIC_DYNAMIC_STATUS
from vsegen.model.guard import hold, symbolic
from vsegen.model.input_checks import frozen
from vsegen.model.layout import Layout
from vsegen.model.monitor_block import Checks
from vsegen.model.schema import KF_FIELDS, LOW_SPEED_RULES, EstimatorSchema, nonnegative, positive
from vsegen.model.signals import Signal

NAME = "fusion"

CHECKS = Checks(kf2dof.METHOD_INPUTS, channels=kf2dof.CHANNELS, linear_range=True)
"""Beyond the paper: the monitor block (model.monitor_block): the input monitors, the consistency
monitor of the KF's innovations and the linear-range flag."""
SCHEMA = EstimatorSchema(
    fields=(*KF_FIELDS, *KINEMATIC_DYNAMIC_FIELDS,
            positive("integral_gain", "1/s", "k_c: integral correction of the kinematic "
                     "integrator towards the KF"),
            nonnegative("disagreement_limit", "rad", "beyond the paper: status SCHEMES_DISAGREE "
                        "while w |beta_kin - beta_KF|, the kinematic scheme's pull on the output away "
                        "from the KF, exceeds this (a bank or an offset drifts the integrator); "
                        "0 = never", default=0.0),
            *kinematic_offset.FIELDS,
            *CHECKS.fields),
    rules=LOW_SPEED_RULES)

OUTPUTS = Layout((
    Signal("beta", "rad", "sideslip angle at the CG, weighted fusion of both schemes"),
    Signal("vy", "m/s", "lateral velocity, weighted fusion"),
    Signal("r", "rad/s", "yaw rate after the reliability check"),
    Signal("weight", "-", "weight w of the kinematic scheme"),
    signals.STATUS,
))


def kinematic_weight(ay_filtered: ca.SX, threshold: float) -> ca.SX:
    """w = |a_y,f| / (2 threshold) (a_y in m/s^2), clamped to [0, 1]: 1/2 at the switching
    threshold. The lower clamp never acts (w is never negative); it keeps the clamp's form."""
    return ca.fmin(ca.fmax(ca.fabs(ay_filtered) / (2 * threshold), 0), 1)


def build(params: Parameters) -> Estimator:
    """The fusion estimator ([vehicle], [inputs], [estimator.fusion])."""
    numeric = params.numeric.settings(NAME)
    seed = KinematicDynamic(params, NAME, CHECKS, kinematic_offset.states(numeric))
    layout, T = seed.layout, seed.T
    state, s = layout.symbols("state")
    inputs, u = seed.inputs.symbols("input")
    guard, decisions = symbolic(seed.guard(s, u))
    pre = seed.preprocess(s, u, guard)
    active = pre.guard.active
    weight = kinematic_weight(pre.ay_filtered, seed.settings["threshold"])

    ok = pre.guard.plausible  # the KF runs every sample: feed it plausible values only
    offset, learned = ca.SX(0), {}
    if kinematic_offset.enabled(numeric):    # learned in near-straight driving, used from the next sample
        offset = s["kin_offset"]
        learned = {"kin_offset": kinematic_offset.update(seed.settings, T, offset, pre,
                                                         hold(u["vx"], ok["vx"], seed.vx_min), active)}
    result = kf2dof.dynamic_update(params, NAME)(
        x=seed.kf.x(s), P=seed.kf.P(s),
        delta_prev=s["delta_prev"], vx_prev=s["vx_prev"], delta=hold(u["delta"], ok["delta"], 0),
        vx=hold(u["vx"], ok["vx"], seed.vx_min),
        ay=hold(seed.roll_corrected(u["ay"]) - kinematic_offset.sensor_part(seed.settings, offset), ok["ay"], 0),
        r_meas=pre.r_checked,
        **seed.kf.learning(pre.kinematic_inputs_frozen),
        **params.keyword())
    vy_kf = result["x_next"][0]
    vy_kin = s["vy_kin"] + T * (s["ay_last"] - s["r_last"] * s["vx_prev"] - offset) \
        + T * seed.settings["integral_gain"] * (s["vy"] - s["vy_kin"])
    if frozen.enabled(numeric, KINEMATIC_INPUTS):   # its inputs frozen: the KF alone, and the integrator follows it
        vy_kin = ca.if_else(pre.kinematic_inputs_frozen, vy_kf, vy_kin)
        weight = weight * ca.logic_not(pre.kinematic_inputs_frozen)
    vx = seed.speed(hold(u["vx"], ok["vx"], seed.vx_min))
    beta_kin = sideslip(vy_kin, vx)
    beta = weight * beta_kin + (1 - weight) * result["beta"]
    judged = seed.monitors.judge_model(s, active, seed.settings, T, result["innovation"], u["ay"], result["ay_model"],
                                       friction_scale=seed.kf.friction_scale(result["x_next"]),
                                       held_here=False)
    code, monitor = pre.status + judged.code, judged.updates
    limit = seed.settings["disagreement_limit"]
    if numeric["disagreement_limit"] > 0:   # beyond the paper
        apart = weight * ca.fabs(beta_kin - result["beta"]) > limit
        code = code + status.SCHEMES_DISAGREE * (active * apart)
    running = seed.advanced({**s, **pre.updates}, u, {
        **seed.kf.entries(result["x_next"], result["P_next"]), "vy_kin": vy_kin, **monitor, **learned})
    holding = seed.held({**s, **pre.updates}, u, guard.plausible)
    next_state = ca.if_else(active, layout.pack(running), layout.pack(holding))
    output = OUTPUTS.pack({
        "beta": ca.if_else(active, beta, 0),
        "vy": ca.if_else(active, weight * vy_kin + (1 - weight) * vy_kf, 0),
        "r": ca.if_else(active, pre.r_checked, s["r_last"]),
        "weight": ca.if_else(active, weight, 0),
        "status": code,
    })
    init, structure = make_guarded(NAME, seed.inputs, layout, OUTPUTS, inputs, state,
                                   seed.initial_state(u), next_state, output, params, decisions, pre.checks)
    return Estimator(NAME, "sideslip by weighted fusion of a kinematic and a KF scheme "
                     "(seed 000's comparison method)", seed.inputs, layout, OUTPUTS, init, structure, params,
                     seed.notes())


DEFINITIONS = (Definition(
    name=NAME, build=build, schema=SCHEMA,
    tunable={**kf2dof.KF_TUNABLES,
             "threshold": Tunable(0.5, 4.0, log=False, regime=LOW_FRICTION),
             "integral_gain": Tunable(0.05, 5.0, regime=BEYOND_LINEAR),
             **YAW_RATE_CHECK_TUNABLES, "lateral_acceleration_band": Tunable(1.0, 8.0, regime=LOW_FRICTION)},
    status_bits=(*KINEMATIC_DYNAMIC_STATUS, status.SCHEMES_DISAGREE, *CHECKS.status_bits),
    monitors=CHECKS.block,
    derived={**ROLL_GRADIENT, **KF_MEASUREMENT_NOISE, **TYRE_FRICTION, **CHECKS.derived}),)
