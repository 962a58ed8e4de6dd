"""The bicycle model with saturating axle forces: the Kalman filter's ``tyre_model = "saturating"``.

Each axle's lateral force follows its slip angle linearly for small angles and saturates at the
friction the tyres can carry (ISO 8855 axes, the sign convention of model.bicycle):

    F = F_peak tanh(C alpha / F_peak),   F_peak = mu F_z,   dF/dalpha = C (1 - tanh^2),

with C the axle's cornering stiffness (N/rad), F_z its static load (m g b / l front, m g a / l rear,
N) and mu the axle's friction (peak lateral force over static load, ``tyre_friction``). Far below
the peak it is the linear model (F = C alpha); at the peak a larger slip angle no longer buys force,
which is what the linear model gets wrong at the limit (it reads the measured a_y as a small slip
angle). The state x = [vy, r] (m/s, rad/s) and the measurement [a_y, r] are the linear model's:

    vy' = (F_f + F_r)/m - vx r,   r' = (a F_f - b F_r)/I_z,   a_y = (F_f + F_r)/m.

The road-wheel angle enters as alpha_f = delta - (vy + a r)/vx (small angles, as the linear model).

The friction is estimated from below at every sample: the road carries at least what the car is
measured to do, so each axle's mu is at least ``friction_floor`` |a_y| / g (:func:`friction`). A
file's mu set or identified too low would otherwise leave the model unable to produce the measured
a_y, and the filter would read it as an ever larger slip angle.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import casadi as ca

from vsegen.model.bicycle import GRAVITY


@dataclass(frozen=True)
class Linearised:
    """The saturating model at one state: ``f`` = dx/dt (2x1), ``A`` its Jacobian in x (2x2),
    ``ay`` the lateral acceleration it predicts (m/s^2) and ``H`` the Jacobian of [a_y, r] in x."""

    f: ca.SX
    A: ca.SX
    ay: ca.SX
    H: ca.SX


def saturating_bicycle(vehicle: Mapping[str, float], friction: Sequence, x: ca.SX, delta, vx) -> Linearised:
    """The bicycle model with tanh-saturating axles at state ``x`` = [vy, r], road-wheel angle
    ``delta`` (rad) and forward speed ``vx`` (m/s, > 0); ``friction`` = [mu_f, mu_r]."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    weight_per_wheelbase = m * GRAVITY / (a + b)
    inv_vx = 1.0 / vx
    vy, r = x[0], x[1]
    force_f, slope_f = _axle(vehicle["cornering_stiffness_front"], friction[0] * weight_per_wheelbase * b,
                             delta - (vy + a * r) * inv_vx)
    force_r, slope_r = _axle(vehicle["cornering_stiffness_rear"], friction[1] * weight_per_wheelbase * a,
                             (b * r - vy) * inv_vx)
    d_front = ca.horzcat(-inv_vx, -a * inv_vx) * slope_f        # dF_f/dx
    d_rear = ca.horzcat(-inv_vx, b * inv_vx) * slope_r          # dF_r/dx
    ay = (force_f + force_r) / m
    d_ay = (d_front + d_rear) / m
    f = ca.vertcat(ay - vx * r, (a * force_f - b * force_r) / iz)
    A = ca.vertcat(d_ay + ca.horzcat(0, -vx), (a * d_front - b * d_rear) / iz)
    return Linearised(f, A, ay, ca.vertcat(d_ay, ca.horzcat(0, 1)))


def friction(tyre_friction: Sequence, floor, ay) -> list:
    """[mu_f, mu_r]: the file's ``tyre_friction``, raised to ``floor`` |ay| / g where the measured
    lateral acceleration ``ay`` (m/s^2) shows the road carries more (``floor`` 0: the file's alone)."""
    shown = floor * ca.fabs(ay) / GRAVITY
    return [ca.fmax(mu, shown) for mu in tyre_friction]


def _axle(stiffness, peak, slip):
    """(F, dF/dalpha) of F = peak tanh(u), u = stiffness slip / peak. The slope is written
    stiffness / cosh(u)^2, not stiffness (1 - tanh(u)^2): beyond the peak tanh(u) rounds to within an
    ulp of 1 and 1 - tanh^2 would keep only its rounding."""
    u = stiffness / peak * slip
    sech = 1 / ca.cosh(u)
    return peak * ca.tanh(u), stiffness * (sech * sech)
