"""Sensor model of simulated logs (configured by the vehicle file's [sensors] table).

* body-fixed accelerometers: ax_m = ax cos(theta) - g sin(theta), ay_m = ay cos(phi) + g sin(phi),
  with quasi-static roll phi = roll_gradient * ay_lt and pitch theta = -pitch_gradient * ax_lt
  (design.md: a rolled body's lateral accelerometer reads the gravity component);
* white Gaussian noise (seed 000 Table 2), biases only when asked (the paper assumes compensated
  biases; shared/methods/README.md);
* wheel speeds from the plant's wheel spin states (a driven wheel spins up under traction), vx as
  an ECU computes it: mean of the non-driven axle's wheel speeds x R_eff (the rear wheels of a
  front-wheel-drive car, the front wheels of a rear-wheel-drive car);
* optional single-sample yaw-rate outliers (seed 000 Fig. 6b).
All random draws come from one seeded generator: the same seed gives the same log.
"""

from __future__ import annotations

import numpy as np

from harness.plant.two_track import GRAVITY
from harness.scenarios.simulate import Run
from model.params import ParameterError, VehicleConfig

GYRO_OUTLIERS = ((2.0, 0.47), (7.0, 0.84))
"""Seed 000 Fig. 6b: (time s, value rad/s) of single-sample yaw-rate spikes."""
WHEELS = ("fl", "fr", "rl", "rr")


def measure(config: VehicleConfig, run: Run, seed: int, bias: bool, outliers: bool) -> dict:
    """The measured log columns (design.md) of ``run``."""
    if config.sensors is None:
        raise ParameterError(f"{config.source}: no [sensors] table: expected the sensor model to "
                             f"simulate (see vehicles/c_class.toml)")
    sensors, plant = config.sensors, config.plant
    rng = np.random.default_rng(seed)
    n = len(run.t)
    phi = plant["roll_gradient"] * run.state("ay_lt")
    theta = -plant["pitch_gradient"] * run.state("ax_lt")
    ax = run.truth_of("ax") * np.cos(theta) - GRAVITY * np.sin(theta)
    ay = run.truth_of("ay") * np.cos(phi) + GRAVITY * np.sin(phi)
    r = run.state("r").copy()
    ax += rng.normal(0.0, sensors["accel_noise"], n) + (sensors["accel_bias"] if bias else 0.0)
    ay += rng.normal(0.0, sensors["accel_noise"], n) + (sensors["accel_bias"] if bias else 0.0)
    r += rng.normal(0.0, sensors["gyro_noise"], n) + (sensors["gyro_bias"] if bias else 0.0)
    if outliers:
        r = inject_gyro_outliers(run.t, r)
    omegas = {f"omega_{w}": run.state(f"omega_{w}") + rng.normal(0.0, sensors["wheel_speed_noise"], n)
              for w in WHEELS}
    axle = "f" if plant["driven_axle"] == "rear" else "r"
    vx = 0.5 * (omegas[f"omega_{axle}l"] + omegas[f"omega_{axle}r"]) * config.vehicle["wheel_radius"]
    return {"delta": run.input("delta"), "vx": vx, "ax": ax, "ay": ay, "r": r, **omegas}


def inject_gyro_outliers(t: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``r`` with each outlier replacing the sample nearest its time (if inside the log)."""
    r = r.copy()
    for time, value in GYRO_OUTLIERS:
        if t[0] <= time <= t[-1]:
            r[int(np.argmin(np.abs(t - time)))] = value
    return r
