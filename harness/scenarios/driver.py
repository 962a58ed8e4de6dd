"""Path-following driver: pure pursuit with understeer compensation and a steering lag."""

from __future__ import annotations

from typing import Callable, Mapping

import numpy as np

PREVIEW_TIME = 0.55
"""Look-ahead distance = max(PREVIEW_MIN, vx * PREVIEW_TIME) in m."""
PREVIEW_MIN = 6.0
STEER_LAG = 0.05
"""First-order lag of the driver's steering (s)."""
STEER_LIMIT = 0.5
"""Largest front road-wheel angle the driver commands (rad)."""


def pure_pursuit(vehicle: Mapping[str, float], vx: float, path: Callable[[float], float],
                 x_start: float, dt: float) -> Callable[[float, np.ndarray], float]:
    """A steering law ``steer(t, state)`` that follows ``path(x)`` (x from the course entry,
    the car starting ``x_start`` m before it)."""
    m = vehicle["mass"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cf, cr = vehicle["cornering_stiffness_front"], vehicle["cornering_stiffness_rear"]
    l = a + b
    ks = m / l**2 * (b / cf - a / cr)
    preview = max(PREVIEW_MIN, vx * PREVIEW_TIME)
    memory = {"delta": 0.0}

    def steer(t: float, state: np.ndarray) -> float:
        X, Y, psi = state[0], state[1], state[2]
        target_x = X + preview
        target_y = float(path(target_x - x_start))
        dx, dy = target_x - X, target_y - Y
        lateral = -np.sin(psi) * dx + np.cos(psi) * dy
        distance = np.hypot(dx, dy)
        command = np.arctan(2 * l * lateral / distance**2) * (1 + ks * vx**2)
        command = float(np.clip(command, -STEER_LIMIT, STEER_LIMIT))
        memory["delta"] += dt / STEER_LAG * (command - memory["delta"])
        return memory["delta"]

    return steer

