"""Driver models: path following (curvature feed-forward + error feedback), speed hold (PI on
wheel torque)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from vsegen.harness.sim.road import FLAT, Road
from vsegen.harness.sim.two_track import AIR_DENSITY, GRAVITY, STATE, static_wheel_loads
from vsegen.harness.sim.tyre import cornering_stiffness

PREVIEW_TIME = 0.2
"""The path curvature is read this far ahead (s), covering steering lag and yaw response."""
STEER_LAG = 0.05
"""First-order lag of the driver's steering (s)."""
STEER_LIMIT = 0.5
"""Largest front road-wheel angle the driver commands (rad)."""
STATE_X, STATE_Y, STATE_PSI, STATE_VX, STATE_VY, STATE_DISTANCE = (
    STATE.index(name) for name in ("X", "Y", "psi", "vx", "vy", "distance"))
"""Indices of the plant state the drivers read (harness.sim.two_track.STATE)."""


def driver_view(config) -> Mapping[str, float]:
    """What the simulated driver (and a synthetic scenario) knows of the car: the [vehicle] table
    with the truth plant's axle cornering stiffnesses at static load (two tyres of the [plant]
    Magic Formula load law), so a log never changes when the estimator-side [vehicle]
    stiffnesses are identified or tuned. Without a [plant] table, the [vehicle] values."""
    vehicle = dict(config.vehicle)
    if config.plant is not None:
        front, rear = static_wheel_loads(vehicle)
        vehicle["cornering_stiffness_front"] = 2 * float(cornering_stiffness(config.plant, front))
        vehicle["cornering_stiffness_rear"] = 2 * float(cornering_stiffness(config.plant, rear))
    return vehicle


@dataclass
class PathFollower:
    """Lateral driver: steady-state curvature feed-forward l kappa (1 + K_s vx^2), read
    PREVIEW_TIME ahead, plus feedback on the lateral error e_y and course-angle error e_chi
    (chi = psi + beta: where the car goes). With e_y'' ~ vx^2 delta / l the gains
    k_y = w^2 l / vx^2 and k_chi = 2 zeta w l / vx place the error poles at w = ``bandwidth``
    (rad/s), zeta = ``damping`` ([plant] driver_bandwidth, driver_damping: a calmer driver for a
    softer car). A first-order STEER_LAG models the driver's arms."""

    vehicle: Mapping[str, float]
    path: Callable[[float], float]
    dt: float
    bandwidth: float
    damping: float
    delta: float = 0.0

    def __call__(self, t: float, state: np.ndarray) -> float:
        v = self.vehicle
        l = v["cg_to_front_axle"] + v["cg_to_rear_axle"]
        ks = v["mass"] / l**2 * (v["cg_to_rear_axle"] / v["cornering_stiffness_front"]
                                 - v["cg_to_front_axle"] / v["cornering_stiffness_rear"])
        X, Y, psi = state[STATE_X], state[STATE_Y], state[STATE_PSI]
        vx, vy = max(state[STATE_VX], 1.0), state[STATE_VY]
        ahead = X + vx * PREVIEW_TIME
        h = 0.5
        y0, y1, y2 = (float(self.path(x)) for x in (ahead - h, ahead, ahead + h))
        slope, second = (y2 - y0) / (2 * h), (y2 - 2 * y1 + y0) / (h * h)
        curvature = second / (1 + slope * slope) ** 1.5
        e_y = float(self.path(X)) - Y
        e_chi = np.arctan((float(self.path(X + h)) - float(self.path(X - h))) / (2 * h)) \
            - (psi + np.arctan2(vy, vx))
        k_y = self.bandwidth**2 * l / vx**2
        k_chi = 2 * self.damping * self.bandwidth * l / vx
        command = l * curvature * (1 + ks * vx * vx) + k_y * e_y + k_chi * e_chi
        command = float(np.clip(command, -STEER_LIMIT, STEER_LIMIT))
        self.delta += self.dt / STEER_LAG * (command - self.delta)
        return self.delta


@dataclass
class SpeedHold:
    """PI speed control: total wheel torque m R (kp e + ki int e) + drag feed-forward, to the
    driven axle when positive, to the brakes (front 70 %, rear 30 %) when negative."""

    vehicle: Mapping[str, float]
    plant: Mapping[str, float]
    target: Callable[[float], float]
    dt: float
    kp: float = 1.5
    ki: float = 0.5
    integral: float = field(default=0.0)
    road: Road = FLAT
    """The road under the car: the driver feels the grade and feeds forward m g sin(grade)."""

    def __call__(self, t: float, state: np.ndarray) -> np.ndarray:
        """Torques (N*m) at fl, fr, rl, rr."""
        vx = state[STATE_VX]
        error = self.target(t) - vx
        self.integral += error * self.dt
        m, radius = self.vehicle["mass"], self.vehicle["wheel_radius"]
        grade = self.road(state[STATE_DISTANCE])[1]
        drag = 0.5 * AIR_DENSITY * self.plant["drag_area"] * vx * abs(vx) + \
            self.plant["rolling_resistance"] * m * GRAVITY + m * GRAVITY * np.sin(grade)
        torque = (m * (self.kp * error + self.ki * self.integral) + drag) * radius
        if torque >= 0:
            front = self.plant["driven_axle"] == "front"
            half = torque / 2
            return np.array([half, half, 0.0, 0.0] if front else [0.0, 0.0, half, half])
        return torque * np.array([0.35, 0.35, 0.15, 0.15])
