"""Linear 2-DOF bicycle (single-track) model in the project convention.

State x = [vy, r] (m/s, rad/s), input u = delta (front road-wheel angle, rad), measurement
y = [ay, r] (m/s^2, rad/s); vx (m/s) is a time-varying parameter. ISO 8855 axes, cornering stiffness
positive (F_y = C*alpha, alpha_f = delta - (vy + a*r)/vx, alpha_r = -(vy - b*r)/vx).
See docs/methods.md, "Signs and the bicycle model".
"""

from __future__ import annotations

from collections.abc import Mapping

import casadi as ca

GRAVITY = 9.81
"""Gravitational acceleration (m/s^2) used by every estimator."""


def bicycle_matrices(vehicle: Mapping[str, float], vx) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
    """A(vx), B, C(vx), D of the linear bicycle model; ``vx`` may be symbolic (SX) or a number."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cf, cr = vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"]
    inv_vx = 1.0 / vx
    a11 = -(cf + cr) / m * inv_vx
    a12 = (b * cr - a * cf) / m * inv_vx
    a21 = (b * cr - a * cf) / iz * inv_vx
    a22 = -(a * a * cf + b * b * cr) / iz * inv_vx
    A = ca.blockcat([[a11, a12 - vx], [a21, a22]])
    B = ca.vertcat(cf / m, a * cf / iz)
    C = ca.blockcat([[a11, a12], [0, 1]])
    D = ca.vertcat(cf / m, 0)
    return A, B, C, D


def sideslip(vy, vx):
    """beta = atan(vy / vx) (rad) from the lateral and a forward speed vx > 0 (m/s): atan2(vy, vx)
    there, at a third of the cost (glibc on x86-64: atan 49 instructions, atan2 127, measured).
    Callers pass a speed clamped to at least vx_min > 0."""
    return ca.atan(vy / vx)


def stability_factor(vehicle: Mapping[str, float]) -> float:
    """K_s = (m/l^2)(b/C_f - a/C_r) in s^2/m^2 (> 0: understeer)."""
    l = vehicle["cg_to_front_axle"] + vehicle["cg_to_rear_axle"]
    return vehicle["mass"] / l**2 * (
        vehicle["cg_to_rear_axle"] / vehicle["cornering_stiffness_front"]
        - vehicle["cg_to_front_axle"] / vehicle["cornering_stiffness_rear"]
    )


def state_matrix_norm_bound(vehicle: Mapping[str, float], vx_min: float, vx_max: float) -> float:
    """An upper bound of the infinity norm of A(vx) over vx_min <= vx <= vx_max (1/s).

    Each entry is c/vx (or c/vx - vx), so |entry| <= |c|/vx_min (+ vx_max): the triangle inequality.
    """
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cf, cr = vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"]
    row1 = ((cf + cr) / m + abs(b * cr - a * cf) / m) / vx_min + vx_max
    row2 = (abs(b * cr - a * cf) / iz + (a * a * cf + b * b * cr) / iz) / vx_min
    return max(row1, row2)
