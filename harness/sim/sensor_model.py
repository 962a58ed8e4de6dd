"""Sensor model of simulated logs (configured by the vehicle file's [sensors] table).

* the inertial sensors sit on the body at [plant] sensor_position p from the CG (x forward, y left,
  z up), rolled by phi and pitched by theta (harness.sim.two_track: a roll mode or quasi-static
  roll, quasi-static pitch); the body's orientation is yaw psi, pitch theta, roll phi (z-y-x);
* accelerometers read the specific force in body axes (docs/conventions.md: a rolled body's lateral
  accelerometer reads the gravity component):
      f = Rx(phi)^T Ry(theta)^T [ax, ay, g] + w' x p + w x (w x p),
      ax_m = ax cos(theta) - g sin(theta),  ay_m = ay cos(phi) + (ax sin(theta) + g cos(theta)) sin(phi)
  (with p = 0), with the body rate w = [phi', theta', r] and w' = [phi'', 0, r'] in the lever-arm
  terms (small angles there);
* the yaw-rate gyro reads the body's z rate, r_m = r cos(theta) cos(phi) - theta' sin(phi);
* white Gaussian noise (seed 000 Table 2), biases only when asked (the paper assumes compensated
  biases; docs/methods.md);
* wheel speeds from the plant's wheel spin states (a driven wheel spins up under traction), vx as
  an ECU computes it: mean of the non-driven axle's wheel speeds x R_eff (the rear wheels of a
  front-wheel-drive car, the front wheels of a rear-wheel-drive car);
* optional single-sample yaw-rate outliers (seed 000 Fig. 6b).
All random draws come from one seeded generator: the same seed gives the same log.
"""

from __future__ import annotations

import numpy as np

from vsegen.harness.sim.simulate import Run
from vsegen.model.params import ParameterError, VehicleConfig

GYRO_OUTLIERS = ((2.0, 0.47), (7.0, 0.84))
"""Seed 000 Fig. 6b: (time s, value rad/s) of single-sample yaw-rate spikes."""
WHEELS = ("fl", "fr", "rl", "rr")


def measure(config: VehicleConfig, run: Run, seed: int, bias: bool, outliers: bool,
            mounting: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> dict:
    """The measured log columns (docs/signals.md) of ``run``, from an IMU mounted on the body
    with the misalignment ``mounting`` (roll, pitch, yaw in rad: :func:`misaligned`)."""
    if config.sensors is None:
        raise ParameterError(f"{config.source}: no [sensors] table: expected the sensor model to "
                             f"simulate (see vehicles/c_class.toml)")
    sensors, plant = config.sensors, config.plant
    rng = np.random.default_rng(seed)
    n = len(run.t)
    phi, theta, r_true = run.truth_of("roll"), run.truth_of("pitch"), run.state("r")
    ax, ay, az = specific_force(run.truth_of("ax"), run.truth_of("ay"), run.truth_of("az"), phi, theta)
    rates = np.stack([run.truth_of("roll_rate"), run.truth_of("pitch_rate"), r_true])
    lever = lever_arm_acceleration(
        np.asarray(plant["sensor_position"]), rates,
        np.stack([run.truth_of("roll_acceleration"), np.zeros(n), run.truth_of("yaw_acceleration")]))
    force = np.stack([ax, ay, az]) + lever
    body_rates = np.stack([rates[0], rates[1], body_yaw_rate(r_true, phi, theta, rates[1])])
    if any(mounting):
        force, body_rates = misaligned(force, mounting), misaligned(body_rates, mounting)
    ax, ay, r = force[0], force[1], body_rates[2]
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


def specific_force(ax, ay, az, roll, pitch):
    """(f_x, f_y, f_z) in body axes (m/s^2) of a body at ``roll``, ``pitch`` (rad, on its
    suspension) whose CG has the specific forces ``ax``, ``ay``, ``az`` along the road plane's
    axes (harness.sim.two_track; az = g on a level road): Rx^T Ry^T [ax, ay, az]."""
    u = ax * np.cos(pitch) - az * np.sin(pitch)
    w = ax * np.sin(pitch) + az * np.cos(pitch)
    return u, ay * np.cos(roll) + w * np.sin(roll), -ay * np.sin(roll) + w * np.cos(roll)


def misaligned(vectors: np.ndarray, mounting: tuple[float, float, float]) -> np.ndarray:
    """Body-axis ``vectors`` (3 x n) as a sensor rotated on the body by (roll, pitch, yaw)
    ``mounting`` (rad, z-y-x like the body's attitude) reads them: R_m^T v."""
    roll, pitch, yaw = mounting
    from scipy.spatial.transform import Rotation  # here: scipy.spatial is slow to import

    rotation = Rotation.from_euler("ZYX", [yaw, pitch, roll])
    return rotation.inv().apply(vectors.T).T


def body_yaw_rate(r, roll, pitch, pitch_rate):
    """The body's z rate (rad/s) read by a body-fixed yaw gyro: psi' cos(theta) cos(phi) - theta'
    sin(phi), with psi' = ``r``."""
    return r * np.cos(pitch) * np.cos(roll) - pitch_rate * np.sin(roll)


def lever_arm_acceleration(position, rate, acceleration):
    """w' x p + w x (w x p) (m/s^2, 3 x n): what a sensor at ``position`` (m, 3) from the CG
    reads on top of the CG's acceleration, with body rates ``rate`` and their derivatives
    ``acceleration`` (3 x n, rad/s and rad/s^2, body axes)."""
    p = np.broadcast_to(position[:, None], rate.shape)
    return (np.cross(acceleration, p, axis=0)
            + np.cross(rate, np.cross(rate, p, axis=0), axis=0))


def inject_gyro_outliers(t: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``r`` with each outlier replacing the sample nearest its time (if inside the log)."""
    r = r.copy()
    for time, value in GYRO_OUTLIERS:
        if t[0] <= time <= t[-1]:
            r[int(np.argmin(np.abs(t - time)))] = value
    return r
