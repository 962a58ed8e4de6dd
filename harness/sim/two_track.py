"""Two-track vehicle model: planar motion, four wheel spins, lagged load transfer, body roll (a
damped roll mode or quasi-static) and quasi-static pitch for the sensors on the body.

State (15): X, Y (m, world), psi (rad), vx, vy (m/s, body), r (rad/s, about the road's normal),
omega_fl, omega_fr, omega_rl, omega_rr (rad/s), ax_lt, ay_lt (m/s^2, the accelerations the load
transfer follows), phi (rad), phi_rate (rad/s): the body's roll on its suspension (ISO: positive
with the left side up, i.e. outward in a left turn), distance (m travelled, sqrt(vx^2 + vy^2)
integrated: where the road profile is read).
Input (9): delta (rad, both front wheels), T_fl, T_fr, T_rl, T_rr (N*m, drive minus brake torque at
each wheel), mu (road friction), bank phi_r and grade theta_r (rad) and vertical curvature kappa_v
(1/m) of the road (harness.sim.road: bank positive with the left edge up, grade positive uphill,
kappa_v positive in a sag).

The road plane carries the car. Gravity has the components -g sin(theta_r) along x and
-g sin(phi_r) cos(theta_r) along y of the road plane, and the road's normal carries the normal
specific force a_z = g cos(phi_r) cos(theta_r) + vx^2 kappa_v. The tyres and the air produce the
specific forces a_x = (sum Fx - drag) / m and a_y = sum Fy / m (what a body-fixed accelerometer
reads on a level body, TRUTH "ax", "ay"); the car's kinematic accelerations are those plus gravity's
components. Wheel loads, load transfer and body roll follow the specific forces.

Wheel i sits at (x_i, y_i) = (a, +t/2), (a, -t/2), (-b, +t/2), (-b, -t/2) (ISO axes). Its loads:

    Fz_i = Fz_static,i a_z / g -+ m ax_lt h / (2 l) -+ chi_axle m ay_lt h / t
           (front loses, rear gains under acceleration; the left side loses in a left turn)

with chi_front = roll_stiffness_front_share, chi_rear = 1 - chi_front. Wheel-plane velocities from
vx - r y_i, vy + r x_i rotated by the wheel's steer angle; slips kappa = (omega R - v_long)/|v|,
tan(alpha) = -v_lat/|v| with |v| regularised as sqrt(v_long^2 + 1 m^2/s^2). Tyre forces from
:mod:`harness.sim.tyre`, rotated back into the body frame. Then

    m (vx' - r vy) = sum Fx - 0.5 rho CdA vx |vx| - m g sin(theta_r)
    m (vy' + r vx) = sum Fy - m g sin(phi_r) cos(theta_r)
    Iz r' = sum (x_i Fy_i - y_i Fx_i)                     I_w omega_i' = T_i - R Fx_i - f_r Fz_i R tanh(omega_i/0.5)
    tau ax_lt' = ax - ax_lt,  tau ay_lt' = ay - ay_lt     (ax, ay: the specific forces above)

Body roll and pitch (the sensors sit on the body, harness.sim.sensor_model), with k_phi =
roll_gradient, k_theta = pitch_gradient:

* roll mode, roll_frequency f > 0 (omega_n = 2 pi f, damping ratio zeta): the body is a damped
  oscillator driven by the lateral acceleration, phi'' = omega_n^2 (k_phi ay - phi) - 2 zeta
  omega_n phi', so that steady cornering gives phi = k_phi ay;
* quasi-static roll, f = 0: phi = k_phi ay_lt, phi' = k_phi (ay - ay_lt) / tau, phi'' taken as 0
  (the roll states stay 0);
* pitch, always quasi-static: theta = -k_theta ax_lt (nose down under braking), theta' = -k_theta
  (ax - ax_lt) / tau.

Integrated with classic RK4 at a fixed step (>= 1 kHz: the wheel-spin modes are the fastest,
about 9500/vx 1/s, so RK4 at 1 ms is stable above ~3.5 m/s).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import casadi as ca
import numpy as np

from vsegen.harness.sim import tyre

GRAVITY = 9.81
AIR_DENSITY = 1.2
STATE = ("X", "Y", "psi", "vx", "vy", "r", "omega_fl", "omega_fr", "omega_rl", "omega_rr",
         "ax_lt", "ay_lt", "phi", "phi_rate", "distance")
INPUT = ("delta", "T_fl", "T_fr", "T_rl", "T_rr", "mu", "bank", "grade", "vertical_curvature")
TRUTH = ("ax", "ay", "fz_fl", "fz_fr", "fz_rl", "fz_rr", "fy_front", "fy_rear", "yaw_acceleration",
         "roll", "roll_rate", "roll_acceleration", "pitch", "pitch_rate", "az")
"""Algebraic outputs of :meth:`Plant.truth`: specific forces of the CG along the road plane's x
and y (m/s^2), wheel loads (N), axle lateral forces in the body frame (N), r' (rad/s^2), roll
angle, rate and acceleration (rad, rad/s, rad/s^2) and pitch angle and rate (rad, rad/s) of the
body on its suspension, and the normal specific force a_z (m/s^2), as the docstring defines them."""


@dataclass
class Plant:
    """The two-track plant of one vehicle; call :meth:`step` to integrate."""

    vehicle: Mapping[str, float]
    params: Mapping[str, float]
    step_fn: ca.Function
    truth_fn: ca.Function
    dt: float

    def step(self, state: np.ndarray, u: np.ndarray) -> np.ndarray:
        """State after one RK4 step of ``dt`` with ``u`` held."""
        return np.asarray(self.step_fn(state, u)).ravel()

    def truth(self, state: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The :data:`TRUTH` quantities at ``state`` with ``u``."""
        return np.asarray(self.truth_fn(state, u)).ravel()

    def static_loads(self) -> tuple[float, float]:
        """Static load of one front and one rear wheel (N)."""
        return static_wheel_loads(self.vehicle)

    def initial_state(self, speed: float, y: float = 0.0) -> np.ndarray:
        """Straight running at ``speed`` m/s, wheels rolling freely, at lateral position ``y``."""
        state = np.zeros(len(STATE))
        state[STATE.index("Y")] = y
        state[STATE.index("vx")] = speed
        for name in ("omega_fl", "omega_fr", "omega_rl", "omega_rr"):
            state[STATE.index(name)] = speed / self.vehicle["wheel_radius"]
        return state


def build_plant(vehicle: Mapping[str, float], params: Mapping[str, float], dt: float) -> Plant:
    """The plant of ``vehicle`` ([vehicle]) with truth-plant ``params`` ([plant]), RK4 step ``dt``."""
    x = ca.SX.sym("x", len(STATE))
    u = ca.SX.sym("u", len(INPUT))
    derivative, truth = equations(vehicle, params, x, u)
    f = ca.Function("f", [x, u], [derivative])
    k1 = f(x, u)
    k2 = f(x + dt / 2 * k1, u)
    k3 = f(x + dt / 2 * k2, u)
    k4 = f(x + dt * k3, u)
    step_fn = ca.Function("rk4", [x, u], [x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
    truth_fn = ca.Function("truth", [x, u], [truth])
    return Plant(vehicle, params, step_fn, truth_fn, dt)


def equations(vehicle, params, x, u):
    """(x', truth) of the plant as CasADi expressions of state ``x`` and input ``u``."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b, l = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"], vehicle["wheelbase"]
    t, h, radius = vehicle["track_width"], vehicle["cg_height"], vehicle["wheel_radius"]
    chi_f = params["roll_stiffness_front_share"]
    s = dict(zip(STATE, ca.vertsplit(x)))
    i = dict(zip(INPUT, ca.vertsplit(u)))
    vx, vy, r = s["vx"], s["vy"], s["r"]

    bank, grade = i["bank"], i["grade"]
    az = GRAVITY * ca.cos(bank) * ca.cos(grade) + vx * vx * i["vertical_curvature"]
    fz_f, fz_r = m * az * b / (2 * l), m * az * a / (2 * l)
    long_shift = m * s["ax_lt"] * h / (2 * l)
    lat_f = chi_f * m * s["ay_lt"] * h / t
    lat_r = (1 - chi_f) * m * s["ay_lt"] * h / t
    wheels = (  # name, x_i, y_i, steer, static load -+ transfers, inertia
        ("fl", a, t / 2, i["delta"], fz_f - long_shift - lat_f, params["wheel_inertia_front"]),
        ("fr", a, -t / 2, i["delta"], fz_f - long_shift + lat_f, params["wheel_inertia_front"]),
        ("rl", -b, t / 2, 0.0, fz_r + long_shift - lat_r, params["wheel_inertia_rear"]),
        ("rr", -b, -t / 2, 0.0, fz_r + long_shift + lat_r, params["wheel_inertia_rear"]),
    )
    sum_fx = sum_fy = yaw_moment = 0
    fy_axle = {"f": 0, "r": 0}
    wheel_rates, loads = [], []
    for name, xi, yi, steer, load, inertia in wheels:
        vwx, vwy = vx - r * yi, vy + r * xi
        v_long = vwx * ca.cos(steer) + vwy * ca.sin(steer)
        v_lat = -vwx * ca.sin(steer) + vwy * ca.cos(steer)
        speed = ca.sqrt(v_long * v_long + 1.0)
        omega = s[f"omega_{name}"]
        kappa = (omega * radius - v_long) / speed
        alpha = ca.atan(-v_lat / speed)
        fx, fy = tyre.forces(params, load, i["mu"], kappa, alpha)
        fbx = fx * ca.cos(steer) - fy * ca.sin(steer)
        fby = fx * ca.sin(steer) + fy * ca.cos(steer)
        sum_fx, sum_fy = sum_fx + fbx, sum_fy + fby
        yaw_moment = yaw_moment + xi * fby - yi * fbx
        fy_axle[name[0]] = fy_axle[name[0]] + fby
        rolling = params["rolling_resistance"] * ca.fmax(load, 0) * radius * ca.tanh(omega / 0.5)
        wheel_rates.append((i[f"T_{name}"] - radius * fx - rolling) / inertia)
        loads.append(load)
    drag = 0.5 * AIR_DENSITY * params["drag_area"] * vx * ca.fabs(vx)
    ax = (sum_fx - drag) / m
    ay = sum_fy / m
    tau = params["load_transfer_time_constant"]
    psi = s["psi"]
    yaw_acceleration = yaw_moment / iz
    roll, roll_rate, roll_acceleration = _roll(params, s, ay, tau)
    pitch = -params["pitch_gradient"] * s["ax_lt"]
    pitch_rate = -params["pitch_gradient"] * (ax - s["ax_lt"]) / tau
    derivative = ca.vertcat(
        vx * ca.cos(psi) - vy * ca.sin(psi),
        vx * ca.sin(psi) + vy * ca.cos(psi),
        r,
        ax - GRAVITY * ca.sin(grade) + r * vy,
        ay - GRAVITY * ca.sin(bank) * ca.cos(grade) - r * vx,
        yaw_acceleration,
        *wheel_rates,
        (ax - s["ax_lt"]) / tau,
        (ay - s["ay_lt"]) / tau,
        s["phi_rate"] if _roll_mode(params) else 0.0,
        roll_acceleration if _roll_mode(params) else 0.0,
        ca.sqrt(vx * vx + vy * vy),
    )
    truth = ca.vertcat(ax, ay, *loads, fy_axle["f"], fy_axle["r"], yaw_acceleration,
                       roll, roll_rate, roll_acceleration, pitch, pitch_rate, az)
    return derivative, truth


def _roll_mode(params) -> bool:
    """True when the body has a roll mode (roll_frequency > 0), False for quasi-static roll."""
    return params["roll_frequency"] > 0.0


def _roll(params, s, ay, tau):
    """(phi, phi', phi'') of the body: the roll mode's states, or quasi-static roll (see the
    module docstring)."""
    gradient = params["roll_gradient"]
    if not _roll_mode(params):
        return gradient * s["ay_lt"], gradient * (ay - s["ay_lt"]) / tau, 0.0
    omega = 2.0 * np.pi * params["roll_frequency"]
    acceleration = (omega * omega * (gradient * ay - s["phi"])
                    - 2.0 * params["roll_damping_ratio"] * omega * s["phi_rate"])
    return s["phi"], s["phi_rate"], acceleration


def static_wheel_loads(vehicle) -> tuple[float, float]:
    """Static load of one front and one rear wheel (N): m g b / (2 l) and m g a / (2 l)."""
    m, l = vehicle["mass"], vehicle["wheelbase"]
    return (m * GRAVITY * vehicle["cg_to_rear_axle"] / (2 * l),
            m * GRAVITY * vehicle["cg_to_front_axle"] / (2 * l))
