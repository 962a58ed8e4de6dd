"""aukf / ukf: speeds, yaw rate and sideslip from an unscented Kalman filter on the 3-DOF HSRI
model, with (aukf) or without (ukf) the sub-optimal Sage-Husa process-noise estimator (seed 002).

docs/methods.md, seed 002, §2 with the §3/§5 defaults:

* state X = [u, v, gamma, Gamma, a_x, a_y], process model ``model.three_dof`` (Euler, HSRI tyres,
  load transfer; C2: Gamma, a_x, a_y one step delayed); cornering stiffness per tyre = half the
  [vehicle] axle value;
* scaled UT with 2n + 1 = 13 points (``model.unscented``): unrolled Cholesky of P plus a
  per-entry jitter, with the non-positive-definite repair (status COVARIANCE_REPAIRED); each pair
  of points propagated in pair arithmetic (``model.increments``, C6), so nothing cancels; the C
  runs the 6 pairs through one kernel in a loop (``model.estimator.Repeated``);
* UKF recursion (12)-(14) with the noise mean q, the points not redrawn, Z = [a_x, a_y, gamma]
  (linear, so P_zz = H P_chi H' + R and P_xz = P_chi H' with P_chi the points' spread), the
  covariance update in Joseph form;
* aukf: (15a)-(15b) with d_k = (1 - f)/(1 - f^(k+1)) (the state keeps f^(k+1)); Q kept diagonal,
  each entry at least 1e-3 Q_0 (§2.10; ``noise_safeguard = "none"`` drops this floor) and, beyond
  the spec, at most ``process_noise_max`` (abusive inputs otherwise grow Q and P until they
  overflow); beyond the spec too, a sample on which the monitor block raises any bit (an input
  check, the consistency monitor, BEYOND_LINEAR_RANGE) is not learnt from: q, Q and f^(k+1) are
  kept (the noise mean integrates the correction, so a steering angle frozen for 2 s otherwise
  left a yaw-moment mean of 530 N*m and beta 0.2 deg off for good after it).

Hold rule (model.guard, on the logged vx like every estimator): while holding every state is kept
and beta = 0; ``hold_reason`` is 2 for a low-speed hold, 1 for an invalid input. The first sample
after a low-speed hold restarts the filter from itself (the speed it stopped with is stale); after
an invalid input it continues. Beyond the spec, an estimate outside the plausible envelope
(``restart_speed_error``, ``restart_sideslip``) restarts the filter from the current sample
(status FILTER_RESTARTED). Initial state [vx_0, 0, 0, 0, 0, 0] (the paper's
X(t_0) = [26.6667, 0, ...] is its test speed), P_0, q_0 = 0, Q_0 from the vehicle file.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import casadi as ca

from vsegen.model import kalman, signals, status, unscented
from vsegen.model.bicycle import GRAVITY
from vsegen.model.calibration import Parameters
from vsegen.model.estimator import ROLL_GRADIENT, Definition, Estimator, Tunable, make_functions, make_repeated
from vsegen.model.guard import first_sample, hold, input_guard, model_speed
from vsegen.model.increments import Pair, lift
from vsegen.model.layout import Layout, covariance_signals
from vsegen.model.monitor_block import Checks, MonitorBlock
from vsegen.model.schema import (
    CAPS_ABOVE_FLOORS,
    LOW_SPEED_FIELDS,
    LOW_SPEED_RULES,
    ROLL_CORRECTION,
    EstimatorSchema,
    Field,
    between,
    choice,
    diagonal,
    nonnegative,
    number_field,
    positive,
)
from vsegen.model.sensors import roll_corrected
from vsegen.model.signals import Signal
from vsegen.model.three_dof import ThreeDof

NAME = "aukf"
PLAIN_NAME = "ukf"

CHANNELS = ("ax", "ay", "r")
"""The measured channels, in Z's order (the consistency monitor's sensor_noise order)."""
_BASE_INPUTS = ("delta", "vx", "ax", "ay", "r")


def method_inputs(settings) -> tuple[str, ...]:
    """What the model reads: with ``longitudinal_force = "wheel_speeds"`` also every wheel speed."""
    wheels = settings["longitudinal_force"] == "wheel_speeds"
    return (*_BASE_INPUTS, *(signals.WHEEL_SPEEDS if wheels else ()))


CHECKS = Checks(method_inputs, channels=CHANNELS, linear_range=True)
"""Beyond the spec: the monitor block (model.monitor_block)."""
UKF_FIELDS: tuple[Field, ...] = (
    choice("longitudinal_force", ("wheel_speeds", "free_rolling"), "tyre slip ratios from the "
           "measured wheel speeds (C4.1) or free rolling with a_x a random walk (C4.2)"),
    positive("friction", "-", "road friction mu of the HSRI model (known, C9)"),
    positive("longitudinal_stiffness", "N", "C_x per tyre, N per unit slip (the cornering "
             "stiffness per tyre is half the [vehicle] axle value)"),
    nonnegative("drag_area", "m^2", "C_d A of the drag F_w = 1.2 C_dA u^2 / 2 (0 = none, the "
                "paper)"),
    positive("slip_speed_floor", "m/s", "eps_v: slip ratios divide by max(r omega, eps_v)"),
    number_field("ut_alpha", "a number in (0, 1]", lambda x: 0.0 < x <= 1.0,
                 "UT spread alpha", bounds=((">", 0.0), ("<=", 1.0))),
    nonnegative("ut_beta", "-", "UT prior-distribution factor beta (2 for Gaussian)"),
    nonnegative("ut_kappa", "-", "UT secondary scaling kappa"),
    diagonal("initial_covariance", 6, "[u, v, gamma, Gamma, a_x, a_y]: SI units squared", "P_0",
             zero_allowed=True),
    diagonal("process_noise", 6, "SI units squared per step", "Q (Q_0 of the adaptive filter)"),
    diagonal("measurement_noise", 3, "[a_x, a_y, gamma]: (m/s^2)^2, (m/s^2)^2, (rad/s)^2", "R"),
    nonnegative("restart_speed_error", "m/s", "beyond the spec: restart the filter from the "
                "current sample when |u - v_x| exceeds this (status FILTER_RESTARTED); 0 = never"),
    nonnegative("restart_sideslip", "rad", "beyond the spec: restart when |atan2(v, u)| exceeds "
                "this; 0 = never"),
    ROLL_CORRECTION,
    *CHECKS.fields,
    *LOW_SPEED_FIELDS,
)
"""Seed 002's UKF on the 3-DOF HSRI model (docs/methods.md, seed 002 §3, §5)."""

UKF_SCHEMA = EstimatorSchema(fields=UKF_FIELDS, rules=LOW_SPEED_RULES)
AUKF_SCHEMA = EstimatorSchema(
    fields=(*UKF_FIELDS, between("forgetting_factor", 0.95, 0.99, "Sage-Husa fading factor f "
                                 "(the paper: 0.95 < f < 0.99)"),
            choice("noise_safeguard", ("floor", "none"), "Sage-Husa safeguard: Q_ii >= 1e-3 "
                   "Q_0,ii (the spec's §2.10) or none (the literal (15b): Q may turn negative and "
                   "the covariance lose positive definiteness, which the repair then catches)"),
            diagonal("process_noise_max", 6, "SI units squared per step", "ceiling of the adapted "
                     "Q (beyond the spec: without it abusive inputs, e.g. a_y alternating "
                     "+-25 m/s^2, grow Q and P until they overflow)")),
    rules=(*LOW_SPEED_RULES, CAPS_ABOVE_FLOORS))
STATE = (("u", "m/s", "longitudinal speed"), ("v", "m/s", "lateral speed"),
         ("gamma", "rad/s", "yaw rate"), ("moment", "N*m", "yaw moment Gamma"),
         ("ax", "m/s^2", "longitudinal acceleration"), ("ay", "m/s^2", "lateral acceleration"))
X_NAMES = tuple(name for name, _, _ in STATE)
N = len(STATE)
MEASURED = (4, 5, 2)
"""Z = [a_x, a_y, gamma] = X[4], X[5], X[2]."""
Q_FLOOR = 1e-3
"""Sage-Husa safeguard: Q_ii >= Q_FLOOR Q_0,ii (§2.10)."""
COVARIANCE = kalman.packed_names("P", X_NAMES)
"""The state names behind each entry of COVARIANCE."""


def force_scales(vehicle) -> dict[str, float]:
    """Per state, the size at which its rounding is judged (``model.layout.Signal.scale``): the
    yaw moment and the accelerations are balances of four tyre forces of about m g / 4 each, so
    m g l / 4 (N*m) and g (m/s^2); 1 for the speeds and the yaw rate."""
    scales = {name: 1.0 for name in X_NAMES}
    scales.update(moment=vehicle["mass"] * GRAVITY * vehicle["wheelbase"] / 4, ax=GRAVITY,
                  ay=GRAVITY)
    return scales




def layouts(settings, adaptive: bool, vehicle) -> tuple[Layout, Layout, Layout]:
    """(inputs, states, outputs) for the configured longitudinal force and variant."""
    block = CHECKS.block(settings)
    inputs = block.inputs
    scale = force_scales(vehicle)
    estimates = tuple(Signal(name, unit, doc, scale=scale[name]) for name, unit, doc in STATE)
    states = Layout((
        *estimates,
        *covariance_signals("P", estimates, doc="covariance entry (upper triangle)"),
        *((*(Signal(f"qmean_{n}", unit, f"process-noise mean of {n}", scale=scale[n])
             for n, unit, _ in STATE),
           *(Signal(f"qvar_{n}", f"({unit})^2", f"process-noise variance of {n}",
                    scale=scale[n] ** 2) for n, unit, _ in STATE),
           Signal("fading", "-", "f^(k+1), for the Sage-Husa weight d_k")) if adaptive else ()),
        *block.states,
        signals.HOLD_REASON,
        *block.segment,
    ))
    outputs = Layout((
        Signal("beta", "rad", "sideslip angle atan2(v, u)"),
        Signal("vx", "m/s", "longitudinal speed u"),
        Signal("vy", "m/s", "lateral speed v"),
        Signal("r", "rad/s", "yaw rate gamma"),
        Signal("yaw_moment", "N*m", "yaw moment Gamma", scale=scale["moment"]),
        Signal("ax", "m/s^2", "longitudinal acceleration a_x", scale=scale["ax"]),
        Signal("ay", "m/s^2", "lateral acceleration a_y", scale=scale["ay"]),
        signals.STATUS,
    ))
    return inputs, states, outputs


def process_model(params: Parameters, name: str) -> ThreeDof:
    """The 3-DOF HSRI model with the vehicle's and the estimator's parameters."""
    config = params.config
    v, s = config.vehicle, config.settings(name)
    return ThreeDof(
        mass=v["mass"], yaw_inertia=v["yaw_inertia"], cg_to_front_axle=v["cg_to_front_axle"],
        cg_to_rear_axle=v["cg_to_rear_axle"], track_width=v["track_width"],
        cg_height=v["cg_height"],
        cornering_front=v["cornering_stiffness_front"] / 2,
        cornering_rear=v["cornering_stiffness_rear"] / 2,
        longitudinal=s["longitudinal_stiffness"], friction=s["friction"],
        drag_area=s["drag_area"], slip_speed_floor=s["slip_speed_floor"],
        sample_time=config.sample_time,
        wheel_speeds=params.numeric.settings(name)["longitudinal_force"] == "wheel_speeds")


def pair_function(model: ThreeDof, name: str, params: Parameters) -> ca.Function:
    """``each(shared, offset[, params]) -> [odd; even]``: the parts of F(x +- offset) - F(x) for
    one pair of sigma points, in pair arithmetic (``model.increments``); ``shared`` =
    [x, delta, cos delta, sin delta, r omega_fl..rr (wheel-speed mode)]. The C calls it once per
    pair (``model.estimator.Repeated``)."""
    shared = ca.SX.sym("shared", N + 3 + (len(signals.WHEEL_SPEEDS) if model.wheel_speeds else 0))
    offset = ca.SX.sym("offset", N)
    x = [shared[i] for i in range(N)]
    delta, cos_delta, sin_delta = shared[N], shared[N + 1], shared[N + 2]
    rolling = [shared[N + 3 + j] for j in range(len(signals.WHEEL_SPEEDS))] if model.wheel_speeds else None
    moved = [lift(v) for v in model.step([Pair(x[i], offset[i], ca.SX(0)) for i in range(N)],
                                         delta, cos_delta, sin_delta, rolling)]
    result = ca.vertcat(*[v.odd for v in moved], *[v.even for v in moved])
    extra = params.inputs()
    return ca.Function(f"vse_{name}_kernel_each", [shared, offset, *extra],
                       [ca.densify(ca.cse(result))], ["shared", "item", *["params"] * len(extra)],
                       ["result"])


def rounding_gain(weights: unscented.Weights, config, name: str) -> float:
    """How much the filter amplifies a rounding of its inputs' scale (``Estimator.rounding_gain``):
    the UT's sum |W_m| times the stiffest tyre force's sensitivity to a speed, relative to the
    force scale m g / 4. A slip ratio (r omega - u_x) / (r omega) rounds at the speed's scale, and
    C_x (or C_y) turns that into force: the relative rounding of a force is 4 C / (m g) times the
    relative rounding of the speed."""
    vehicle = config.vehicle
    stiffest = max(config.settings(name)["longitudinal_stiffness"],
                   vehicle["cornering_stiffness_front"] / 2, vehicle["cornering_stiffness_rear"] / 2)
    return weights.rounding_gain * 4 * stiffest / (vehicle["mass"] * GRAVITY)


def diverged(x: ca.SX, vx_measured: ca.SX, settings) -> ca.SX:
    """1 when the estimate x left the plausible envelope: |u - v_x,measured| above
    ``restart_speed_error`` or |atan2(v, u)| above ``restart_sideslip`` (each 0 = never)."""
    speed, sideslip = settings["restart_speed_error"], settings["restart_sideslip"]
    return ca.logic_or(
        ca.logic_and(speed > 0, ca.fabs(x[0] - vx_measured) > speed),
        ca.logic_and(sideslip > 0, ca.fabs(ca.atan2(x[1], x[0])) > sideslip))


def build_adaptive(params: Parameters) -> Estimator:
    """The aukf estimator ([vehicle], [inputs], [estimator.aukf])."""
    return _build(params, NAME, adaptive=True)


def build_plain(params: Parameters) -> Estimator:
    """The ukf estimator ([vehicle], [inputs], [estimator.ukf])."""
    return _build(params, PLAIN_NAME, adaptive=False)


@dataclass(frozen=True)
class _Symbols:
    """What every section of one build reads: the layouts, the symbols and the input guard."""

    params: Parameters
    name: str
    adaptive: bool
    settings: Any
    inputs_layout: Layout
    states: Layout
    outputs: Layout
    state: ca.SX
    kept: dict
    inputs: ca.SX
    u: dict
    guard: Any
    monitors: MonitorBlock


@dataclass(frozen=True)
class _Filter:
    """The filter's values at the start of a step: the state entries ``s`` (after a low-speed
    restart), the estimate x, its covariance P and the process-noise mean q and variances Q."""

    s: dict
    x: ca.SX
    P: ca.SX
    q: ca.SX
    Q: ca.SX


def _build(params: Parameters, name: str, adaptive: bool) -> Estimator:
    config = params.config
    settings = config.settings(name)
    numeric = params.numeric.settings(name)
    inputs_layout, states, outputs = layouts(numeric, adaptive, params.numeric.vehicle)
    state, kept = states.symbols("state")
    inputs, u = inputs_layout.symbols("input")
    block = CHECKS.block(numeric)
    sym = _Symbols(params, name, adaptive, settings, inputs_layout, states, outputs, state, kept, inputs, u,
                   input_guard(u, config.limits, settings["vx_min"], settings["vx_resume"], kept["hold_reason"],
                               block.monitored),
                   block)
    init_state = _initial_state(sym)
    start = _restarted_after_low_speed(sym, init_state)
    return _step(sym, init_state, start)


def _initial_state(sym: _Symbols) -> ca.SX:
    """The state at the first sample: [vx_0, 0, ...], P_0, q_0 = 0, Q_0, the monitor at rest."""
    config, settings = sym.params.config, sym.settings
    first, holding = first_sample(sym.u, config.limits, settings["vx_min"], settings["vx_resume"],
                                  sym.guard.monitored)
    vx0 = model_speed(first["vx"], settings["vx_min"], config.limits["vx_max"])
    Q0 = ca.vertcat(*settings["process_noise"])
    P0 = settings["initial_covariance"]
    return sym.states.pack({
        "u": vx0, **{n: ca.SX(0) for n in X_NAMES[1:]},
        **dict(zip(COVARIANCE, ca.vertsplit(kalman.pack_symmetric(ca.diag(ca.vertcat(*P0)))))),
        **({**{f"qmean_{n}": ca.SX(0) for n in X_NAMES},
            **{f"qvar_{n}": Q0[i] for i, n in enumerate(X_NAMES)},
            "fading": ca.SX(settings["forgetting_factor"])} if sym.adaptive else {}),
        **sym.monitors.initial_entries(first),
        "hold_reason": 2 * holding,
    })


def _restarted_after_low_speed(sym: _Symbols, init_state: ca.SX) -> _Filter:
    """The filter this step starts from: the first sample after a low-speed hold (hold_reason = 2)
    restarts the filter from itself, any other continues from the state."""
    start = ca.if_else(sym.kept["hold_reason"] > 1.5, init_state, sym.state)
    s = {name: start[i] for i, name in enumerate(sym.states.names)}
    x = ca.vertcat(*[s[n] for n in X_NAMES])
    P = kalman.unpack_symmetric(ca.vertcat(*[s[n] for n in COVARIANCE]), N)
    if sym.adaptive:
        q = ca.vertcat(*[s[f"qmean_{n}"] for n in X_NAMES])
        Q = ca.vertcat(*[s[f"qvar_{n}"] for n in X_NAMES])
    else:
        q, Q = ca.SX.zeros(N), ca.vertcat(*sym.settings["process_noise"])
    return _Filter(s, x, P, q, Q)


def _step(sym: _Symbols, init_state: ca.SX, f: _Filter) -> Estimator:
    """Prediction (10)-(12), update (13)-(14), Sage-Husa (15a)-(15b), monitors, the estimator."""
    params, name, settings, u, active = sym.params, sym.name, sym.settings, sym.u, sym.guard.active
    config = params.config
    model = process_model(params, name)
    weights = unscented.Weights(N, settings["ut_alpha"], settings["ut_beta"], settings["ut_kappa"])

    # ---- prediction (10)-(12): inputs are used only while active, so hold them harmlessly -------
    delta = hold(u["delta"], active, 0)
    cos_delta, sin_delta = ca.cos(delta), ca.sin(delta)
    wheels = [hold(u[n], active, 0) * config.vehicle["wheel_radius"]
              for n in signals.WHEEL_SPEEDS] if model.wheel_speeds else None
    L, repaired = unscented.cholesky_repaired(f.P)
    offsets = unscented.sigma_offsets(L, weights)
    shared = ca.vertcat(f.x, delta, cos_delta, sin_delta, *(wheels or []))
    each = pair_function(model, name, params)
    results = ca.SX.sym("pairs", 2 * N * N)            # per pair of points: odd, even (N each)
    pairs = [(results[2 * N * k:2 * N * k + N], results[2 * N * k + N:2 * N * (k + 1)])
             for k in range(N)]
    centre = ca.vertcat(*model.step([f.x[i] for i in range(N)], delta, cos_delta, sin_delta, wheels))
    propagated, spread = unscented.statistics(centre, pairs, weights)
    x_pred = propagated + f.q

    x_new, P_new, innovation, correction = _update(settings, u, active, x_pred, spread, f.Q)
    watched, judged = _monitors(sym, f, innovation, x_pred[MEASURED[1]])
    extra = (_sage_husa(sym, f, propagated, spread, x_new, P_new, correction, learns=watched.code + judged.code == 0)
             if sym.adaptive else {})
    next_state, output, checks = _finish(sym, init_state, f, x_new, P_new, repaired, extra, watched, judged)
    repeated, next_state, output = make_repeated(name, sym.state, sym.inputs, offsets, shared, each,
                                                 results, ca.cse(next_state), ca.cse(output), params, checks)
    init, step = make_functions(name, sym.inputs_layout, sym.states, sym.outputs, sym.inputs, sym.state,
                                init_state, next_state, output, params, checks)
    return _estimator(sym, init, replace(repeated, step=step))


def _update(settings, u, active, x_pred: ca.SX, spread: ca.SX, Q: ca.SX):
    """Measurement update (13)-(14): (x, P, prior innovation, correction K innovation)."""
    R = ca.diag(ca.vertcat(*settings["measurement_noise"]))
    H = ca.SX.zeros(3, N)
    for row, column in enumerate(MEASURED):
        H[row, column] = 1
    z = ca.vertcat(hold(u["ax"], active, 0),
                   roll_corrected(hold(u["ay"], active, 0), settings["roll_gradient"]),
                   hold(u["r"], active, 0))
    P_zz = ca.mtimes([H, spread, H.T]) + R
    P_xz = ca.mtimes(spread, H.T)
    K = ca.mtimes(P_xz, ca.inv(P_zz))
    innovation = z - ca.mtimes(H, x_pred)
    correction = ca.mtimes(K, innovation)
    x_new = x_pred + correction
    # P_pred - K P_zz K' (14) in Joseph form for the points' spread (K is its optimal gain):
    # a sum of positive semi-definite terms, with none of the cancellation of the printed form
    I_KH = ca.SX.eye(N) - ca.mtimes(K, H)
    P_new = ca.mtimes([I_KH, spread, I_KH.T]) + ca.mtimes([K, R, K.T]) + ca.diag(Q)
    return x_new, P_new, innovation, correction


def _monitors(sym: _Symbols, f: _Filter, innovation, ay_model):
    """(the input checks' stage, the model checks' stage) of the monitor block, from the state as it
    came in, the prior ``innovation`` and the prior's a_y ``ay_model`` (for the linear-range flag)."""
    config = sym.params.config
    T = config.sample_time
    watched = sym.monitors.watch_inputs(sym.kept, sym.u, sym.guard.plausible, sym.guard.active, sym.settings, T,
                                        config.vehicle, config.limits)
    judged = sym.monitors.judge_model(f.s, sym.guard.active, sym.settings, T, innovation, sym.u["ay"], ay_model,
                                      held_here=False)
    return watched, judged


def _sage_husa(sym: _Symbols, f: _Filter, propagated, spread, x_new, P_new, correction, learns) -> dict:
    """Sage-Husa (15a)-(15b): the next noise mean and variances (floored, capped) and fading, where
    ``learns``; else the three kept (beyond the spec: the sample is skipped while the monitor block
    raises any bit, so that a fault or the model's error at the limit is not learnt as noise: the
    noise mean integrates the correction, and kept for good what it learnt there)."""
    settings = sym.settings
    forgetting = settings["forgetting_factor"]
    d = (1 - forgetting) / (1 - f.s["fading"])
    q_new = (1 - d) * f.q + d * (x_new - propagated)
    bracket = correction * correction + ca.diag(P_new) - ca.diag(spread)
    Q_new = (1 - d) * f.Q + d * bracket
    if sym.params.numeric.settings(sym.name)["noise_safeguard"] == "floor":
        Q_new = ca.fmax(Q_new, Q_FLOOR * ca.vertcat(*settings["process_noise"]))
    Q_new = ca.fmin(Q_new, ca.vertcat(*settings["process_noise_max"]))
    learnt = {**{f"qmean_{n}": q_new[i] for i, n in enumerate(X_NAMES)},
              **{f"qvar_{n}": Q_new[i] for i, n in enumerate(X_NAMES)},
              "fading": f.s["fading"] * forgetting}
    return {name: ca.if_else(learns, value, f.s[name]) for name, value in learnt.items()}


def _finish(sym: _Symbols, init_state, f: _Filter, x_new, P_new, repaired, extra: dict, watched, judged):
    """(next state, output, the input checks' segment): the update, the hold, or a restart (beyond
    the spec: the innovation monitor's first firing or an estimate outside the plausible envelope),
    and the status; ``watched`` and ``judged`` the monitor block's stages (``_monitors``)."""
    settings, u, guard, kept, states = sym.settings, sym.u, sym.guard, sym.kept, sym.states
    active = guard.active

    def keep(value, key):
        return ca.if_else(active, value, kept[key])

    extra = {**extra, **judged.updates}
    stuck = watched.updates
    upper = ca.vertsplit(kalman.pack_symmetric(P_new))
    updated = states.pack({**dict(zip(X_NAMES, ca.vertsplit(x_new))), **dict(zip(COVARIANCE, upper)),
                           **extra, **stuck, "hold_reason": ca.SX(0)})
    held = states.pack({**kept, **stuck, "hold_reason": ca.if_else(guard.low_speed, 2, 1)})
    restart = states.pack({**{n: init_state[i] for i, n in enumerate(states.names)},
                           **judged.updates,
                           **stuck, "hold_reason": ca.SX(0)})
    restarted = ca.logic_and(active, ca.logic_or(diverged(x_new, u["vx"], settings), judged.first_inconsistent))
    x_out = ca.if_else(restarted, restart[:N], x_new)
    code = (guard.status + ca.if_else(active, repaired * status.COVARIANCE_REPAIRED, 0)
            + ca.if_else(restarted, status.FILTER_RESTARTED, 0)
            + watched.code + judged.code)
    output = sym.outputs.pack({
        "beta": ca.if_else(active, ca.atan2(x_out[1], x_out[0]), 0),
        **{out: keep(x_out[X_NAMES.index(n)], n) for out, n in
           (("vx", "u"), ("vy", "v"), ("r", "gamma"), ("yaw_moment", "moment"), ("ax", "ax"),
            ("ay", "ay"))},
        "status": code,
    })
    next_state = ca.if_else(active, ca.if_else(restarted, restart, updated), held)
    return next_state, output, watched.checks


def _estimator(sym: _Symbols, init: ca.Function, repeated) -> Estimator:
    """The Estimator with its description and the UT weights it reports."""
    variant = "adaptive UKF (Sage-Husa process noise)" if sym.adaptive else "UKF"
    numeric = sym.params.numeric.settings(sym.name)
    ut = unscented.Weights(N, numeric["ut_alpha"], numeric["ut_beta"], numeric["ut_kappa"])
    return Estimator(sym.name, f"speeds, yaw rate and sideslip: {variant} on the 3-DOF HSRI model "
                               "(seed 002)", sym.inputs_layout, sym.states, sym.outputs, init, repeated,
                     sym.params,
                     {"longitudinal_force": numeric["longitudinal_force"],
                      "sigma_points": f"{2 * N + 1}, weights W_m0 = {ut.mean0:.7g}, "
                                      f"W_i = {ut.other:.7g}; the C propagates the {N} pairs "
                                      "in a loop"},
                     rounding_gain=rounding_gain(ut, sym.params.numeric, sym.name))


_UKF_TUNABLE = {"process_noise": Tunable(1e-8, 1e-2), "measurement_noise": Tunable(1e-5, 1e-1)}
_UKF_STATUS = (status.LOW_SPEED, status.INVALID_INPUT, status.COVARIANCE_REPAIRED, status.FILTER_RESTARTED,
               *CHECKS.status_bits)
_UKF_DERIVED = {**ROLL_GRADIENT, **CHECKS.derived}
DEFINITIONS = (
    Definition(name=PLAIN_NAME, build=build_plain, schema=UKF_SCHEMA, tunable=_UKF_TUNABLE,
               status_bits=_UKF_STATUS, derived=_UKF_DERIVED, monitors=CHECKS.block),
    Definition(name=NAME, build=build_adaptive, schema=AUKF_SCHEMA,
               tunable={**_UKF_TUNABLE, "forgetting_factor": Tunable(0.95, 0.99, log=False)},
               status_bits=_UKF_STATUS, derived=_UKF_DERIVED, monitors=CHECKS.block),
)
