"""ekf_rls: sideslip by fusing an EKF whose cornering stiffness is estimated online (RLS) with the
integral method, weighted by the rate of change of the stiffness (seed 001).

docs/methods.md, seed 001, §2 with the §3/§5 defaults (every equation there is
reconstructed; numbers in brackets are the spec's):

* filtered yaw acceleration r_dot = s/(tau_d s + 1){r}, Tustin; axle forces from a_y and r_dot
  [21, 22]; wheel loads with load transfer, each at least 5 % of a static corner load [23];
  load-proportional left/right split and lateral force coefficients f_L, f_R (B3);
  alpha_eq = |delta - L r / vx| [18];
* RLS on X = [C0_L, C0_R] with regressor alpha_eq I [26-32], forgetting factor tau^(T / 1 ms)
  (B6), updated only while alpha_eq >= alpha_min (and, beyond the paper, no input monitor raises a
  bit: model.monitor_block), trace(P) bounded by p_max, X clamped to
  [0.3, 1.5] C0_nom [33]; C_f, C_r [24, 25]; ``stiffness = "constant"`` gives the plain EKF with
  the vehicle file's C_f, C_r;
* per-axle regressors, X = [C0_f, C0_r] against each axle's slip angle [3], updated while both
  |alpha| >= alpha_min: ``stiffness_regressor = "ekf_slip"`` (B2) takes beta from the EKF prior;
  ``"kinematic_slip"`` (ours) takes it from a second integral method that is re-seeded from the
  fused beta only while lambda = 0, so that the stiffness it learns in a manoeuvre comes from
  kinematics and not from the EKF it feeds (in steady cornering the two would agree on any
  stiffness). Its forces [21, 22], slip angles and wheel loads all come from the same first-order
  low-pass (tau_d) of a_x, a_y, r, delta and that beta, so both sides of y = A X lag alike and the
  load noise of a_x does not reach the stiffness rate;
* ``roll_gradient`` removes body roll from the body-fixed a_y (model.sensors; 0 = literal);
* EKF on x = [beta, r], Euler, with the previous sample's C_f, C_r (B7), measurement y = r
  [9-15], Joseph update (model.kalman);
* nonlinearity indicator D = max(|dC_f/dt| / C_f,nom, |dC_r/dt| / C_r,nom), low-passed (tau_D),
  lambda = clamp((D - D1) / (D2 - D1), 0, 1) [37]; ``weighting = "integral_only"`` forces
  lambda = 1 (the integral method alone);
* integral method re-seeded from the last fused beta [35, 36 as corrected in §2.5];
* beta = (1 - lambda) beta_EKF + lambda beta_int.

Hold rule (model.guard): while not active every state is kept and beta = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

from vsegen.model import filters, kalman, signals, status
from vsegen.model.bicycle import GRAVITY
from vsegen.model.calibration import Parameters, matrix
from vsegen.model.estimator import (
    BEYOND_LINEAR,
    GYRO_VARIANCE,
    ROLL_GRADIENT,
    Definition,
    Estimator,
    Tunable,
    make_guarded,
)
from vsegen.model.guard import first_sample, hold, input_guard, model_speed, symbolic
from vsegen.model.layout import Layout, covariance_signals
from vsegen.model.monitor_block import Checks, MonitorBlock
from vsegen.model.schema import (
    LOW_SPEED_FIELDS,
    LOW_SPEED_RULES,
    ROLL_CORRECTION,
    EstimatorSchema,
    above,
    choice,
    fraction,
    nonnegative,
    positive,
    share,
    spd_matrix,
)
from vsegen.model.sensors import roll_corrected
from vsegen.model.signals import Signal

NAME = "ekf_rls"

CHANNELS = ("r",)
"""The EKF's measured channel (the consistency monitor's sensor_noise)."""
METHOD_INPUTS = ("delta", "vx", "ax", "ay", "r")
"""What the method reads; the monitors may add theirs (``CHECKS.block(settings).inputs``)."""
CHECKS = Checks(METHOD_INPUTS, channels=CHANNELS, linear_range=True)
"""Beyond the paper: the monitor block (model.monitor_block)."""
SCHEMA = EstimatorSchema(
    fields=(
        choice("stiffness", ("rls", "constant"), "cornering stiffness: estimated online (the "
               "method) or the vehicle file's C_f, C_r (the plain EKF)"),
        choice("weighting", ("stiffness_rate", "integral_only"), "fusion weight lambda: from the "
               "stiffness rate (the method) or 1 (the integral method alone)"),
        choice("stiffness_regressor", ("literal", "ekf_slip", "kinematic_slip"), "RLS regression: "
               "side-wise over alpha_eq = |delta - L r / vx| (the paper), or per axle over the slip "
               "angles of the EKF prior (B2) or of the integral method (forces and slip angles "
               "low-passed alike)"),
        spd_matrix("process_noise", 2, "[beta, r]: rad^2*s, (rad/s)^2*s", "Q_c; Q_d = Q_c*T"),
        positive("measurement_noise", "(rad/s)^2", "R: gyro noise variance"),
        spd_matrix("initial_covariance", 2, "[beta, r]: rad^2, (rad/s)^2", "P_0 of the EKF"),
        fraction("forgetting_factor", "RLS forgetting factor per 1 ms (rescaled to T)"),
        positive("rls_initial_covariance", "1/rad^2", "P_RLS,0 = this times I"),
        positive("rls_covariance_max", "1/rad^2", "bound on trace(P_RLS) (wind-up guard)"),
        positive("slip_min", "rad", "update the RLS only while alpha_eq (per-axle regressors: both "
                 "|slip angles|) is at least this"),
        positive("stiffness_min", "-", "lower clamp of C0 as a factor of C0_nom"),
        positive("stiffness_max", "-", "upper clamp of C0 as a factor of C0_nom"),
        positive("derivative_time_constant", "s", "tau_d of the filtered yaw acceleration, and of "
                 "the low-pass of kinematic_slip"),
        positive("indicator_time_constant", "s", "tau_D of the low-passed stiffness rate"),
        nonnegative("indicator_low", "1/s", "D_1: lambda = 0 below"),
        positive("indicator_high", "1/s", "D_2: lambda = 1 above"),
        ROLL_CORRECTION,
        share("stiffness_drop_limit", "beyond the paper: either axle's online stiffness below this share "
                 "of the vehicle file's raises BEYOND_LINEAR_RANGE (the tyres are past their linear range, "
                 "where the linear stiffness it learns lags what they do; 0 = never)", default=0.0),
        *CHECKS.fields,
        *LOW_SPEED_FIELDS,
    ),
    rules=(*LOW_SPEED_RULES, above("indicator_high", "indicator_low", "a rate", "1/s"),
           above("stiffness_max", "stiffness_min", "a factor")))
"""Seed 001's EKF with RLS stiffness and stiffness-rate fusion (docs/methods.md, seed 001 §3,
§5)."""
REFERENCE_PERIOD = 0.001
"""Sample time (s) at which the paper's forgetting factor applies (B6)."""
LOAD_FLOOR = 0.05
"""Smallest wheel load, as a share of a static corner load m g / 4 [23]."""

_EKF = kalman.packed_names("P", ("beta", "r"))
_RLS = kalman.packed_names("Prls", ("c0_1", "c0_2"))
_EKF_ESTIMATES = (Signal("beta_ekf", "rad", "EKF sideslip angle"),
                  Signal("r_ekf", "rad/s", "EKF yaw rate"))
STATES = Layout((
    *_EKF_ESTIMATES,
    *covariance_signals("P", _EKF_ESTIMATES, ("beta", "r"), "EKF covariance entry (upper triangle)"),
    Signal("c0_1", "1/rad", "normalised cornering stiffness: left wheels (literal) or front axle"),
    Signal("c0_2", "1/rad", "normalised cornering stiffness: right wheels (literal) or rear axle"),
    *(Signal(n, "1/rad^2", "RLS covariance entry (upper triangle)") for n in _RLS),
    Signal("c_front", "N/rad", "front axle cornering stiffness of the last sample"),
    Signal("c_rear", "N/rad", "rear axle cornering stiffness of the last sample"),
    Signal("r_last", "rad/s", "gyro yaw rate of the last sample (derivative filter)"),
    Signal("r_dot", "rad/s^2", "filtered yaw acceleration of the last sample"),
    Signal("indicator", "1/s", "low-passed nonlinearity indicator D"),
    Signal("beta", "rad", "fused sideslip angle of the last sample"),
    signals.HOLDING,
))
KINEMATIC_STATES = Layout((
    Signal("beta_kin", "rad", "integral method for slip angles, re-seeded only while lambda = 0"),
    Signal("ax_f", "m/s^2", "low-passed a_x"),
    Signal("ay_f", "m/s^2", "low-passed a_y (roll-corrected)"),
    Signal("r_f", "rad/s", "low-passed yaw rate"),
    Signal("delta_f", "rad", "low-passed steer angle"),
    Signal("beta_f", "rad", "low-passed beta_kin"),
))
"""Extra states of ``stiffness_regressor = "kinematic_slip"``."""
OUTPUTS = Layout((
    Signal("beta", "rad", "fused sideslip angle"),
    Signal("beta_ekf", "rad", "EKF sideslip angle"),
    Signal("beta_int", "rad", "integral-method sideslip angle"),
    Signal("r", "rad/s", "EKF yaw rate"),
    Signal("weight", "-", "lambda, the integral method's weight"),
    Signal("c_front", "N/rad", "front axle cornering stiffness"),
    Signal("c_rear", "N/rad", "rear axle cornering stiffness"),
    signals.STATUS,
))


def wheel_loads(vehicle, ax, ay) -> dict[str, ca.SX]:
    """F_z of each wheel (N) with longitudinal and lateral load transfer [23], floored."""
    m, a, b = vehicle["mass"], vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    h, d = vehicle["cg_height"], vehicle["track_width"]
    L = a + b
    pitch = m * ax * h / (2 * L)
    floor = LOAD_FLOOR * m * GRAVITY / 4
    front, rear = m * GRAVITY * b / (2 * L), m * GRAVITY * a / (2 * L)
    roll_front, roll_rear = m * ay * h * b / (L * d), m * ay * h * a / (L * d)
    return {"fl": ca.fmax(front - pitch - roll_front, floor),
            "fr": ca.fmax(front - pitch + roll_front, floor),
            "rl": ca.fmax(rear + pitch - roll_rear, floor),
            "rr": ca.fmax(rear + pitch + roll_rear, floor)}


def axle_forces(vehicle, delta, ay, r_dot) -> tuple[ca.SX, ca.SX]:
    """F_yf, F_yr (N) from the measured a_y and the filtered yaw acceleration [21, 22]."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    L = a + b
    return (b * m * ay + iz * r_dot) / (L * ca.cos(delta)), (a * m * ay - iz * r_dot) / L


def side_coefficients(vehicle, delta, ay, r_dot, loads) -> tuple[ca.SX, ca.SX]:
    """(f_L, f_R): lateral force over load per side, each axle force [21, 22] split between its
    wheels in proportion to their loads (B3)."""
    fy_front, fy_rear = axle_forces(vehicle, delta, ay, r_dot)
    front_share = fy_front / (loads["fl"] + loads["fr"])
    rear_share = fy_rear / (loads["rl"] + loads["rr"])
    f_left = (front_share * loads["fl"] + rear_share * loads["rl"]) / (loads["fl"] + loads["rl"])
    f_right = (front_share * loads["fr"] + rear_share * loads["rr"]) / (loads["fr"] + loads["rr"])
    return f_left, f_right


def nominal_c0(vehicle):
    """C0_nom = (C_f + C_r) / (m g) (1/rad)."""
    return (vehicle["cornering_stiffness_front"] + vehicle["cornering_stiffness_rear"]) / (
        vehicle["mass"] * GRAVITY)


def states(settings) -> Layout:
    """The state layout: ``kinematic_slip`` adds its integral method and low-passed signals, the
    monitor block its entries."""
    kinematic = KINEMATIC_STATES.signals if settings["stiffness_regressor"] == "kinematic_slip" else ()
    block = CHECKS.block(settings)
    return Layout((*STATES.signals, *kinematic, *block.states, *block.segment))


def axle_stiffness(regressor: str, c0, loads) -> tuple[ca.SX, ca.SX]:
    """C_f, C_r from the normalised stiffness and the wheel loads: left/right [24, 25], or front/rear
    (the per-axle regressors)."""
    if regressor == "literal":
        return c0[0] * loads["fl"] + c0[1] * loads["fr"], c0[0] * loads["rl"] + c0[1] * loads["rr"]
    return c0[0] * (loads["fl"] + loads["fr"]), c0[1] * (loads["rl"] + loads["rr"])


def side_regression(vehicle, delta, vx, ay, r_m, r_dot, loads):
    """(y, A, excitation) of the literal RLS y = A X: the side-wise coefficients over
    alpha_eq = |delta - L r / vx| [18, 27-29]; excitation = alpha_eq."""
    L = vehicle["cg_to_front_axle"] + vehicle["cg_to_rear_axle"]
    f_left, f_right = side_coefficients(vehicle, delta, ay, r_dot, loads)
    alpha_eq = ca.fabs(delta - L * r_m / vx)
    return ca.vertcat(ca.fabs(f_left), ca.fabs(f_right)), alpha_eq * ca.SX.eye(2), alpha_eq


def axle_regression(vehicle, delta, vx, ay, r, r_dot, beta, loads):
    """(y, A, excitation) of a per-axle RLS y = A X: each axle's force [21, 22] over its load
    against its slip angle [3] at sideslip ``beta``; excitation = the smaller |slip angle|."""
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    fy_front, fy_rear = axle_forces(vehicle, delta, ay, r_dot)
    alpha_f, alpha_r = delta - beta - a * r / vx, -beta + b * r / vx
    y = ca.vertcat(fy_front / (loads["fl"] + loads["fr"]), fy_rear / (loads["rl"] + loads["rr"]))
    return (y, ca.diag(ca.vertcat(alpha_f, alpha_r)),
            ca.fmin(ca.fabs(alpha_f), ca.fabs(alpha_r)))


def integral_step(beta_prev, T, vx, ax, ay, r):
    """One Euler step of the integral method [35, 36] from ``beta_prev`` (rad)."""
    speed = vx / ca.cos(beta_prev)
    return beta_prev + T * ((ay * ca.cos(beta_prev) - ax * ca.sin(beta_prev)) / speed - r)


def fusion_weight(weighting: str, indicator, d1, d2):
    """lambda [37]: clamp((D - D1) / (D2 - D1), 0, 1), or 1 for ``integral_only``."""
    if weighting == "stiffness_rate":
        return ca.fmin(ca.fmax((indicator - d1) / (d2 - d1), 0), 1)
    return ca.SX(1)


def rls_update(X, P, y, A, forgetting, p_max):
    """[30-32] for y = A X: (X, P); then trace(P) bounded by p_max."""
    eye = ca.SX.eye(2)
    K = ca.mtimes([P, A.T, ca.inv(forgetting * eye + ca.mtimes([A, P, A.T]))])
    X_new = X + ca.mtimes(K, y - ca.mtimes(A, X))
    P_new = ca.mtimes(eye - ca.mtimes(K, A), P) / forgetting
    trace = P_new[0, 0] + P_new[1, 1]
    return X_new, P_new * ca.fmin(1, p_max / trace)


def ekf_model(vehicle, x, delta, vx, c_front, c_rear):
    """f(x, u) of the 2-DOF model in beta form [1-4] and its Jacobian [13] (small angles, B9)."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    beta, r = x[0], x[1]
    alpha_f = delta - beta - a * r / vx
    alpha_r = -beta + b * r / vx
    fy_f, fy_r = c_front * alpha_f * ca.cos(delta), c_rear * alpha_r
    f = ca.vertcat((fy_f + fy_r) / (m * vx) - r, (a * fy_f - b * fy_r) / iz)
    return f, ca.jacobian(f, x)


def rounding_gain(vehicle, settings, T: float) -> float:
    """How much lambda amplifies a rounding of the stiffness (``Estimator.rounding_gain``): D
    differences C over one sample, so a rounding dC moves lambda by
    dC / C_nom (1 - exp(-T / tau_D)) / (T (D2 - D1)); C is at most C0_max m g (every load on one
    axle), judged against the softer axle's C_nom."""
    c_max = settings["stiffness_max"] * nominal_c0(vehicle) * vehicle["mass"] * GRAVITY
    softer = min(vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"])
    share = 1 - math.exp(-T / settings["indicator_time_constant"])
    return c_max / softer * share / (T * (settings["indicator_high"] - settings["indicator_low"]))


def kinematic_slip_signals(s, T, time_constant, seed_from_fused, vx, ax, ay, r_m, delta):
    """Next values of KINEMATIC_STATES: the integral method re-seeded from the fused beta where
    ``seed_from_fused``, and the first-order low-pass exp(-T / time_constant) of a_x, a_y, r, delta
    and of that beta."""
    beta_kin = integral_step(ca.if_else(seed_from_fused, s["beta"], s["beta_kin"]), T, vx, ax, ay,
                             r_m)
    share = 1 - ca.exp(-T / time_constant)
    raw = {"ax_f": ax, "ay_f": ay, "r_f": r_m, "delta_f": delta, "beta_f": beta_kin}
    return {"beta_kin": beta_kin, **{n: s[n] + share * (value - s[n]) for n, value in raw.items()}}


@dataclass(frozen=True)
class _Measured:
    """One sample's inputs as the filters use them: held where implausible, a_y roll-corrected,
    v_x clamped to [vx_min, vx_max]."""

    delta: ca.SX
    ax: ca.SX
    ay: ca.SX
    r: ca.SX
    vx: ca.SX


@dataclass(frozen=True)
class _Stiffness:
    """The stiffness section's results: the filtered yaw acceleration, the EKF model f and its
    Jacobian at the previous stiffness, the kinematic-slip filters' next values (regressor
    "kinematic_slip" only), the RLS's next estimate and covariance and the axle stiffnesses."""

    r_dot: ca.SX
    f: ca.SX
    jacobian: ca.SX
    kinematic: dict
    X_next: ca.SX
    P_rls_next: ca.SX
    c_front: ca.SX
    c_rear: ca.SX


def build(params: Parameters) -> Estimator:
    """The ekf_rls estimator ([vehicle], [inputs], [estimator.ekf_rls])."""
    config = params.config
    settings, choices = config.settings(NAME), params.numeric.settings(NAME)
    layout, block = states(choices), CHECKS.block(choices)
    state, s = layout.symbols("state")
    in_layout = block.inputs
    inputs, u = in_layout.symbols("input")
    guard, decisions = symbolic(input_guard(u, config.limits, settings["vx_min"], settings["vx_resume"],
                                            s["holding"], block.monitored))
    ok = guard.plausible
    delta, ax, ay_measured, r_m = (hold(u[n], ok[n], 0) for n in ("delta", "ax", "ay", "r"))
    vx_min = settings["vx_min"]
    vx = model_speed(hold(u["vx"], ok["vx"], vx_min), vx_min, config.limits["vx_max"])
    measured = _Measured(delta, ax, roll_corrected(ay_measured, settings["roll_gradient"]), r_m, vx)
    watched = block.watch_inputs(s, u, ok, guard.active, settings, config.sample_time, config.vehicle,
                                 config.limits)
    stiffness = _stiffness(config, settings, choices, s, measured, inputs_suspect=watched.code > 0)
    ekf = _ekf(config, settings, s, stiffness, measured.r)
    next_state, output = _fused(config, settings, choices, layout, block, s, guard, measured, stiffness, ekf,
                                watched)
    init_state = _initial_state(config, settings, choices, layout, block, u, stiffness.kinematic)
    init, structure = make_guarded(NAME, in_layout, layout, OUTPUTS, inputs, state, init_state,
                                   next_state, output, params, decisions, watched.checks)
    per_sample = choices["forgetting_factor"] ** (params.numeric.sample_time / REFERENCE_PERIOD)
    return Estimator(NAME, "sideslip: EKF with RLS cornering stiffness fused with the integral "
                           "method by the stiffness rate (seed 001)",
                     in_layout, layout, OUTPUTS, init, structure, params,
                     notes={"stiffness": choices["stiffness"], "weighting": choices["weighting"],
                            "stiffness_regressor": choices["stiffness_regressor"],
                            "forgetting_factor_per_sample": f"{per_sample:.6g}"},
                     rounding_gain=rounding_gain(params.numeric.vehicle, choices,
                                                 params.numeric.sample_time))


def _stiffness(config, settings, choices, s: dict, m: _Measured, inputs_suspect) -> _Stiffness:
    """Filtered r_dot, the axle forces' regression (per ``stiffness_regressor``), wheel loads and
    the RLS update of the load-normalised stiffness, clamped, on excited samples while no input
    monitor raises a bit (``inputs_suspect``: a frozen, offset or inconsistent input would teach
    it a stiffness that steady driving, where any stiffness fits, never corrects)."""
    vehicle, T = config.vehicle, config.sample_time
    regressor = choices["stiffness_regressor"]
    c0_nom = nominal_c0(vehicle)
    n_dot, d_dot = filters.tustin_derivative(settings["derivative_time_constant"], T)
    r_dot = n_dot * (m.r - s["r_last"]) - d_dot * s["r_dot"]
    x = ca.vertcat(s["beta_ekf"], s["r_ekf"])
    f, jacobian = ekf_model(vehicle, x, m.delta, m.vx, s["c_front"], s["c_rear"])
    kinematic = {}
    if regressor == "kinematic_slip":
        seed_from_fused = s["indicator"] <= settings["indicator_low"] if choices["weighting"] == "stiffness_rate" else 0
        kinematic = kinematic_slip_signals(s, T, settings["derivative_time_constant"],
                                           seed_from_fused, m.vx, m.ax, m.ay, m.r, m.delta)
        loads = wheel_loads(vehicle, kinematic["ax_f"], kinematic["ay_f"])
        y, A, excitation = axle_regression(vehicle, kinematic["delta_f"], m.vx, kinematic["ay_f"],
                                           kinematic["r_f"], (kinematic["r_f"] - s["r_f"]) / T,
                                           kinematic["beta_f"], loads)
    elif regressor == "ekf_slip":
        loads = wheel_loads(vehicle, m.ax, m.ay)
        prior = x + T * f
        y, A, excitation = axle_regression(vehicle, m.delta, m.vx, m.ay, prior[1], r_dot, prior[0],
                                           loads)
    else:
        loads = wheel_loads(vehicle, m.ax, m.ay)
        y, A, excitation = side_regression(vehicle, m.delta, m.vx, m.ay, m.r, r_dot, loads)
    X = ca.vertcat(s["c0_1"], s["c0_2"])
    P_rls = kalman.unpack_symmetric(ca.vertcat(*[s[n] for n in _RLS]), 2)
    forgetting = settings["forgetting_factor"] ** (T / REFERENCE_PERIOD)
    X_upd, P_upd = rls_update(X, P_rls, y, A, forgetting, settings["rls_covariance_max"])
    excited = ca.logic_and(excitation >= settings["slip_min"], ca.logic_not(inputs_suspect))
    low, high = settings["stiffness_min"] * c0_nom, settings["stiffness_max"] * c0_nom
    X_next = ca.fmin(ca.fmax(ca.if_else(excited, X_upd, X), low), high)
    P_rls_next = ca.if_else(excited, kalman.pack_symmetric(P_upd), kalman.pack_symmetric(P_rls))
    if choices["stiffness"] == "rls":
        c_front, c_rear = axle_stiffness(regressor, X_next, loads)
    else:
        c_front, c_rear = ca.SX(vehicle["cornering_stiffness_front"]), ca.SX(vehicle["cornering_stiffness_rear"])
    return _Stiffness(r_dot, f, jacobian, kinematic, X_next, P_rls_next, c_front, c_rear)


def _ekf(config, settings, s: dict, k: _Stiffness, r_m: ca.SX):
    """The EKF step with the previous sample's stiffness (B7): (x, P, yaw-rate innovation)."""
    T = config.sample_time
    x = ca.vertcat(s["beta_ekf"], s["r_ekf"])
    x_pred, P_pred = kalman.ekf_predict(
        x + T * k.f, kalman.unpack_symmetric(ca.vertcat(*[s[n] for n in _EKF]), 2),
        ca.SX.eye(2) + T * k.jacobian, matrix(settings["process_noise"]) * T)
    return kalman.update_joseph(x_pred, P_pred, r_m, ca.horzcat(0, 1), ca.SX.zeros(1, 1), ca.SX(0),
                                settings["measurement_noise"])


def _fused(config, settings, choices, layout: Layout, block: MonitorBlock, s: dict, guard, m: _Measured,
           k: _Stiffness, ekf, watched):
    """(next state, output): the stiffness-rate weight, the integral method re-seeded from the
    fused beta, their fusion, the monitor block's stages (``watched``: its input monitors') and the
    hold."""
    vehicle, T = config.vehicle, config.sample_time
    x_ekf, P_ekf, innovation = ekf
    active = guard.active
    rate = ca.fmax(ca.fabs(k.c_front - s["c_front"]) / (T * vehicle["cornering_stiffness_front"]),
                   ca.fabs(k.c_rear - s["c_rear"]) / (T * vehicle["cornering_stiffness_rear"]))
    indicator = s["indicator"] + (1 - ca.exp(-T / settings["indicator_time_constant"])) * (
        rate - s["indicator"])
    weight = fusion_weight(choices["weighting"], indicator, settings["indicator_low"], settings["indicator_high"])
    beta_int = integral_step(s["beta"], T, m.vx, m.ax, m.ay, m.r)
    beta = (1 - weight) * x_ekf[0] + weight * beta_int

    def keep(value, name):
        return ca.if_else(active, value, s[name])

    # beyond the paper: the EKF's yaw-rate innovation concerns the output only while the EKF carries
    # most of it (lambda < 1/2); the learned stiffness can say the tyres left their linear range
    judged = block.judge_model(s, active, settings, T, innovation, m.ay, concerns=weight < 0.5,
                               beyond=_stiffness_dropped(vehicle, settings, choices, k))
    code = guard.status + watched.code + judged.code
    next_state = layout.pack({
        "beta_ekf": keep(x_ekf[0], "beta_ekf"), "r_ekf": keep(x_ekf[1], "r_ekf"),
        **{n: keep(kalman.pack_symmetric(P_ekf)[i], n) for i, n in enumerate(_EKF)},
        "c0_1": keep(k.X_next[0], "c0_1"), "c0_2": keep(k.X_next[1], "c0_2"),
        **{n: keep(k.P_rls_next[i], n) for i, n in enumerate(_RLS)},
        "c_front": keep(k.c_front, "c_front"), "c_rear": keep(k.c_rear, "c_rear"),
        "r_last": keep(m.r, "r_last"), "r_dot": keep(k.r_dot, "r_dot"),
        "indicator": keep(indicator, "indicator"), "beta": keep(beta, "beta"),
        "holding": ca.if_else(active, 0, 1),
        **{n: keep(value, n) for n, value in k.kinematic.items()},
        **watched.updates, **judged.updates,
    })
    output = OUTPUTS.pack({
        "beta": ca.if_else(active, beta, 0), "beta_ekf": ca.if_else(active, x_ekf[0], 0),
        "beta_int": ca.if_else(active, beta_int, 0), "r": keep(x_ekf[1], "r_ekf"),
        "weight": ca.if_else(active, weight, 0), "c_front": keep(k.c_front, "c_front"),
        "c_rear": keep(k.c_rear, "c_rear"), "status": code,
    })
    return next_state, output


def _stiffness_dropped(vehicle, settings, choices, k: _Stiffness) -> tuple:
    """The tests of an axle's learned stiffness below ``stiffness_drop_limit`` times the vehicle
    file's (the tyres work past their linear range); none while the limit is 0 (``choices``, the
    numeric settings)."""
    if choices["stiffness_drop_limit"] <= 0:
        return ()
    share = settings["stiffness_drop_limit"]
    return (k.c_front < share * vehicle["cornering_stiffness_front"],
            k.c_rear < share * vehicle["cornering_stiffness_rear"])


def _initial_state(config, settings, choices, layout: Layout, block: MonitorBlock, u: dict,
                   kinematic: dict) -> ca.SX:
    """The state at the first sample (§2.7): EKF at [0, r_0] with P_0, RLS at the nominal
    stiffness, the filters at sample 0."""
    vehicle = config.vehicle
    c0_nom = nominal_c0(vehicle)
    first, holding = first_sample(u, config.limits, settings["vx_min"], settings["vx_resume"], block.monitored)
    ay0 = roll_corrected(first["ay"], settings["roll_gradient"])
    P0 = kalman.pack_symmetric(matrix(settings["initial_covariance"]))
    P_rls0 = kalman.pack_symmetric(ca.SX.eye(2) * settings["rls_initial_covariance"])
    if choices["stiffness"] == "rls":
        c_front0, c_rear0 = axle_stiffness(choices["stiffness_regressor"], (c0_nom, c0_nom),
                                           wheel_loads(vehicle, first["ax"], ay0))
    else:
        c_front0, c_rear0 = ca.SX(vehicle["cornering_stiffness_front"]), ca.SX(vehicle["cornering_stiffness_rear"])
    kinematic0 = {"beta_kin": ca.SX(0), "ax_f": first["ax"], "ay_f": ay0, "r_f": first["r"],
                  "delta_f": first["delta"], "beta_f": ca.SX(0)}
    return layout.pack({
        "beta_ekf": ca.SX(0), "r_ekf": first["r"],
        **{n: P0[i] for i, n in enumerate(_EKF)},
        "c0_1": c0_nom, "c0_2": c0_nom, **{n: P_rls0[i] for i, n in enumerate(_RLS)},
        "c_front": c_front0, "c_rear": c_rear0, "r_last": first["r"], "r_dot": ca.SX(0),
        "indicator": ca.SX(0), "beta": ca.SX(0), "holding": holding,
        **{n: kinematic0[n] for n in kinematic},
        **block.initial_entries(first),
    })


DEFINITIONS = (Definition(
    name=NAME, build=build, schema=SCHEMA,
    tunable={"process_noise": Tunable(1e-8, 1e-1), "measurement_noise": Tunable(1e-5, 1e-2),
             "forgetting_factor": Tunable(0.95, 0.9999, log=False),
             "indicator_low": Tunable(0.1, 2.0, regime=BEYOND_LINEAR),
             "indicator_high": Tunable(0.5, 10.0, regime=BEYOND_LINEAR)},
    status_bits=(status.LOW_SPEED, status.INVALID_INPUT, *CHECKS.status_bits), monitors=CHECKS.block,
    derived={**ROLL_GRADIENT, **GYRO_VARIANCE, **CHECKS.derived}),)
