"""kf2dof: sideslip from the linear 2-DOF bicycle model and a Kalman filter.

The dynamic scheme of shared/methods/000-switch-sideslip.md (sections 2.5, 2.8-2.10), alone:

* predict from k-1 to k with the inputs of k-1 (zero-order hold): Phi, Gamma of A(vx_k-1), B by the
  configured discretisation; Q_d = Q_c T;
* update with z_k = [ay_k, r_k] (raw accelerometer, gyro), C(vx_k), D delta_k, Joseph form;
* beta = atan2(vy, vx_k).

Hold rule (model.guard): while not active, vy := 0, P := P_0, r is held, the previous inputs keep
their last plausible values, and the output is beta = 0, vy = 0, r = held r. The model is always
evaluated at vx clamped to [vx_min, vx_max], so no division by a small speed can happen.
Initialisation: vy = 0, r = r_0, P = P_0, previous inputs = sample 0; holding unless sample 0 is
plausible and vx_0 >= vx_resume.
"""

from __future__ import annotations

import casadi as ca

from model import discretize, kalman
from model.bicycle import bicycle_matrices, state_matrix_norm_bound
from model.estimator import Estimator, make_functions
from model.guard import hold, input_guard
from model.layout import Layout, Signal
from model.params import VehicleConfig

NAME = "kf2dof"

INPUTS = Layout((
    Signal("delta", "rad", "front road-wheel steer angle, positive left"),
    Signal("vx", "m/s", "longitudinal speed (rear wheel speeds x R_eff)"),
    Signal("ay", "m/s^2", "lateral acceleration at the CG, body frame, positive left"),
    Signal("r", "rad/s", "gyro yaw rate, positive counter-clockwise"),
))

_COVARIANCE = kalman.packed_names("P", ("vy", "r"))
STATES = Layout((
    Signal("vy", "m/s", "lateral velocity estimate"),
    Signal("r", "rad/s", "yaw-rate estimate"),
    *(Signal(name, "SI", "covariance entry (upper triangle, row by row)") for name in _COVARIANCE),
    Signal("delta_prev", "rad", "last plausible steer angle (input of the next prediction)"),
    Signal("vx_prev", "m/s", "last plausible speed (input of the next prediction)"),
    Signal("holding", "-", "1 while holding (low speed or invalid input), else 0"),
))

OUTPUTS = Layout((
    Signal("beta", "rad", "sideslip angle at the CG, atan2(vy, vx)"),
    Signal("vy", "m/s", "lateral velocity"),
    Signal("r", "rad/s", "filtered yaw rate"),
    Signal("status", "-", "status bits (model.status)", integer=True),
))


def build(config: VehicleConfig) -> Estimator:
    """The kf2dof estimator for ``config`` (its [vehicle], [inputs] and [estimator.kf2dof])."""
    vehicle, limits, T = config.vehicle, config.limits, config.sample_time
    settings = config.settings(NAME)
    vx_min, vx_resume, vx_max = settings["vx_min"], settings["vx_resume"], limits["vx_max"]
    Qd = ca.SX(ca.DM(settings["process_noise"])) * T
    R = ca.SX(ca.DM(settings["measurement_noise"]))
    P0 = ca.SX(ca.DM(settings["initial_covariance"]))
    plan = discretize.plan_zoh(state_matrix_norm_bound(vehicle, vx_min, vx_max), T)

    state, s = STATES.symbols("state")
    inputs, u = INPUTS.symbols("input")

    guard = input_guard(u, limits, vx_min, vx_resume, s["holding"])

    def model_speed(vx):
        return ca.fmin(ca.fmax(vx, vx_min), vx_max)

    # dynamic update from the previous (plausible) inputs and this sample
    x = ca.vertcat(s["vy"], s["r"])
    P = kalman.unpack_symmetric(ca.vertcat(*[s[n] for n in _COVARIANCE]), 2)
    A, B, _, _ = bicycle_matrices(vehicle, model_speed(s["vx_prev"]))
    Phi, Gamma = discretize.discretise(settings["discretisation"], A, B, T, plan)
    x_pred, P_pred = kalman.predict(x, P, Phi, Gamma, s["delta_prev"], Qd)

    vx = model_speed(hold(u["vx"], guard.plausible["vx"], vx_min))
    delta = hold(u["delta"], guard.plausible["delta"], 0)
    z = ca.vertcat(hold(u["ay"], guard.plausible["ay"], 0), hold(u["r"], guard.plausible["r"], 0))
    _, _, C, D = bicycle_matrices(vehicle, vx)
    x_upd, P_upd, _ = kalman.update_joseph(x_pred, P_pred, z, C, D, delta, R)

    active = guard.active
    vy_next = ca.if_else(active, x_upd[0], 0)
    r_next = ca.if_else(active, x_upd[1], s["r"])
    P_next = kalman.pack_symmetric(ca.if_else(active, P_upd, P0))
    next_state = STATES.pack({
        "vy": vy_next,
        "r": r_next,
        **{name: P_next[i] for i, name in enumerate(_COVARIANCE)},
        "delta_prev": hold(u["delta"], guard.plausible["delta"], s["delta_prev"]),
        "vx_prev": hold(u["vx"], guard.plausible["vx"], s["vx_prev"]),
        "holding": ca.if_else(active, 0, 1),
    })
    output = OUTPUTS.pack({
        "beta": ca.if_else(active, ca.atan2(x_upd[0], vx), 0),
        "vy": vy_next,
        "r": r_next,
        "status": guard.status,
    })

    first = input_guard(u, limits, vx_resume, vx_resume, ca.SX(1))
    P0_packed = kalman.pack_symmetric(P0)
    init_state = STATES.pack({
        "vy": ca.SX(0),
        "r": hold(u["r"], first.plausible["r"], 0),
        **{name: P0_packed[i] for i, name in enumerate(_COVARIANCE)},
        "delta_prev": hold(u["delta"], first.plausible["delta"], 0),
        "vx_prev": hold(u["vx"], first.plausible["vx"], vx_min),
        "holding": ca.if_else(first.active, 0, 1),
    })
    init, step = make_functions(NAME, INPUTS, STATES, OUTPUTS, inputs, state, init_state,
                                next_state, output)
    notes = {"discretisation": settings["discretisation"]}
    if settings["discretisation"] == "zoh":
        notes["zoh_series"] = (f"{plan.terms} Taylor terms, {plan.squarings} squarings, "
                               f"|Phi - expm(A T)|_inf <= {plan.error_bound:.1e} for "
                               f"{vx_min} <= vx <= {vx_max} m/s")
    return Estimator(NAME, "sideslip from the linear 2-DOF bicycle model + Kalman filter",
                     INPUTS, STATES, OUTPUTS, init, step, notes)
