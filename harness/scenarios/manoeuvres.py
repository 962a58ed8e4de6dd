"""The manoeuvres: each returns a Log at ``rate_hz`` with the columns of design.md and truth."""

from __future__ import annotations

import numpy as np

from harness.logs import Log
from harness.scenarios import course, sensors, simple_plant
from harness.scenarios.driver import pure_pursuit
from model.params import VehicleConfig

PLANT_RATE = 1000.0
"""Minimum plant integration rate (Hz); the plant runs at an integer multiple of the log rate."""
LEAD_IN = 40.0
"""Straight road before the course entry (m)."""
RUN_OUT = 60.0
"""Straight road after the course (m)."""


def _plant_substeps(rate_hz: float) -> int:
    return max(1, int(np.ceil(PLANT_RATE / rate_hz - 1e-9)))


def dlc(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float, mu: float,
        outliers: bool) -> Log:
    """ISO 3888-1 DLC at ``speed_kmh`` on friction ``mu``; gyro outliers of seed 000 Fig. 6b if
    ``outliers``."""
    vx = speed_kmh / 3.6
    sub = _plant_substeps(rate_hz)
    dt = 1.0 / (rate_hz * sub)
    duration = (LEAD_IN + course.LENGTH + RUN_OUT) / vx
    steer = pure_pursuit(config.vehicle, vx, course.centre_line, LEAD_IN, dt)
    truth = simple_plant.simulate(config.vehicle, vx, mu, duration, dt, steer)
    pick = slice(None, None, sub)
    t = truth.t[pick]
    vy, r, ay, delta = truth.vy[pick], truth.r[pick], truth.ay[pick], truth.delta[pick]
    ax_true = -r * vy  # body-frame x acceleration at constant speed: vx' - r vy
    rng = np.random.default_rng(seed)
    ax_m, ay_m, r_m = sensors.add_noise(rng, ax_true, ay, r)
    if outliers:
        r_m = sensors.inject_gyro_outliers(t, r_m)
    return _log(config, t, delta, np.full_like(t, vx), ax_m, ay_m, r_m, vy, r, np.full_like(t, mu))


def low_speed(config: VehicleConfig, rate_hz: float, seed: int) -> Log:
    """Kinematic steady-state cornering while the speed falls 12 -> 0 -> -1 (reverse) -> 12 m/s."""
    vehicle = config.vehicle
    l = vehicle["cg_to_front_axle"] + vehicle["cg_to_rear_axle"]
    t = np.arange(0.0, 24.0 + 0.5 / rate_hz, 1.0 / rate_hz)
    vx = np.interp(t, [0, 2, 9, 10, 11, 12, 13, 20, 24], [12, 12, 0, 0, -1, -1, 0, 12, 12])
    delta = 0.04 * np.sin(2 * np.pi * 0.25 * t)
    m, a, b = vehicle["mass"], vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cr = vehicle["cornering_stiffness_rear"]
    ks = m / l**2 * (b / vehicle["cornering_stiffness_front"] - a / cr)
    gain = 1.0 / (1.0 + ks * vx**2)
    r = vx * delta / l * gain
    beta = (b / l - m * a * vx**2 / (l**2 * cr)) * delta * gain
    vy = vx * np.tan(beta)
    rng = np.random.default_rng(seed)
    ax_m, ay_m, r_m = sensors.add_noise(rng, np.gradient(vx, t), vx * r, r)
    return _log(config, t, delta, vx, ax_m, ay_m, r_m, vy, r, np.ones_like(t))


def invalid_inputs(config: VehicleConfig, rate_hz: float, seed: int) -> Log:
    """The 80 km/h DLC with bad samples: NaN, +-Inf and out-of-range values in every input, alone
    and in runs, so every hold/resume path is taken."""
    log = dlc(config, rate_hz, seed, 80.0, 1.0, False)
    n = len(log)
    faults = (
        ("ay", 0.30, 1, np.nan), ("r", 0.50, 1, np.inf), ("delta", 0.70, 1, -np.inf),
        ("vx", 0.90, 1, np.nan), ("ax", 1.10, 1, np.nan), ("delta", 2.00, 3, 2.5),
        ("r", 2.50, 5, 40.0), ("vx", 3.00, 1, 1e6), ("vx", 3.50, 2, -np.inf),
        ("ay", 4.00, 20, np.nan), ("vx", 5.00, 4, 0.5), ("ay", 5.50, 1, -1e300),
    )
    for column, time, count, value in faults:
        start = int(round(time * rate_hz))
        if start < n:
            log.columns[column][start:start + count] = value
    return log


def _log(config, t, delta, vx, ax, ay, r, vy_true, r_true, mu) -> Log:
    radius = config.vehicle["wheel_radius"]
    omega = vx / radius
    return Log({
        "t": t, "delta": delta, "vx": vx, "ax": ax, "ay": ay, "r": r,
        "omega_rl": omega, "omega_rr": omega,
        "beta_ref": np.arctan2(vy_true, vx),
        "vx_ref": vx.astype(float), "vy_ref": vy_true, "r_ref": r_true, "mu": mu,
    }, source="<simulated>")
