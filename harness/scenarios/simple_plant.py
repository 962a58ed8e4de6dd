"""A simple nonlinear single-track truth plant (a stand-in until the two-track plant lands).

States [X, Y, psi, vy, r] (m, m, rad, m/s, rad/s) at constant speed vx. Axle lateral forces from a
saturating Magic-Formula-shaped curve F = mu Fz sin(c atan(k alpha)), c = 1.3, with k chosen so that
the slope at zero slip equals the vehicle file's axle cornering stiffness (design.md,
shared/methods/README.md: stiffness = zero-slip slope of the plant's tyres). Slip angles
alpha_f = delta - atan((vy + a r)/vx), alpha_r = -atan((vy - b r)/vx). Integrated by RK4.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

SHAPE = 1.3
GRAVITY = 9.81


@dataclass
class Trajectory:
    """Truth at every integration step: time, positions, states, steer and lateral acceleration."""

    t: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    psi: np.ndarray
    vy: np.ndarray
    r: np.ndarray
    delta: np.ndarray
    ay: np.ndarray
    vx: float


def _axle_force(stiffness: float, load: float, mu: float, alpha):
    peak = mu * load
    k = stiffness / (SHAPE * peak)
    return peak * np.sin(SHAPE * np.arctan(k * alpha))


def simulate(vehicle: Mapping[str, float], vx: float, mu: float, duration: float, dt: float,
             steer: Callable[[float, np.ndarray], float], y0: float = 0.0) -> Trajectory:
    """Integrate the plant with RK4 at ``dt``; ``steer(t, state)`` is the driver (held per step)."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cf, cr = vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"]
    l = a + b
    fz_f, fz_r = m * GRAVITY * b / l, m * GRAVITY * a / l

    def forces(state, delta):
        vy, r = state[3], state[4]
        fyf = _axle_force(cf, fz_f, mu, delta - np.arctan((vy + a * r) / vx))
        fyr = _axle_force(cr, fz_r, mu, -np.arctan((vy - b * r) / vx))
        return fyf * np.cos(delta), fyr, fyf * np.cos(delta)

    def derivative(state, delta):
        psi, vy, r = state[2], state[3], state[4]
        fy_front, fy_rear, _ = forces(state, delta)
        return np.array([
            vx * np.cos(psi) - vy * np.sin(psi),
            vx * np.sin(psi) + vy * np.cos(psi),
            r,
            (fy_front + fy_rear) / m - r * vx,
            (a * fy_front - b * fy_rear) / iz,
        ])

    steps = int(round(duration / dt)) + 1
    out = np.zeros((steps, 5))
    deltas = np.zeros(steps)
    ays = np.zeros(steps)
    state = np.array([0.0, y0, 0.0, 0.0, 0.0])
    for k in range(steps):
        delta = steer(k * dt, state)
        fy_front, fy_rear, _ = forces(state, delta)
        out[k], deltas[k], ays[k] = state, delta, (fy_front + fy_rear) / m
        k1 = derivative(state, delta)
        k2 = derivative(state + dt / 2 * k1, delta)
        k3 = derivative(state + dt / 2 * k2, delta)
        k4 = derivative(state + dt * k3, delta)
        state = state + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    t = np.arange(steps) * dt
    return Trajectory(t, out[:, 0], out[:, 1], out[:, 2], out[:, 3], out[:, 4], deltas, ays, vx)
