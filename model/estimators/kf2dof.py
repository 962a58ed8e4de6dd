"""kf2dof: sideslip from the linear 2-DOF bicycle model and a Kalman filter.

The dynamic scheme of docs/methods.md, seed 000 (sections 2.5, 2.8-2.10), alone:

* predict from k-1 to k with the inputs of k-1 (zero-order hold): Phi, Gamma of A(vx_k-1), B by the
  configured discretisation; Q_d = Q_c T;
* update with z_k = [ay_k, r_k] (raw accelerometer, gyro), C(vx_k), D delta_k, Joseph form;
* beta = atan2(vy, vx_k).

Beyond the paper, ``tyre_model = "saturating"`` makes it an extended KF of the bicycle model with
saturating axle forces (model.tyres), right where the tyres reach their friction limit.

Hold rule (model.guard): while not active, vy := 0, P := P_0, r is held, the previous inputs keep
their last plausible values, and the output is beta = 0, vy = 0, r = held r. The model is always
evaluated at vx clamped to [vx_min, vx_max], so no division by a small speed can happen.
Initialisation: vy = 0, r = r_0, P = P_0, previous inputs = sample 0; holding unless sample 0 is
plausible and vx_0 >= vx_resume.
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import discretize, kalman, signals, status, tyres
from vsegen.model.bicycle import bicycle_matrices, sideslip, state_matrix_norm_bound
from vsegen.model.calibration import Parameters, matrix
from vsegen.model.estimator import (
    BEYOND_LINEAR,
    KF_MEASUREMENT_NOISE,
    TYRE_FRICTION,
    Definition,
    Estimator,
    Tunable,
    make_guarded,
)
from vsegen.model.guard import first_sample, hold, input_guard, model_speed, previous_inputs, symbolic
from vsegen.model.layout import Layout, covariance_signals
from vsegen.model.monitor_block import Checks, MonitorBlock
from vsegen.model.schema import KF_FIELDS, LOW_SPEED_RULES, EstimatorSchema
from vsegen.model.signals import Signal

NAME = "kf2dof"

CHANNELS = ("ay", "r")
"""The KF's measured channels (the consistency monitor's sensor_noise order)."""
METHOD_INPUTS = ("delta", "vx", "ay", "r")
"""What the bicycle-model KF reads; the monitors may add theirs (``CHECKS.block(settings).inputs``)."""
CHECKS = Checks(METHOD_INPUTS, channels=CHANNELS, linear_range=True)
"""Beyond the paper: the monitor block (model.monitor_block)."""
SCHEMA = EstimatorSchema(fields=(*KF_FIELDS, *CHECKS.fields), rules=LOW_SPEED_RULES)

_ESTIMATES = (Signal("vy", "m/s", "lateral velocity estimate"), Signal("r", "rad/s", "yaw-rate estimate"))
_COVARIANCE = kalman.packed_names("P", ("vy", "r"))
def states(settings) -> Layout:
    """The state layout; the monitors' entries only when they are on."""
    return Layout((
        *_ESTIMATES,
        *covariance_signals("P", _ESTIMATES),
        Signal("delta_prev", "rad", "last plausible steer angle (input of the next prediction)"),
        Signal("vx_prev", "m/s", "last plausible speed (input of the next prediction)"),
        *CHECKS.block(settings).states,
        signals.HOLDING,
        *CHECKS.block(settings).segment,
    ))

OUTPUTS = Layout((
    Signal("beta", "rad", "sideslip angle at the CG, atan2(vy, vx)"),
    Signal("vy", "m/s", "lateral velocity"),
    Signal("r", "rad/s", "filtered yaw rate"),
    signals.STATUS,
))


def _saturating(settings) -> bool:
    return settings["tyre_model"] == "saturating"


KF_TUNABLES = {"process_noise": Tunable(1e-4, 1e2), "measurement_noise": Tunable(1e-6, 1e1),
               "tyre_friction": Tunable(0.3, 1.6, log=False, when=_saturating, regime=BEYOND_LINEAR),
               "friction_floor": Tunable(0.8, 1.5, log=False, when=_saturating, regime=BEYOND_LINEAR)}
"""The settings ``vsegen tune`` may search in every estimator running this KF: the noises, and with
saturating tyres their friction and its floor (they act beyond the linear range)."""


def dynamic_update(params: Parameters, table: str = NAME) -> ca.Function:
    """One Kalman predict + update of the 2-DOF model, as a named CasADi Function: the linear
    model's KF, or with ``tyre_model = "saturating"`` the EKF of model.tyres' saturating axles.

    Inputs: ``x`` = [vy, r] (m/s, rad/s), ``P`` = packed covariance [P11, P12, P22],
    ``delta_prev`` (rad), ``vx_prev`` (m/s): the inputs held over the prediction (ZOH);
    ``delta`` (rad), ``vx`` (m/s), ``ay`` (m/s^2), ``r_meas`` (rad/s): this sample.
    With calibratable parameters, a last input ``params`` carries them. ``table`` names the
    [estimator.<table>] whose KF settings (model.schema.KF_FIELDS) it uses.
    Outputs: ``x_next``, ``P_next`` (packed), ``beta`` = atan2(vy, vx) (rad; as atan(vy / vx), the
    speed being clamped positive), ``innovation`` =
    z - C x- - D delta (the prior innovation of [a_y, r], for the consistency monitor) and
    ``ay_model``, the prior's a_y (m/s^2, a_y minus its innovation; for the linear-range flag).
    Both speeds are clamped to [vx_min, vx_max] before use; the caller's guard ensures the inputs
    are plausible. Reused by every estimator with a dynamic (KF) scheme.
    """
    config = params.config
    vehicle, T = config.vehicle, config.sample_time
    settings = config.settings(table)
    vx_min, vx_max = settings["vx_min"], config.limits["vx_max"]
    Qd = matrix(settings["process_noise"]) * T
    R = matrix(settings["measurement_noise"])
    plan = zoh_plan(params, table)
    x = ca.SX.sym("x", 2)
    P_packed = ca.SX.sym("P", kalman.packed_size(2))
    delta_prev, vx_prev, delta, vx, ay, r_meas = (
        ca.SX.sym(n) for n in ("delta_prev", "vx_prev", "delta", "vx", "ay", "r_meas"))

    def seen_speed(speed):
        return model_speed(speed, vx_min, vx_max)

    P = kalman.unpack_symmetric(P_packed, 2)
    z = ca.vertcat(ay, r_meas)
    if settings["tyre_model"] == "saturating":
        # EKF: x- = x + Gamma_I f(x), the Jacobian's Phi and Gamma_I = int_0^T e^(A s) ds by the
        # configured method (exact for the linear model: Phi x + Gamma delta), P- = Phi P Phi' + Q_d
        friction = tyres.friction(settings["tyre_friction"], settings["friction_floor"], ay)
        prior = tyres.saturating_bicycle(vehicle, friction, x, delta_prev, seen_speed(vx_prev))
        Phi, Gamma = discretize.discretise(settings["discretisation"], prior.A, ca.SX.eye(2), T, plan)
        x_pred, P_pred = kalman.ekf_predict(x + ca.mtimes(Gamma, prior.f), P, Phi, Qd)
        seen = tyres.saturating_bicycle(vehicle, friction, x_pred, delta, seen_speed(vx))
        innovation = z - ca.vertcat(seen.ay, x_pred[1])
        x_new, P_new = kalman.correct(x_pred, P_pred, innovation, seen.H, R)
    else:
        A, B, _, _ = bicycle_matrices(vehicle, seen_speed(vx_prev))
        Phi, Gamma = discretize.discretise(settings["discretisation"], A, B, T, plan)
        x_pred, P_pred = kalman.predict(x, P, Phi, Gamma, delta_prev, Qd)
        _, _, C, D = bicycle_matrices(vehicle, seen_speed(vx))
        x_new, P_new, innovation = kalman.update_joseph(x_pred, P_pred, z, C, D, delta, R)
    names = ["x", "P", "delta_prev", "vx_prev", "delta", "vx", "ay", "r_meas"]
    return ca.Function(
        f"{table}_dynamic_update",
        [x, P_packed, delta_prev, vx_prev, delta, vx, ay, r_meas, *params.inputs()],
        [x_new, kalman.pack_symmetric(P_new), sideslip(x_new[0], seen_speed(vx)), innovation, ay - innovation[0]],
        names + ["params"] * params.calibratable,
        ["x_next", "P_next", "beta", "innovation", "ay_model"],
    )


def zoh_plan(params: Parameters, table: str = NAME) -> discretize.ZohPlan:
    """The ZOH series plan for the generated parameter values (with the calibration margin)."""
    numeric = params.numeric
    settings = numeric.settings(table)
    bound = state_matrix_norm_bound(numeric.vehicle, settings["vx_min"], numeric.limits["vx_max"])
    return discretize.plan_zoh(bound * params.norm_margin, numeric.sample_time)


def zoh_note(params: Parameters, table: str = NAME) -> dict[str, str]:
    """Notes for generated files: the discretisation and, for ZOH, the series' error bound."""
    numeric = params.numeric
    settings = numeric.settings(table)
    notes = {"discretisation": settings["discretisation"]}
    if settings["discretisation"] == "zoh":
        plan = zoh_plan(params, table)
        margin = f" x {params.norm_margin:g} (calibration margin)" if params.calibratable else ""
        notes["zoh_series"] = (f"{plan.terms} Taylor terms, {plan.squarings} squarings, "
                               f"|Phi - expm(A T)|_inf <= {plan.error_bound:.1e} for ||A|| up to "
                               f"its bound over {settings['vx_min']} <= vx <= "
                               f"{numeric.limits['vx_max']} m/s{margin}")
    return notes


def build(params: Parameters) -> Estimator:
    """The kf2dof estimator ([vehicle], [inputs] and [estimator.kf2dof]) with ``params``."""
    config = params.config
    limits = config.limits
    settings = config.settings(NAME)
    vx_min, vx_resume = settings["vx_min"], settings["vx_resume"]
    P0 = kalman.pack_symmetric(matrix(settings["initial_covariance"]))
    update = dynamic_update(params)
    block = CHECKS.block(params.numeric.settings(NAME))
    layout = states(params.numeric.settings(NAME))

    state, s = layout.symbols("state")
    in_layout = block.inputs
    inputs, u = in_layout.symbols("input")
    guard, decisions = symbolic(input_guard(u, limits, vx_min, vx_resume, s["holding"], block.monitored))
    ok = guard.plausible
    result = update(
        x=ca.vertcat(s["vy"], s["r"]),
        P=ca.vertcat(*[s[n] for n in _COVARIANCE]),
        delta_prev=s["delta_prev"],
        vx_prev=s["vx_prev"],
        delta=hold(u["delta"], ok["delta"], 0),
        vx=hold(u["vx"], ok["vx"], vx_min),
        ay=hold(u["ay"], ok["ay"], 0),
        r_meas=hold(u["r"], ok["r"], 0),
        **params.keyword(),
    )
    active = guard.active
    vy_next = ca.if_else(active, result["x_next"][0], 0)
    r_next = ca.if_else(active, result["x_next"][1], s["r"])
    P_next = ca.if_else(active, result["P_next"], P0)
    watched = block.watch_inputs(s, u, ok, active, settings, config.sample_time, config.vehicle, config.limits)
    judged = block.judge_model(s, active, settings, config.sample_time, result["innovation"], u["ay"],
                               result["ay_model"])
    code = guard.status + watched.code + judged.code
    next_state = layout.pack({
        "vy": vy_next,
        "r": r_next,
        **{name: P_next[i] for i, name in enumerate(_COVARIANCE)},
        **previous_inputs(u, ok, s),
        **watched.updates, **judged.updates,
        "holding": ca.if_else(active, 0, 1),
    })
    output = OUTPUTS.pack({
        "beta": ca.if_else(active, result["beta"], 0),
        "vy": vy_next,
        "r": r_next,
        "status": code,
    })

    init_state = _initial_state(params, layout, block, u, P0)
    init, structure = make_guarded(NAME, in_layout, layout, OUTPUTS, inputs, state, init_state,
                                   next_state, output, params, decisions, watched.checks)
    return Estimator(NAME, "sideslip from the 2-DOF bicycle model + Kalman filter",
                     in_layout, layout, OUTPUTS, init, structure, params, zoh_note(params))


def _initial_state(params: Parameters, layout: Layout, block: MonitorBlock, u: dict, P0) -> ca.SX:
    """Initialisation: vy = 0, r = r_0, P = P_0 (packed), previous inputs = sample 0, the monitors
    at their first-sample entries; holding unless sample 0 is plausible and vx_0 >= vx_resume."""
    settings = params.config.settings(NAME)
    first, holding = first_sample(u, params.config.limits, settings["vx_min"], settings["vx_resume"],
                                  block.monitored)
    return layout.pack({
        "vy": ca.SX(0),
        "r": first["r"],
        **{name: P0[i] for i, name in enumerate(_COVARIANCE)},
        "delta_prev": first["delta"],
        "vx_prev": first["vx"],
        **block.initial_entries(first),
        "holding": holding,
    })

DEFINITIONS = (Definition(
    name=NAME, build=build, schema=SCHEMA,
    tunable=KF_TUNABLES,
    status_bits=(status.LOW_SPEED, status.INVALID_INPUT, *CHECKS.status_bits), monitors=CHECKS.block,
    derived={**KF_MEASUREMENT_NOISE, **TYRE_FRICTION, **CHECKS.derived}),)
