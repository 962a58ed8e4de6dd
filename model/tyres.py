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

The friction is bounded from below at every sample: the road carries at least what the car is
measured to do, so each axle's mu is at least ``friction_floor`` |a_y| / g (:func:`friction`). A
file's mu set or identified too low would otherwise leave the model unable to produce the measured
a_y, and the filter would read it as an ever larger slip angle.

With ``friction_noise`` > 0 the filter also estimates the friction from above: a third state, the
friction scale rho (1 = the file's ``tyre_friction``), scales both axles' mu (mu_i = max(rho
mu_file,i, floor |a_y| / g)). The model's sensitivity to it, dF/dpeak = tanh(u) - u / cosh(u)^2,
vanishes in the linear range and approaches 1 at the peak, so the measurements move rho only where
the tyres saturate (Grip et al., IEEE Control Systems Magazine 2009, estimate the friction the same
way: from the lateral force the car does not get).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import casadi as ca

from vsegen.model.bicycle import GRAVITY

FRICTION_SCALE_RANGE = (0.1, 2.0)
"""The estimated friction scale rho stays within these bounds (a road below a tenth of the file's
friction, or above twice it, is no road the model describes)."""


@dataclass(frozen=True)
class Friction:
    """Each axle's friction ``mu`` = [mu_f, mu_r] and its derivative ``slope`` = [dmu_f/drho,
    dmu_r/drho] in the friction scale rho (the file's mu where rho sets it, 0 where the floor does)."""

    mu: list
    slope: list


@dataclass(frozen=True)
class Linearised:
    """The saturating model at one state: ``f`` = dx/dt (2x1), ``A`` its Jacobian in x = [vy, r]
    (2x2), ``ay`` the lateral acceleration it predicts (m/s^2), ``H`` the Jacobian of [a_y, r] in x,
    and their derivatives in the friction scale: ``f_friction`` (2x1) and ``ay_friction``."""

    f: ca.SX
    A: ca.SX
    ay: ca.SX
    H: ca.SX
    f_friction: ca.SX
    ay_friction: ca.SX


def saturating_bicycle(vehicle: Mapping[str, float], friction: Friction, x: ca.SX, delta, vx) -> Linearised:
    """The bicycle model with tanh-saturating axles at state ``x`` = [vy, r], road-wheel angle
    ``delta`` (rad) and forward speed ``vx`` (m/s, > 0), with the axles' ``friction``."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    weight_per_wheelbase = m * GRAVITY / (a + b)
    load_f, load_r = weight_per_wheelbase * b, weight_per_wheelbase * a
    inv_vx = 1.0 / vx
    vy, r = x[0], x[1]
    front = _axle(vehicle["cornering_stiffness_front"], friction.mu[0] * load_f, delta - (vy + a * r) * inv_vx)
    rear = _axle(vehicle["cornering_stiffness_rear"], friction.mu[1] * load_r, (b * r - vy) * inv_vx)
    d_front = ca.horzcat(-inv_vx, -a * inv_vx) * front.slope        # dF_f/dx
    d_rear = ca.horzcat(-inv_vx, b * inv_vx) * rear.slope           # dF_r/dx
    ay = (front.force + rear.force) / m
    d_ay = (d_front + d_rear) / m
    f = ca.vertcat(ay - vx * r, (a * front.force - b * rear.force) / iz)
    A = ca.vertcat(d_ay + ca.horzcat(0, -vx), (a * d_front - b * d_rear) / iz)
    rho_front = front.peak_slope * load_f * friction.slope[0]     # dF_f/drho
    rho_rear = rear.peak_slope * load_r * friction.slope[1]       # dF_r/drho
    ay_friction = (rho_front + rho_rear) / m
    return Linearised(f, A, ay, ca.vertcat(d_ay, ca.horzcat(0, 1)),
                      ca.vertcat(ay_friction, (a * rho_front - b * rho_rear) / iz), ay_friction)


def friction(tyre_friction: Sequence, floor, ay, scale=None) -> Friction:
    """Each axle's friction: ``scale`` (the estimated friction scale rho; None without an estimate)
    times the file's ``tyre_friction``, raised to ``floor`` |ay| / g where the measured lateral
    acceleration ``ay`` (m/s^2) shows the road carries more (``floor`` 0: the scaled file's alone)."""
    shown = floor * ca.fabs(ay) / GRAVITY
    scaled = list(tyre_friction) if scale is None else [scale * mu for mu in tyre_friction]
    return Friction([ca.fmax(mu, shown) for mu in scaled],
                    [ca.if_else(mu >= shown, file_mu, 0) for mu, file_mu in zip(scaled, tyre_friction)])


@dataclass(frozen=True)
class _Axle:
    force: ca.SX
    slope: ca.SX
    """dF/dalpha"""
    peak_slope: ca.SX
    """dF/dpeak"""


def _axle(stiffness, peak, slip) -> _Axle:
    """F = peak tanh(u), u = stiffness slip / peak, and its slopes in the slip angle and in the
    peak. The slip slope is written stiffness / cosh(u)^2, not stiffness (1 - tanh(u)^2): beyond the
    peak tanh(u) rounds to within an ulp of 1 and 1 - tanh^2 would keep only its rounding."""
    u = stiffness / peak * slip
    sech = 1 / ca.cosh(u)
    tanh = ca.tanh(u)
    return _Axle(peak * tanh, stiffness * (sech * sech), tanh - u * (sech * sech))
