"""kf2dof: sideslip from the linear 2-DOF bicycle model and a Kalman filter.

The dynamic scheme of docs/methods.md, seed 000 (sections 2.5, 2.8-2.10), alone:

* predict from k-1 to k with the inputs of k-1 (zero-order hold): Phi, Gamma of A(vx_k-1), B by the
  configured discretisation; Q_d = Q_c T;
* update with z_k = [ay_k, r_k] (raw accelerometer, gyro), C(vx_k), D delta_k, Joseph form;
* beta = atan2(vy, vx_k).

Beyond the paper, ``tyre_model = "saturating"`` makes it an extended KF of the bicycle model with
saturating axle forces (model.tyres), right where the tyres reach their friction limit; with
``friction_noise`` > 0 its state has a third entry, the friction scale rho (:class:`KalmanState`).

Hold rule (model.guard): while not active, vy := 0, P := P_0, r (and rho) are held, the previous
inputs keep their last plausible values, and the output is beta = 0, vy = 0, r = held r. The model
is always evaluated at vx clamped to [vx_min, vx_max], so no division by a small speed can happen.
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
from vsegen.model.input_checks import frozen
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

ESTIMATES = (Signal("vy", "m/s", "lateral velocity estimate"), Signal("r", "rad/s", "yaw-rate estimate"))
FRICTION_SCALE = Signal("friction", "-", "estimated friction scale rho (1 = the file's tyre_friction)")


def friction_estimated(settings) -> bool:
    """Whether the KF estimates the friction scale (structural: ``friction_noise`` > 0 when it is
    generated, with saturating tyres)."""
    return settings["tyre_model"] == "saturating" and settings["friction_noise"] > 0


class KalmanState:
    """The 2-DOF KF's state entries of one settings table: [vy, r], and the friction scale rho
    where it is estimated, with the packed covariance; P_0 is ``initial_covariance`` with rho
    known (variance 0: the file's friction until the driving shows another)."""

    def __init__(self, numeric_settings, settings, estimates: tuple[Signal, Signal] = ESTIMATES,
                 covariance_doc: str | None = None) -> None:
        self.estimates_friction = friction_estimated(numeric_settings)
        self.signals = (*estimates, *((FRICTION_SCALE,) if self.estimates_friction else ()))
        self.names = tuple(entry.name for entry in self.signals)
        self.covariance = kalman.packed_names("P", self.names)
        self.covariance_signals = covariance_signals("P", self.signals, **({"doc": covariance_doc} if covariance_doc
                                                                             else {}))
        P0 = matrix(settings["initial_covariance"])
        self.P0 = kalman.pack_symmetric(ca.diagcat(P0, ca.SX(0)) if self.estimates_friction else P0)

    def x(self, s: dict) -> ca.SX:
        """The state vector from the entries ``s``."""
        return ca.vertcat(*[s[n] for n in self.names])

    def P(self, s: dict) -> ca.SX:
        """The packed covariance from the entries ``s``."""
        return ca.vertcat(*[s[n] for n in self.covariance])

    def entries(self, x, P) -> dict:
        """The state entries of ``x`` and the packed ``P``."""
        return {**{n: x[i] for i, n in enumerate(self.names)}, **{n: P[i] for i, n in enumerate(self.covariance)}}

    def learning(self, inputs_frozen) -> dict:
        """The update's ``inputs_frozen`` keyword where the friction scale is estimated."""
        return {"inputs_frozen": inputs_frozen} if self.estimates_friction else {}

    def friction_scale(self, x):
        """The estimated friction scale of the state vector ``x``; None where it is not estimated."""
        return x[2] if self.estimates_friction else None

    def initial(self, r0) -> dict:
        """vy = 0, r = ``r0``, rho = 1, P = P_0."""
        return self.entries(ca.vertcat(0, r0, *([1] if self.estimates_friction else [])), self.P0)


def states(settings) -> Layout:
    """The state layout; the monitors' entries and the friction scale only when they are on."""
    kf = KalmanState(settings, settings)
    return Layout((
        *kf.signals,
        *kf.covariance_signals,
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


def noise_grows(settings) -> bool:
    """Whether the KF's process noise grows with a_y (structural: ``process_noise_load`` > 0 when it
    is generated, also in calibratable mode)."""
    return settings["process_noise_load"] > 0


KF_TUNABLES = {"process_noise": Tunable(1e-4, 1e2), "measurement_noise": Tunable(1e-6, 1e1),
               "process_noise_load": Tunable(0.5, 20.0, when=noise_grows),
               "tyre_friction": Tunable(0.3, 1.6, log=False, when=_saturating, regime=BEYOND_LINEAR),
               "friction_floor": Tunable(0.8, 1.5, log=False, when=_saturating, regime=BEYOND_LINEAR),
               "friction_noise": Tunable(1e-4, 1.0, when=friction_estimated, regime=BEYOND_LINEAR),
               "friction_time": Tunable(0.2, 10.0, when=friction_estimated, regime=BEYOND_LINEAR)}
"""The settings ``vsegen tune`` may search in every estimator running this KF: the noises and, where
the process noise grows with a_y, the load of its growth; with saturating tyres their friction and its
floor, and where the KF estimates the friction scale its noise and its return time (they act beyond
the linear range). The growth and the friction state are structural: a file with either off keeps
it off."""


def dynamic_update(params: Parameters, table: str = NAME) -> ca.Function:
    """One Kalman predict + update of the 2-DOF model, as a named CasADi Function: the linear
    model's KF, or with ``tyre_model = "saturating"`` the EKF of model.tyres' saturating axles.

    Inputs: ``x`` = [vy, r] (m/s, rad/s; [vy, r, rho] where the friction scale is estimated, see
    :func:`saturating_update`), ``P`` = its packed covariance (upper triangle, row by row),
    ``delta_prev`` (rad), ``vx_prev`` (m/s): the inputs held over the prediction (ZOH);
    ``delta`` (rad), ``vx`` (m/s), ``ay`` (m/s^2), ``r_meas`` (rad/s): this sample.
    Where the friction scale is estimated, ``inputs_frozen`` (1 while a_y or r is frozen,
    ``model.input_checks.frozen``) keeps it at its prior: a stuck measurement would teach it a
    friction the road does not have. With calibratable parameters, a last input ``params`` carries
    them. ``table`` names the [estimator.<table>] whose KF settings (model.schema.KF_FIELDS) it uses.
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
    R = matrix(settings["measurement_noise"])
    plan = zoh_plan(params, table)
    n = 3 if friction_estimated(params.numeric.settings(table)) else 2
    x = ca.SX.sym("x", n)
    P_packed = ca.SX.sym("P", kalman.packed_size(n))
    delta_prev, vx_prev, delta, vx, ay, r_meas, inputs_frozen = (
        ca.SX.sym(name) for name in ("delta_prev", "vx_prev", "delta", "vx", "ay", "r_meas", "inputs_frozen"))

    def seen_speed(speed):
        return model_speed(speed, vx_min, vx_max)

    P = kalman.unpack_symmetric(P_packed, n)
    z = ca.vertcat(ay, r_meas)
    Qd = process_noise(params.numeric.settings(table), settings, ay, T)
    if settings["tyre_model"] == "saturating":
        x_new, P_new, innovation = saturating_update(settings, vehicle, T, plan, x, P, z, Qd, delta_prev,
                                                     seen_speed(vx_prev), delta, seen_speed(vx),
                                                     inputs_frozen if n == 3 else None)
    else:
        A, B, _, _ = bicycle_matrices(vehicle, seen_speed(vx_prev))
        Phi, Gamma = discretize.discretise(settings["discretisation"], A, B, T, plan)
        x_pred, P_pred = kalman.predict(x, P, Phi, Gamma, delta_prev, Qd)
        _, _, C, D = bicycle_matrices(vehicle, seen_speed(vx))
        x_new, P_new, innovation = kalman.update_joseph(x_pred, P_pred, z, C, D, delta, R)
    names = ["x", "P", "delta_prev", "vx_prev", "delta", "vx", "ay", "r_meas"] + ["inputs_frozen"] * (n == 3)
    return ca.Function(
        f"{table}_dynamic_update",
        [x, P_packed, delta_prev, vx_prev, delta, vx, ay, r_meas, *([inputs_frozen] if n == 3 else []),
         *params.inputs()],
        [x_new, kalman.pack_symmetric(P_new), sideslip(x_new[0], seen_speed(vx)), innovation, ay - innovation[0]],
        names + ["params"] * params.calibratable,
        ["x_next", "P_next", "beta", "innovation", "ay_model"],
    )


LOAD_CEILING = 6.0
"""m/s^2: the process noise grows with |a_y| up to this, where a passenger car's tyres approach
their friction limit (their force, and the model's error, stop growing there; a larger a_y is the
limit itself, a fault the input checks report, or aero); at process_noise_load = 2, Q grows at most
10-fold (25-fold up to 1 g). The growth amplifies float rounding: fusion's float calibratable build
drifts about 1e-4 from its reference on input_extremes in one of the truth cars at either ceiling
(tests/test_equivalence.py, KNOWN_DRIFT)."""
LOAD_FLOOR = 0.1
"""m/s^2: a ``process_noise_load`` below this counts as this (Q_c grows at most 1 + (6 / 0.1)^2,
about 3600-fold: a calibrated 1e-300 must not make Q infinite)."""


def process_noise(numeric_settings, settings, ay, T: float) -> ca.SX:
    """Q_d of [vy, r] for a sample whose measured lateral acceleration is ``ay`` (m/s^2): Q_c T, grown
    by 1 + (min(|a_y|, :data:`LOAD_CEILING`) / max(``process_noise_load``, :data:`LOAD_FLOOR`))^2
    where that setting is > 0 (structural: decided on the ``numeric_settings``; ``settings`` may
    hold calibration symbols, and a calibrated 0 gives the constant noise back)."""
    Qd = matrix(settings["process_noise"]) * T
    if noise_grows(numeric_settings):
        load = settings["process_noise_load"]
        growth = 1 + (ca.fmin(ca.fabs(ay), LOAD_CEILING) / ca.fmax(load, LOAD_FLOOR)) ** 2
        Qd = Qd * ca.if_else(load > 0, growth, 1)
    return Qd


def saturating_update(settings, vehicle, T: float, plan, x, P, z, Qd, delta_prev, vx_prev, delta, vx,
                      inputs_frozen=None):
    """The EKF step of the saturating model (model.tyres): (x+, P+, the prior innovation). Both
    speeds are clamped already. x- = x + Gamma_I f(x), with Phi and Gamma_I = int_0^T e^(A s) ds of
    the Jacobian A by the configured method (exact for the linear model: Phi x + Gamma delta),
    P- = Phi P Phi' + Q_d (``Qd``, :func:`process_noise`), the update from [a_y, r] with their
    Jacobian H.

    With ``inputs_frozen`` (not None: ``friction_noise`` > 0) x = [vy, r, rho]: rho scales both
    axles' ``tyre_friction`` (the floor still holds, model.tyres.friction); between samples it
    returns to 1 with ``friction_time`` tau, rho- = 1 + (rho - 1) e^(-T / tau), a random walk of
    intensity ``friction_noise`` q on top. It is held over the sample in the equation of [vy, r], so
    the transition is block-triangular: F = [[Phi, Gamma df/drho], [0, e^(-T / tau)]],
    Q_d = diag(Q_c T, q T). H gains da_y/drho, which is 0 in the linear range: only a saturating
    axle moves rho. The updated rho is clamped to ``model.tyres.FRICTION_SCALE_RANGE``, and kept at
    its prior while ``inputs_frozen``."""
    estimated = inputs_frozen is not None
    scale = x[2] if estimated else None
    friction = tyres.friction(settings["tyre_friction"], settings["friction_floor"], z[0], scale)
    prior = tyres.saturating_bicycle(vehicle, friction, x[:2], delta_prev, vx_prev)
    Phi, Gamma = discretize.discretise(settings["discretisation"], prior.A, ca.SX.eye(2), T, plan)
    F, x_pred = Phi, x[:2] + ca.mtimes(Gamma, prior.f)
    if estimated:
        decay = ca.exp(-T / settings["friction_time"])
        F = ca.blockcat([[Phi, ca.mtimes(Gamma, prior.f_friction)], [ca.SX.zeros(1, 2), decay]])
        Qd = ca.diagcat(Qd, settings["friction_noise"] * T)
        x_pred = ca.vertcat(x_pred, 1 + (scale - 1) * decay)
        friction = tyres.friction(settings["tyre_friction"], settings["friction_floor"], z[0], x_pred[2])
    x_pred, P_pred = kalman.ekf_predict(x_pred, P, F, Qd)
    seen = tyres.saturating_bicycle(vehicle, friction, x_pred[:2], delta, vx)
    innovation = z - ca.vertcat(seen.ay, x_pred[1])
    H = ca.horzcat(seen.H, ca.vertcat(seen.ay_friction, 0)) if estimated else seen.H
    x_new, P_new = kalman.correct(x_pred, P_pred, innovation, H, matrix(settings["measurement_noise"]))
    if not estimated:
        return x_new, P_new, innovation
    low, high = tyres.FRICTION_SCALE_RANGE
    kept = ca.if_else(inputs_frozen, x_pred[2], ca.fmin(ca.fmax(x_new[2], low), high))
    return ca.vertcat(x_new[:2], kept), P_new, innovation


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
    kf = KalmanState(params.numeric.settings(NAME), settings)
    update = dynamic_update(params)
    block = CHECKS.block(params.numeric.settings(NAME))
    layout = states(params.numeric.settings(NAME))

    state, s = layout.symbols("state")
    in_layout = block.inputs
    inputs, u = in_layout.symbols("input")
    guard, decisions = symbolic(input_guard(u, limits, vx_min, vx_resume, s["holding"], block.monitored))
    ok = guard.plausible
    result = update(
        x=kf.x(s),
        P=kf.P(s),
        delta_prev=s["delta_prev"],
        vx_prev=s["vx_prev"],
        delta=hold(u["delta"], ok["delta"], 0),
        vx=hold(u["vx"], ok["vx"], vx_min),
        ay=hold(u["ay"], ok["ay"], 0),
        r_meas=hold(u["r"], ok["r"], 0),
        **kf.learning(frozen.any_frozen(s, settings, block.check_time(config.sample_time), CHANNELS)),
        **params.keyword(),
    )
    active = guard.active
    x_next = ca.if_else(active, result["x_next"], ca.vertcat(0, kf.x(s)[1:]))
    vy_next, r_next = x_next[0], x_next[1]
    P_next = ca.if_else(active, result["P_next"], kf.P0)
    watched = block.watch_inputs(s, u, ok, active, settings, config.sample_time, config.vehicle, config.limits)
    judged = block.judge_model(s, active, settings, config.sample_time, result["innovation"], u["ay"],
                               result["ay_model"], friction_scale=kf.friction_scale(result["x_next"]))
    code = guard.status + watched.code + judged.code
    next_state = layout.pack({
        **kf.entries(x_next, P_next),
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

    init_state = _initial_state(params, layout, block, u, kf)
    init, structure = make_guarded(NAME, in_layout, layout, OUTPUTS, inputs, state, init_state,
                                   next_state, output, params, decisions, watched.checks)
    return Estimator(NAME, "sideslip from the 2-DOF bicycle model + Kalman filter",
                     in_layout, layout, OUTPUTS, init, structure, params, zoh_note(params))


def _initial_state(params: Parameters, layout: Layout, block: MonitorBlock, u: dict, kf: KalmanState) -> ca.SX:
    """Initialisation: vy = 0, r = r_0, rho = 1, P = P_0 (packed), previous inputs = sample 0, the
    monitors at their first-sample entries; holding unless sample 0 is plausible and vx_0 >= vx_resume."""
    settings = params.config.settings(NAME)
    first, holding = first_sample(u, params.config.limits, settings["vx_min"], settings["vx_resume"],
                                  block.monitored)
    return layout.pack({
        **kf.initial(first["r"]),
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
