"""arx_dual_kf: yaw rate from an ARX model with a dual Kalman filter (seed 004, a patent).

docs/methods.md, seed 004, §2 with the §3/§5 defaults:

* ARX(2) model x_n = a1 x_n-1 + a2 x_n-2 + b1 u_n-1 (+ b_delta delta_n-1 with
  ``exogenous = "mz_delta"``, E2), u = the direct yaw moment ``mz`` (N*m) [A2];
* KF1 on s = [x_n, x_n-1] in companion form (E3 default): predict with theta_n-1 and the inputs
  of n-1, update with the gyro (h = [1 0]) [B1-B6]; its first gain entry K1 is an output;
* KF2 on theta (random walk): measurement = KF1's output x_n, regressor
  phi = [x_n-1, x_n-2, u_n-1 (, delta_n-1)] from KF1 outputs (E4 default), R_theta = K1^2 R
  [C1-C6]; skipped (covariance still predicted) when the gyro sample is implausible, the speed is
  low, or phi' P phi < excitation_floor (E5);
* E5 projection: when a parameter update moves the roots of z^2 - a1 z - a2 outside
  ``stability_radius``, a1 and a2 are rescaled onto it (status PARAMETERS_PROJECTED).

Both filters use the Joseph form of the shared model.kalman update. Invalid inputs (docs/methods.md, the common rule):
an implausible gyro sample skips both updates (prediction only); an implausible ``mz`` (or
delta) counts as 0 for this sample; status INVALID_INPUT. The ``mz`` column is optional in a log:
the harness feeds 0 when it is absent, and the filter then is an adaptive AR(2) smoother of the
gyro (E2; ``exogenous = "mz_delta"`` explains steer-induced yaw as well).

Priors (§2.5) at the first sample's speed vx_0 (clamped to [vx_min, vx_max]): Phi, Gamma = ZOH of
the bicycle model's A(vx_0) and [B_delta, B_M], B_M = [0, 1/I_z]; a1 = tr Phi, a2 = -det Phi,
b1 = Gamma_M(2), b_delta = Gamma_delta(2). The noise scales of the input parameters use their
first-order values b1 ~ T/I_z and b_delta ~ T a C_f/I_z (generation-time constants).
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import discretize, kalman, signals, status
from vsegen.model.bicycle import bicycle_matrices
from vsegen.model.calibration import Parameters
from vsegen.model.estimator import GYRO_VARIANCE, Definition, Estimator, SingleStep, Tunable, make_functions
from vsegen.model.estimators.kf2dof import zoh_plan
from vsegen.model.guard import first_sample, hold, input_guard, model_speed
from vsegen.model.layout import Layout
from vsegen.model.schema import LOW_SPEED_FIELDS, LOW_SPEED_RULES, EstimatorSchema, choice, fraction, positive
from vsegen.model.signals import Signal

NAME = "arx_dual_kf"

SCHEMA = EstimatorSchema(
    fields=(
        choice("exogenous", ("mz", "mz_delta"), "ARX inputs: the patent's direct yaw moment, or "
               "also the steer angle (E2)"),
        positive("measurement_noise", "(rad/s)^2", "R: gyro noise variance"),
        positive("model_noise", "(rad/s)^2", "Q: variance of the ARX model error e_n per step"),
        positive("ar_drift", "-", "Q_theta of a1 and a2 per step"),
        positive("input_drift", "-", "Q_theta of an input parameter = (input_drift b)^2 per step"),
        positive("ar_initial_variance", "-", "P_theta,0 of a1 and a2"),
        positive("input_initial_factor", "-", "P_theta,0 of an input parameter = (factor b)^2"),
        fraction("stability_radius", "largest root radius of z^2 - a1 z - a2 (E5)"),
        positive("excitation_floor", "-", "skip the parameter update when phi' P phi is below"),
        *LOW_SPEED_FIELDS,
    ),
    rules=LOW_SPEED_RULES)
"""Seed 004's ARX dual Kalman filter (docs/methods.md, seed 004 §3, §5)."""

INPUTS = Layout(signals.inputs("delta", "vx", "r", "mz"))
HISTORY = ("x_1", "x_2")
"""KF1 state: the yaw-rate outputs x_n-1 and x_n-2 before a step (x_n and x_n-1 after it)."""


def regressors(settings) -> tuple[str, ...]:
    """Names of the ARX parameters, in regressor order."""
    return ("a1", "a2", "b_mz", *(("b_delta",) if settings["exogenous"] == "mz_delta" else ()))


def layouts(settings) -> tuple[Layout, Layout]:
    """(states, outputs) for the configured exogenous inputs."""
    theta = regressors(settings)
    states = Layout((
        Signal("x_1", "rad/s", "yaw-rate output one sample back"),
        Signal("x_2", "rad/s", "yaw-rate output two samples back"),
        *(Signal(n, "(rad/s)^2", "KF1 covariance entry (upper triangle)")
          for n in kalman.packed_names("P", HISTORY)),
        *(Signal(n, "-", f"ARX parameter {n}") for n in theta),
        *(Signal(n, "-", "KF2 covariance entry (upper triangle)")
          for n in kalman.packed_names("Pt", theta)),
        Signal("mz_prev", "N*m", "yaw moment of the previous sample (0 if it was implausible)"),
        *((Signal("delta_prev", "rad", "steer angle of the previous sample"),)
          if "b_delta" in theta else ()),
        signals.LOW_SPEED_HOLD,
    ))
    outputs = Layout((
        Signal("r", "rad/s", "filtered yaw rate x_n"),
        *(Signal(n, "-", f"ARX parameter {n}") for n in theta),
        Signal("gain", "-", "KF1 gain K1 of this sample"),
        signals.STATUS,
    ))
    return states, outputs


def prior(params: Parameters, vx) -> ca.SX:
    """theta_0 = [tr Phi, -det Phi, Gamma_M(2) (, Gamma_delta(2))] of the bicycle model at ``vx``."""
    config = params.config
    vehicle = config.vehicle
    A, B_delta, _, _ = bicycle_matrices(vehicle, vx)
    B = ca.horzcat(B_delta, ca.vertcat(0, 1.0 / vehicle["yaw_inertia"]))
    Phi, Gamma = discretize.discretise("zoh", A, B, config.sample_time, zoh_plan(params, NAME))
    theta = [Phi[0, 0] + Phi[1, 1], -(Phi[0, 0] * Phi[1, 1] - Phi[0, 1] * Phi[1, 0]), Gamma[1, 1]]
    if config.settings(NAME)["exogenous"] == "mz_delta":
        theta.append(Gamma[1, 0])
    return ca.vertcat(*theta)


def input_scales(params: Parameters) -> list:
    """First-order sizes of b_mz (T/I_z) and b_delta (T a C_f / I_z) for the noise scales."""
    vehicle, T = params.config.vehicle, params.config.sample_time
    scales = [T / vehicle["yaw_inertia"]]
    if params.config.settings(NAME)["exogenous"] == "mz_delta":
        scales.append(T * vehicle["cg_to_front_axle"] * vehicle["cornering_stiffness_front"]
                      / vehicle["yaw_inertia"])
    return scales


def parameter_covariances(params: Parameters) -> tuple[ca.SX, ca.SX]:
    """(P_theta,0, Q_theta): diagonal; AR entries ar_initial_variance and ar_drift, input entries
    (input_initial_factor b)^2 and (input_drift b)^2."""
    settings = params.config.settings(NAME)
    scales = input_scales(params)
    P0 = [settings["ar_initial_variance"]] * 2 + [(settings["input_initial_factor"] * b) ** 2
                                                  for b in scales]
    Q = [settings["ar_drift"]] * 2 + [(settings["input_drift"] * b) ** 2 for b in scales]
    return ca.diag(ca.vertcat(*P0)), ca.diag(ca.vertcat(*Q))


PARAMETER_WALK_GAIN = 10.0
"""``Estimator.rounding_gain``: KF2 models the ARX parameters as random walks, so the rounding
difference a step leaves in a1, a2 is kept, not forgotten, and the differences of a run add up
(a plain Kalman filter's state forgets them). Found on rwd_saloon's spinning mu = 0.5 DLC at
120 km/h: every single step matches the reference within 3e-14, but while the spin's large yaw
rates drive the parameter update (with the E5 projection active) a step leaves up to 5e-15 in
a1 or a2; 100 such steps left 1.1e-14, which is 1.1e-12 of the guard when a2 crosses zero. The
verification runs are at most 3001 steps long; a gain of 10 covers that accumulation."""


def project_stable(a1, a2, radius, updated):
    """E5: (a1, a2, projected) with the roots of z^2 - a1 z - a2 scaled into |z| <= radius, after
    an ``updated`` parameter step only (unchanged parameters were projected when they changed;
    testing them again would flicker on the boundary in rounding)."""
    discriminant = a1 * a1 + 4 * a2
    rho = ca.if_else(discriminant >= 0, (ca.fabs(a1) + ca.sqrt(ca.fmax(discriminant, 0))) / 2,
                     ca.sqrt(ca.fmax(-a2, 0)))
    projected = ca.logic_and(updated, rho > radius)
    scale = ca.if_else(projected, radius / rho, 1)
    return a1 * scale, a2 * scale * scale, projected


def build(params: Parameters) -> Estimator:
    """The arx_dual_kf estimator ([vehicle], [inputs], [estimator.arx_dual_kf])."""
    config = params.config
    settings = config.settings(NAME)
    states, outputs = layouts(params.numeric.settings(NAME))
    theta_names = regressors(params.numeric.settings(NAME))
    n = len(theta_names)
    R, Q = settings["measurement_noise"], settings["model_noise"]
    _, Q_theta = parameter_covariances(params)
    vx_min, vx_resume = settings["vx_min"], settings["vx_resume"]

    state, s = states.symbols("state")
    inputs, u = INPUTS.symbols("input")
    guard = input_guard(u, config.limits, vx_min, vx_resume, s["low_speed_hold"])
    ok = guard.plausible
    gyro_ok = ok["r"]
    adapting = ca.logic_and(gyro_ok, ca.logic_and(ok["vx"], ca.logic_not(guard.low_speed)))

    theta = ca.vertcat(*[s[name] for name in theta_names])
    previous_inputs = [s["mz_prev"], *([s["delta_prev"]] if n == 4 else [])]
    phi = ca.vertcat(s["x_1"], s["x_2"], *previous_inputs)
    s_next, P_next, gain = _history_kf(s, theta, previous_inputs, hold(u["r"], gyro_ok, 0), gyro_ok, R, Q)
    x_n = s_next[0]
    theta_out, P_theta_next, projected = _parameter_kf(s, theta_names, theta, phi, x_n, gain * gain * R,
                                                       Q_theta, settings, adapting)

    mz = hold(u["mz"], ok["mz"], 0)
    next_state = states.pack({
        "x_1": x_n, "x_2": s_next[1],
        **{k: P_next[i] for i, k in enumerate(kalman.packed_names("P", HISTORY))},
        **{k: theta_out[i] for i, k in enumerate(theta_names)},
        **{k: P_theta_next[i] for i, k in enumerate(kalman.packed_names("Pt", theta_names))},
        "mz_prev": mz,
        **({"delta_prev": hold(u["delta"], ok["delta"], 0)} if n == 4 else {}),
        "low_speed_hold": ca.if_else(guard.low_speed, 1, 0),
    })
    code = guard.status + ca.if_else(projected, status.PARAMETERS_PROJECTED, 0)
    output = outputs.pack({"r": x_n, **{k: theta_out[i] for i, k in enumerate(theta_names)},
                           "gain": gain, "status": code})

    init_state = _initial_state(params, states, theta_names, u)
    init, step = make_functions(NAME, INPUTS, states, outputs, inputs, state, init_state,
                                next_state, output, params)
    return Estimator(NAME, "yaw rate from an ARX model with a dual Kalman filter (seed 004)",
                     INPUTS, states, outputs, init, SingleStep(step), params,
                     notes(params), rounding_gain=PARAMETER_WALK_GAIN)


def _history_kf(s: dict, theta, previous_inputs: list, r_measured, gyro_ok, R, Q):
    """KF1: companion-form prediction of the yaw-rate history with theta_n-1, update with the gyro
    where it is plausible. Returns (history, its packed covariance, the gain of its first entry)."""
    n = theta.numel()
    companion = ca.blockcat([[theta[0], theta[1]], [1, 0]])
    Gamma = ca.vertcat(ca.horzcat(*[theta[i] for i in range(2, n)]), ca.SX.zeros(1, n - 2))
    P = kalman.unpack_symmetric(ca.vertcat(*[s[k] for k in kalman.packed_names("P", HISTORY)]), 2)
    s_pred, P_pred = kalman.predict(ca.vertcat(s["x_1"], s["x_2"]), P, companion, Gamma,
                                    ca.vertcat(*previous_inputs), ca.diag(ca.vertcat(Q, 0)))
    h = ca.horzcat(1, 0)
    s_upd, P_upd, _ = kalman.update_joseph(s_pred, P_pred, r_measured, h, ca.SX.zeros(1, 1), ca.SX(0), R)
    gain = ca.if_else(gyro_ok, P_pred[0, 0] / (P_pred[0, 0] + R), 0)
    s_next = ca.if_else(gyro_ok, s_upd, s_pred)
    P_next = ca.if_else(gyro_ok, kalman.pack_symmetric(P_upd), kalman.pack_symmetric(P_pred))
    return s_next, P_next, gain


def _parameter_kf(s: dict, theta_names, theta, phi, x_n, variance, Q_theta, settings, adapting):
    """KF2: random-walk parameters with KF1's output ``x_n`` (of ``variance``) as measurement, on
    excited samples while ``adapting``, projected into the stability region. Returns (theta, the
    packed covariance, whether the projection acted)."""
    n = len(theta_names)
    P_theta = kalman.unpack_symmetric(
        ca.vertcat(*[s[k] for k in kalman.packed_names("Pt", theta_names)]), n) + Q_theta
    excited = ca.mtimes([phi.T, P_theta, phi]) >= settings["excitation_floor"]
    identify = ca.logic_and(adapting, excited)
    theta_upd, P_theta_upd, _ = kalman.update_joseph(theta, P_theta, x_n, phi.T, ca.SX.zeros(1, 1),
                                                     ca.SX(0), variance)
    theta_next = ca.if_else(identify, theta_upd, theta)
    P_theta_next = ca.if_else(identify, kalman.pack_symmetric(P_theta_upd),
                              kalman.pack_symmetric(P_theta))
    a1, a2, projected = project_stable(theta_next[0], theta_next[1], settings["stability_radius"],
                                       identify)
    return ca.vertcat(a1, a2, theta_next[2:]), P_theta_next, projected


def _initial_state(params: Parameters, states: Layout, theta_names: tuple[str, ...], u: dict) -> ca.SX:
    """The state at the first sample: both history entries at r_0 with P = R I, the parameters at
    their prior for v_x,0 with P_theta,0, the previous inputs at sample 0."""
    config = params.config
    settings = config.settings(NAME)
    vx_min = settings["vx_min"]
    first, holding = first_sample(u, config.limits, vx_min, settings["vx_resume"])
    vx0 = model_speed(first["vx"], vx_min, config.limits["vx_max"])
    theta0 = prior(params, vx0)
    P0 = kalman.pack_symmetric(ca.SX.eye(2) * settings["measurement_noise"])
    P_theta0_packed = kalman.pack_symmetric(parameter_covariances(params)[0])
    return states.pack({
        "x_1": first["r"], "x_2": first["r"],
        **{k: P0[i] for i, k in enumerate(kalman.packed_names("P", HISTORY))},
        **{k: theta0[i] for i, k in enumerate(theta_names)},
        **{k: P_theta0_packed[i] for i, k in enumerate(kalman.packed_names("Pt", theta_names))},
        "mz_prev": first["mz"],
        **({"delta_prev": first["delta"]} if len(theta_names) == 4 else {}),
        "low_speed_hold": holding,
    })


def notes(params: Parameters) -> dict[str, str]:
    """Notes for the generated files: inputs and the prior's ZOH series."""
    plan = zoh_plan(params, NAME)
    return {"exogenous": params.numeric.settings(NAME)["exogenous"],
            "prior_zoh_series": f"{plan.terms} Taylor terms, {plan.squarings} squarings, "
                                f"|Phi - expm(A T)|_inf <= {plan.error_bound:.1e}"}


DEFINITIONS = (Definition(
    name=NAME, build=build, schema=SCHEMA,
    tunable={"measurement_noise": Tunable(1e-6, 1e-2), "model_noise": Tunable(1e-7, 1e-3),
             "ar_drift": Tunable(1e-9, 1e-3), "input_drift": Tunable(1e-4, 1.0)},
    status_bits=(status.LOW_SPEED, status.INVALID_INPUT, status.PARAMETERS_PROJECTED),
    derived=GYRO_VARIANCE),)
