"""Seed 002's process model: planar 3-DOF vehicle with four-wheel kinematics, HSRI tyres and load
transfer, Euler at T (docs/methods.md, seed 002 §2.1-§2.7, all reconstructed).

State X = [u, v, gamma, Gamma, a_x, a_y] (m/s, m/s, rad/s, N*m, m/s^2, m/s^2), ISO axes; wheels
fl, fr, rl, rr; only the front wheels steer. The function is written with +, -, *, / and
``model.increments``' sqrt/fmax/fmin, so it evaluates a state (CasADi SX) and, unchanged, a pair
of sigma points (``increments.Pair``).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from vsegen.model import increments
from vsegen.model.bicycle import GRAVITY
from vsegen.model.increments import Value

AIR_DENSITY = 1.2
"""kg/m^3, for the drag F_w = rho C_dA u^2 / 2 (§3)."""
LOAD_GUARD = 1.0
"""N: lambda divides by the adhesion, a smooth max(mu F_z, this) (:func:`adhesion`), so a lifted
wheel (F_z <= 0) has a few N of grip (3.5 N at mu F_z = -1 kN)."""
ADHESION_ROUNDING = 100.0
"""N: the width over which :func:`adhesion` bends from mu F_z to LOAD_GUARD. A kink there (a
literal max(mu F_z, 1 N), or F_z clamped at 0) inside a pair of sigma points turns the pair's even
part from second order to first, and the UT's mean weight 1/(alpha^2 (n + kappa)) = 1.7e5 (alpha =
0.001) multiplies the absolute rounding of F_z (a difference of loads of ~3 kN: 2e-4 N in float)
into tens of N of tyre force: the float C of seed 002's aukf departed from its reference by 2.7e-2
on a_x where a wheel lifted. Bent over 100 N the guard's curvature is at most 1/(2 x 100 N), so the
rounding stays of second order (bent over 10 N, the curvature's own change still multiplied float
trajectory differences to 4e-4, measured); it exceeds mu F_z by W^2 / (4 mu F_z), 1.25 N at 2 kN."""
WHEELS = ("fl", "fr", "rl", "rr")


def adhesion(grip: Value) -> Value:
    """mu F_z (N) guarded from below by LOAD_GUARD, smoothly: (g + G + sqrt((g - G)^2 + W^2)) / 2
    with G = LOAD_GUARD, W = ADHESION_ROUNDING; above max(g, G) by at most W / 2 (at g = G) and by
    W^2 / (4 |g - G|) far from it."""
    excess = grip - LOAD_GUARD
    return (grip + LOAD_GUARD + increments.sqrt(excess * excess + ADHESION_ROUNDING ** 2)) / 2


@dataclass(frozen=True)
class ThreeDof:
    """Parameters of (1)-(8). Stiffnesses are per tyre: ``cornering_front``/``_rear`` C_y (N/rad),
    ``longitudinal`` C_x (N per unit slip); ``wheel_speeds``: longitudinal slip from the measured
    wheel speeds (C4.1), else free rolling with a_x a random walk (C4.2)."""

    mass: float
    yaw_inertia: float
    cg_to_front_axle: float
    cg_to_rear_axle: float
    track_width: float
    cg_height: float
    cornering_front: float
    cornering_rear: float
    longitudinal: float
    friction: float
    drag_area: float
    slip_speed_floor: float
    sample_time: float
    wheel_speeds: bool

    def loads(self, ax: Value, ay: Value) -> list[Value]:
        """(7): F_z of fl, fr, rl, rr (N) with steady load transfer; negative when a wheel would
        lift (the tyre's :func:`adhesion` then gives it no grip)."""
        m, a, b, h, t = (self.mass, self.cg_to_front_axle, self.cg_to_rear_axle, self.cg_height,
                         self.track_width)
        L = a + b
        pitch = ax * (m * h / (2 * L))
        front, rear = m * GRAVITY * b / (2 * L), m * GRAVITY * a / (2 * L)
        roll_front, roll_rear = ay * (m * h * b / (L * t)), ay * (m * h * a / (L * t))
        return [front - pitch - roll_front, front - pitch + roll_front,
                rear + pitch - roll_rear, rear + pitch + roll_rear]

    def tyre(self, slip_x: Value, slip_y: Value, load: Value, cornering: float):
        """(2): HSRI forces (F_x, F_y) in the wheel frame, N. f(lambda) = (l - 1/4) / l^2 with
        l = max(lambda, 1/2), which is 1 for lambda <= 1/2 (continuous with its derivative)."""
        cx_sx, cy_sy = slip_x * self.longitudinal, slip_y * cornering
        demand = increments.sqrt(cx_sx * cx_sx + cy_sy * cy_sy)
        lam = increments.fmax(demand / adhesion(load * self.friction), 0.5)
        factor = (lam - 0.25) / (lam * lam)
        return cx_sx * factor, -(cy_sy * factor)

    def step(self, x: list[Value], delta: ca.SX, cos_delta: ca.SX, sin_delta: ca.SX,
             rolling_speeds: list[ca.SX] | None) -> list[Value]:
        """(8): X_{k+1} from X_k at steer angle delta (rad, its cos and sin given so they are
        computed once); ``rolling_speeds`` r omega_j of fl, fr, rl, rr (m/s), or None for free
        rolling."""
        u, v, gamma, moment, ax, ay = x
        a, b, half_track = self.cg_to_front_axle, self.cg_to_rear_axle, self.track_width / 2
        T = self.sample_time
        centre = {"fl": (u - gamma * half_track, v + gamma * a),
                  "fr": (u + gamma * half_track, v + gamma * a),
                  "rl": (u - gamma * half_track, v - gamma * b),
                  "rr": (u + gamma * half_track, v - gamma * b)}
        loads = dict(zip(WHEELS, self.loads(ax, ay)))
        body_x, body_y = {}, {}
        for j, wheel in enumerate(WHEELS):
            u_c, v_c = centre[wheel]
            front = wheel.startswith("f")
            u_x = u_c * cos_delta + v_c * sin_delta if front else u_c
            v_y = v_c * cos_delta - u_c * sin_delta if front else v_c
            if rolling_speeds is None:                                   # C4.2: S_x = 0
                slip_x = 0.0
                slip_y = v_y / increments.fmax(u_x, self.slip_speed_floor)
            else:                                                        # (3), (4)
                rolling = ca.fmax(rolling_speeds[j], self.slip_speed_floor)
                slip_x = (rolling_speeds[j] - u_x) / rolling
                slip_y = v_y / rolling
            cornering = self.cornering_front if front else self.cornering_rear
            f_x, f_y = self.tyre(slip_x, slip_y, loads[wheel], cornering)
            if front:
                body_x[wheel] = f_x * cos_delta - f_y * sin_delta
                body_y[wheel] = f_x * sin_delta + f_y * cos_delta
            else:
                body_x[wheel], body_y[wheel] = f_x, f_y
        force_x = body_x["fl"] + body_x["fr"] + body_x["rl"] + body_x["rr"]
        force_y = body_y["fl"] + body_y["fr"] + body_y["rl"] + body_y["rr"]
        yaw_moment = ((body_y["fl"] + body_y["fr"]) * a - (body_y["rl"] + body_y["rr"]) * b
                      + (body_x["fr"] - body_x["fl"] + body_x["rr"] - body_x["rl"]) * half_track)
        if rolling_speeds is None:
            ax_next = ax                                                 # C4.2: random walk
        else:
            drag = u * u * (AIR_DENSITY * self.drag_area / 2)
            ax_next = (force_x - drag) / self.mass
        return [u + (ax + v * gamma) * T,
                v + (ay - u * gamma) * T,
                gamma + moment * (T / self.yaw_inertia),
                yaw_moment,
                ax_next,
                force_y / self.mass]
