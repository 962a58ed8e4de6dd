"""Magic-Formula tyre with combined slip (similarity method), symbolic (CasADi) or numeric.

Pure slip (Pacejka, "Tyre and Vehicle Dynamics", 3rd ed., §4.3), with the peak D = mu Fz:

    F_x0(s) = D sin(C_x atan(B_x s)),   B_x = K_x / (C_x D),   K_x = k_x Fz
    F_y0(s) = D sin(C_y atan(B_y s)),   B_y = K_y / (C_y D),
    K_y = p_Ky1 F_z0 sin(2 atan(Fz / (p_Ky2 F_z0)))         (MF 5.2 load law of the cornering stiffness)

Combined slip by the similarity method (ibid. §4.3.2): theoretical slips s_x = kappa/(1+kappa),
s_y = tan(alpha)/(1+kappa), s = |(s_x, s_y)|, and F_x = F_x0(s) s_x/s, F_y = F_y0(s) s_y/s. So
dF_y/dalpha = K_y at zero slip, and |F| <= mu Fz always (friction ellipse). Signs: alpha > 0 gives
F_y > 0 (project convention), kappa > 0 (driving) gives F_x > 0.
"""

from __future__ import annotations

from collections.abc import Mapping

import casadi as ca

MIN_LOAD = 50.0
"""Loads below this (N, e.g. a lifting wheel) are evaluated at it, keeping B finite."""
SLIP_EPS = 1e-9
"""Regularises s near zero slip."""


def cornering_stiffness(plant: Mapping[str, float], load):
    """K_y (N/rad) of one tyre at vertical load ``load`` (N)."""
    fz0 = plant["tyre_nominal_load"]
    return plant["tyre_cornering_factor"] * fz0 * ca.sin(
        2 * ca.atan(load / (plant["tyre_cornering_load_factor"] * fz0)))


def forces(plant: Mapping[str, float], load, mu, kappa, alpha):
    """(F_x, F_y) in N in the wheel frame for vertical load, friction, slip ratio and slip angle."""
    fz = ca.fmax(load, MIN_LOAD)
    peak = mu * fz
    cx, cy = plant["tyre_shape_longitudinal"], plant["tyre_shape_lateral"]
    bx = plant["tyre_slip_stiffness_factor"] * fz / (cx * peak)
    by = cornering_stiffness(plant, fz) / (cy * peak)
    kappa = ca.fmax(kappa, -0.95)
    sx = kappa / (1 + kappa)
    sy = ca.tan(alpha) / (1 + kappa)
    s = ca.sqrt(sx * sx + sy * sy + SLIP_EPS**2)
    fx0 = peak * ca.sin(cx * ca.atan(bx * s))
    fy0 = peak * ca.sin(cy * ca.atan(by * s))
    return fx0 * sx / s, fy0 * sy / s
