"""The manoeuvres. Each returns a Log at ``rate_hz`` with the columns of docs/signals.md, the truth
columns, and notes saying whether the car stayed inside the cones and did not spin. ``progress``,
if given, is called with the fraction simulated.

Scenario parameters not given by the seeds are marked *assumption* in the docstrings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsegen.harness.jobs.memo import Memo
from vsegen.harness.logs.table import SPIN_SIDESLIP, Log
from vsegen.harness.sim import course as courses
from vsegen.harness.sim import sensor_model as sensors
from vsegen.harness.sim.disturbances import NONE, Disturbances
from vsegen.harness.sim.driver import PathFollower, SpeedHold, driver_view
from vsegen.harness.sim.road import FLAT, Road, slope_angle
from vsegen.harness.sim.simulate import FrictionProfile, Run, simulate, substeps
from vsegen.harness.sim.two_track import GRAVITY
from vsegen.model import signals
from vsegen.model.params import VehicleConfig

LEAD_IN = 40.0
"""Straight road before a course (m)."""
RUN_OUT = 60.0
"""Straight road after a course (m), at least."""
MIN_DLC_DURATION = 10.0
"""A DLC log lasts at least this long (s): seed 000's Fig. 6 run has an outlier at 7 s."""


def dlc(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float, mu: float,
        outliers: bool, bias: bool, yaw_moment: float = 0.0, progress=None, **disturbances) -> Log:
    """ISO 3888-1 double lane change at constant ``speed_kmh`` on friction ``mu``, path-following
    driver. ``outliers``: seed 000 Fig. 6b gyro spikes; ``bias``: Table 2 sensor biases on;
    ``yaw_moment`` (N*m): rear torque-vectoring pulses (:class:`YawMomentPulses`), logged as
    ``mz``."""
    speed = speed_kmh / 3.6
    course = courses.iso_dlc(LEAD_IN, _width(config))
    duration = max((course.length + RUN_OUT) / speed, MIN_DLC_DURATION)
    return _drive(config, rate_hz, seed, course, speed, duration, _constant(mu), outliers, bias,
                  progress, YawMomentPulses(yaw_moment), Disturbances.of(**disturbances))


def continuous_dlc(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float,
                   mu_sequence: str, switch_times: str, switch_by: str, duration: float,
                   outliers: bool, bias: bool, yaw_moment: float = 0.0, progress=None, **disturbances) -> Log:
    """Seed 000 scenario B: three double lane changes back to back at constant speed, the road
    friction stepping through ``mu_sequence`` (comma-separated) at ``switch_times`` (s, or m of
    travelled distance when ``switch_by`` is "distance"); one DLC per friction segment.

    The seed gives no geometry: each DLC has the ISO offset (3.5 m) and lane widths, and a
    transition length chosen so that its centre line asks for 70 % of the friction then
    available, L = pi v sqrt(offset / (2 * 0.7 mu g)), as a skilled driver would (*assumption*).
    ``yaw_moment`` as in :func:`dlc`.
    """
    speed = speed_kmh / 3.6
    profile = FrictionProfile(_numbers("mu_sequence", mu_sequence),
                              _numbers("switch_times", switch_times), switch_by)
    scale = speed if switch_by == "time" else 1.0
    segment_starts = [0.0] + [s * scale for s in profile.switches]
    transitions = [np.pi * speed * np.sqrt(courses.ISO_OFFSET / (2 * 0.7 * m * GRAVITY))
                   for m in profile.values]
    course = courses.lane_changes([x + LEAD_IN for x in segment_starts], transitions, 25.0,
                                  _width(config))
    return _drive(config, rate_hz, seed, course, speed, duration, profile, outliers, bias, progress,
                  YawMomentPulses(yaw_moment), Disturbances.of(**disturbances))


def step_steer(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float, mu: float,
               delta: float, t_step: float, duration: float, bias: bool, progress=None, **disturbances) -> Log:
    """Seed 001's step steer: front road-wheel angle to ``delta`` rad at ``t_step`` s (ramped over
    0.1 s, *assumption*: a true step is not physical), speed held."""
    def steer(t: float, state: np.ndarray) -> float:
        return delta * float(np.clip((t - t_step) / 0.1, 0.0, 1.0))

    return _open_loop(config, rate_hz, seed, speed_kmh / 3.6, mu, steer, duration, bias, progress,
                      disturbances=Disturbances.of(**disturbances))


def sine_steer(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float, mu: float,
               amplitude: float, frequency: float, duration: float, bias: bool,
               yaw_moment: float = 0.0, progress=None, **disturbances) -> Log:
    """Seed 003's sine steer: delta = amplitude sin(2 pi f (t - 1)) after 1 s straight, speed held
    (amplitude 0.02 rad and 0.5 Hz are *assumptions*: the seed gives none); ``yaw_moment`` as in
    :func:`dlc`."""
    def steer(t: float, state: np.ndarray) -> float:
        return amplitude * np.sin(2 * np.pi * frequency * (t - 1.0)) if t > 1.0 else 0.0

    return _open_loop(config, rate_hz, seed, speed_kmh / 3.6, mu, steer, duration, bias, progress,
                      YawMomentPulses(yaw_moment), Disturbances.of(**disturbances))


def fishhook(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float, mu: float,
             amplitude: float, duration: float, bias: bool, progress=None, **disturbances) -> Log:
    """Seed 002's fishhook (NHTSA profile, reconstructed): after 1 s straight, steer to
    +amplitude in 0.25 s, hold 0.25 s, to -amplitude in 0.5 s, hold 3 s, back to 0 in 0.5 s."""
    times = np.array([0.0, 1.0, 1.25, 1.5, 2.0, 5.0, 5.5])
    values = np.array([0.0, 0.0, 1.0, 1.0, -1.0, -1.0, 0.0]) * amplitude

    def steer(t: float, state: np.ndarray) -> float:
        return float(np.interp(t, times, values))

    return _open_loop(config, rate_hz, seed, speed_kmh / 3.6, mu, steer, duration, bias, progress,
                      disturbances=Disturbances.of(**disturbances))


def hil_sine(config: VehicleConfig, rate_hz: float, seed: int, mu: float, v_start: float,
             v_end: float, speed_tau: float, frequency: float, ay_start: float, ay_end: float,
             duration: float, outliers: bool, bias: bool, progress=None, **disturbances) -> Log:
    """Seed 000 scenario C (HIL with a driver), reconstructed: the pedal is held, so vx rises
    from ``v_start`` towards ``v_end`` (m/s) as v_end - (v_end - v_start) exp(-t / speed_tau);
    the steering is a sine of ``frequency`` Hz whose amplitude grows so that the steady-state
    lateral acceleration it asks for rises linearly from ``ay_start`` to ``ay_end`` times mu g
    over ``duration`` s (*assumptions*: the paper shows the driver's input only in figures).
    The steer angle for a demand a_y at speed vx is a_y l (1 + K_s vx^2) / vx^2."""
    chosen = Disturbances.of(**disturbances)
    truth = chosen.truth_car(config)
    vehicle = driver_view(truth)
    l = vehicle["cg_to_front_axle"] + vehicle["cg_to_rear_axle"]
    ks = vehicle["mass"] / l**2 * (vehicle["cg_to_rear_axle"] / vehicle["cornering_stiffness_front"]
                                   - vehicle["cg_to_front_axle"] / vehicle["cornering_stiffness_rear"])

    def target(t: float) -> float:
        return v_end - (v_end - v_start) * np.exp(-t / speed_tau)

    def steer(t: float, state: np.ndarray) -> float:
        if t < 1.0:
            return 0.0
        demand = mu * GRAVITY * (ay_start + (ay_end - ay_start) * t / duration)
        vx = target(t)
        return demand * l * (1 + ks * vx**2) / vx**2 * np.sin(2 * np.pi * frequency * (t - 1.0))

    dt = 1.0 / (rate_hz * substeps(rate_hz))
    hold = SpeedHold(truth.vehicle, truth.plant, target, dt, road=chosen.road())
    run = simulate(truth, rate_hz, duration, v_start, steer, hold, _constant(mu),
                   progress=progress, road=chosen.road())
    return _log(truth, run, seed, outliers, bias, np.zeros(len(run.t), dtype=bool),
                disturbances=chosen)


def banked_curve(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float, mu: float,
                 radius: float, superelevation: float, duration: float, outliers: bool, bias: bool,
                 progress=None, **disturbances) -> Log:
    """A highway bend: 60 m straight, then a left-hand clothoid over 100 m into an arc of
    ``radius`` m, at constant ``speed_kmh``; the road's superelevation (% toward the inside,
    the outer edge up) runs off linearly along the clothoid (bank -atan(e/100)), as highway
    design does (*assumption*: RAA/AASHTO-style runoff over the transition)."""
    bend = courses.Bend(60.0, 100.0, radius, speed_kmh / 3.6 * duration + 20.0)
    road = Road((0.0, 60.0, 160.0), (0.0, 0.0, -slope_angle(superelevation)), (0.0, 0.0, 0.0))
    return _drive(config, rate_hz, seed, bend, speed_kmh / 3.6, duration, _constant(mu), outliers,
                  bias, progress, disturbances=Disturbances.of(**disturbances), road=road)


def crossfall_lane_change(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float,
                          mu: float, crossfall: float, duration: float, outliers: bool, bias: bool,
                          progress=None, **disturbances) -> Log:
    """Lane changes on a straight road with ``crossfall`` % (drainage to the right, the left
    edge up): a 3.5 m change to the left over 60 m, 60 m in that lane, and back over 60 m."""
    course = courses.lane_changes([LEAD_IN], [60.0], 60.0, _width(config))
    road = Road.constant(bank=slope_angle(crossfall))
    return _drive(config, rate_hz, seed, course, speed_kmh / 3.6, duration, _constant(mu), outliers,
                  bias, progress, disturbances=Disturbances.of(**disturbances), road=road)


def downhill_brake_curve(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float,
                         end_speed_kmh: float, deceleration: float, mu: float, radius: float,
                         downhill: float, duration: float, outliers: bool, bias: bool, progress=None,
                         **disturbances) -> Log:
    """Braking into a left-hand bend of ``radius`` m on a ``downhill`` % slope:
    from ``speed_kmh`` down to ``end_speed_kmh`` at ``deceleration`` m/s^2 from t = 2 s, the
    clothoid starting at 40 m."""
    ramp = SpeedRamp(speed_kmh / 3.6, end_speed_kmh / 3.6, 2.0, deceleration)
    travel = sum(ramp(t) for t in np.arange(0.0, duration, 0.01)) * 0.01
    bend = courses.Bend(40.0, 40.0, radius, travel + 20.0)
    road = Road.constant(grade=-slope_angle(downhill))
    return _drive(config, rate_hz, seed, bend, speed_kmh / 3.6, duration, _constant(mu), outliers,
                  bias, progress, disturbances=Disturbances.of(**disturbances), road=road,
                  target=ramp)


def crest_dip(config: VehicleConfig, rate_hz: float, seed: int, speed_kmh: float, mu: float,
              peak_grade: float, amplitude: float, frequency: float, duration: float, outliers: bool,
              bias: bool, progress=None, **disturbances) -> Log:
    """A straight road over a crest and through a dip at ``speed_kmh``: the grade rises to
    +``peak_grade`` % over 100 m, falls to -``peak_grade`` % over 200 m (the crest) and back to 0 over 100 m
    (the dip), from 50 m on; gentle sine steering of ``amplitude`` rad at ``frequency`` Hz keeps
    the car turning (*assumption*: a country road)."""
    g = slope_angle(peak_grade)
    road = Road((0.0, 50.0, 150.0, 350.0, 450.0), (0.0,) * 5, (0.0, 0.0, g, -g, 0.0))

    def steer(t: float, state: np.ndarray) -> float:
        return amplitude * np.sin(2 * np.pi * frequency * t)

    return _open_loop(config, rate_hz, seed, speed_kmh / 3.6, mu, steer, duration, bias, progress,
                      disturbances=Disturbances.of(**disturbances), road=road, outliers=outliers)


def low_speed(config: VehicleConfig, rate_hz: float, seed: int, progress=None) -> Log:
    """Synthetic steady-state cornering while the speed falls 12 -> 0 -> -1 (reverse) -> 12 m/s;
    exercises the estimators' low-speed hold (no plant: the plant needs |v| > 3.5 m/s)."""
    vehicle = driver_view(config)
    l = vehicle["cg_to_front_axle"] + vehicle["cg_to_rear_axle"]
    t = np.arange(0.0, 24.0 + 0.5 / rate_hz, 1.0 / rate_hz)
    vx = np.interp(t, [0, 2, 9, 10, 11, 12, 13, 20, 24], [12, 12, 0, 0, -1, -1, 0, 12, 12])
    delta = 0.04 * np.sin(2 * np.pi * 0.25 * t)
    m, a, b = vehicle["mass"], vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cr = vehicle["cornering_stiffness_rear"]
    ks = m / l**2 * (b / vehicle["cornering_stiffness_front"] - a / cr)
    gain = 1.0 / (1.0 + ks * vx**2)
    r = vx * delta / l * gain
    vy = vx * np.tan((b / l - m * a * vx**2 / (l**2 * cr)) * delta * gain)
    rng = np.random.default_rng(seed)
    noise = config.sensors or {"accel_noise": 0.3, "gyro_noise": np.deg2rad(1.0)}
    half_track, radius = vehicle["track_width"] / 2, vehicle["wheel_radius"]
    rear = {side: (vx + sign * r * half_track) / radius for side, sign in (("l", -1), ("r", 1))}
    front = {side: ((vx + sign * r * half_track) * np.cos(delta) + (vy + a * r) * np.sin(delta)) / radius
             for side, sign in (("l", -1), ("r", 1))}     # free rolling, along each wheel's heading
    return Log({
        "t": t, "delta": delta, "vx": vx,
        "ax": np.gradient(vx, t) + rng.normal(0, noise["accel_noise"], len(t)),
        "ay": vx * r + rng.normal(0, noise["accel_noise"], len(t)),
        "r": r + rng.normal(0, noise["gyro_noise"], len(t)),
        "omega_fl": front["l"], "omega_fr": front["r"], "omega_rl": rear["l"], "omega_rr": rear["r"],
        "beta_ref": np.arctan2(vy, vx), "vx_ref": vx, "vy_ref": vy, "r_ref": r,
        "mu": np.ones_like(t), "off_course": np.zeros_like(t),
    }, source="<simulated low_speed>", notes={"run": "synthetic, no plant"})


def invalid_inputs(config: VehicleConfig, rate_hz: float, seed: int, progress=None) -> Log:
    """The 80 km/h DLC with bad samples: NaN, +-Inf and out-of-range values in every input, alone
    and in runs, so every hold/resume path is taken."""
    log = dlc(config, rate_hz, seed, 80.0, 1.0, False, False, progress=progress)
    n = len(log)
    faults = (
        ("ay", 0.30, 1, np.nan), ("r", 0.50, 1, np.inf), ("delta", 0.70, 1, -np.inf),
        ("vx", 0.90, 1, np.nan), ("ax", 1.10, 1, np.nan), ("delta", 2.00, 3, 2.5),
        ("r", 2.50, 5, 40.0), ("vx", 3.00, 1, 1e6), ("vx", 3.50, 2, -np.inf),
        ("ay", 4.00, 20, np.nan), ("vx", 5.00, 4, 0.5), ("ay", 5.50, 1, -1e300),
        ("omega_fl", 6.00, 1, np.nan), ("omega_rr", 6.50, 3, np.inf), ("omega_fr", 7.00, 1, 1e4),
    )
    for column, time, count, value in faults:
        start = int(round(time * rate_hz))
        if start < n:
            log.columns[column][start:start + count] = value
    log.source = "<simulated invalid_inputs>"
    return log


def input_extremes(config: VehicleConfig, rate_hz: float, seed: int, progress=None) -> Log:
    """Synthetic, no plant (``seed`` unused): noise-free inputs at 80 km/h that drive every
    estimator to the edges of its decisions, for the model coverage (``vsegen verify --coverage``).
    Stretches of 0.4 s (nothing in between): straight with every input exactly 0 (no excitation);
    a_y and a_x at 0.85 of their plausibility limits in each pair of signs (a wheel lifts); a yaw
    rate of half its limit (a measurement rejected past its time-out); the speed input 10 m/s
    above the wheels' (a diverged filter); a steering step to a fifth of its limit; then each input
    once at 1.5 times its limit. Its truth columns are the nominal values (straight at 80 km/h),
    not a vehicle's: it is verified, not scored."""
    vehicle = driver_view(config)
    limits = config.limits
    t = np.arange(0.0, 8.7 + 0.5 / rate_hz, 1.0 / rate_hz)
    speed, zero = np.full_like(t, 80.0 / 3.6), np.zeros_like(t)
    columns = {"t": t, "delta": zero.copy(), "vx": speed.copy(), "ax": zero.copy(), "ay": zero.copy(),
               "r": zero.copy(), "mz": zero.copy()}

    def stretch(k: int) -> np.ndarray:
        """The k-th 0.4-s stretch from 1 s, with 0.4 s of nominal inputs before each."""
        start = 1.0 + 0.8 * k
        return (t >= start) & (t < start + 0.4)

    for k, (ay_sign, ax_sign) in enumerate(((1, 1), (-1, 1), (1, -1), (-1, -1))):
        columns["ay"][stretch(k)] = ay_sign * 0.85 * limits["ay_max"]
        columns["ax"][stretch(k)] = ax_sign * 0.85 * limits["ax_max"]
    columns["r"][stretch(4)] = 0.5 * limits["r_max"]
    columns["vx"][stretch(5)] += 10.0
    columns["delta"][stretch(6)] = 0.2 * limits["delta_max"]
    columns.update({f"omega_{corner}": speed / vehicle["wheel_radius"] for corner in ("fl", "fr", "rl", "rr")})
    for k, entry in enumerate(signals.INPUTS):
        columns[entry.name][int(round((6.7 + 0.2 * k) * rate_hz))] = 1.5 * limits[entry.limit_key]
    return Log({**columns, "beta_ref": zero, "vx_ref": speed, "vy_ref": zero, "r_ref": zero,
                "mu": np.ones_like(t), "off_course": zero},
               source="<synthetic input_extremes>",
               notes={"run": "synthetic, no plant: the truth columns are nominal, the run is not scored"})


# ------------------------------------------------------------------------------------------------


def _numbers(key: str, text: str) -> tuple[float, ...]:
    try:
        return tuple(float(part) for part in text.split(","))
    except ValueError:
        raise ValueError(f"{key} = {text!r}: expected comma-separated numbers") from None


def _width(config: VehicleConfig) -> float:
    return config.vehicle["track_width"] + courses.BODY_OVERHANG


def _constant(mu: float) -> FrictionProfile:
    return FrictionProfile((mu,))


RUNS = Memo(size=32)
"""Truth runs by (vehicle, rate, course, speed, duration, friction, yaw moment): the plant is
deterministic, only the sensor noise depends on the seed, so Monte-Carlo runs simulate the plant once."""


@dataclass(frozen=True)
class SpeedRamp:
    """A target speed (m/s): ``start`` until ``t0`` s, then changing by ``rate`` m/s^2 toward
    ``end``, then ``end``."""

    start: float
    end: float
    t0: float
    rate: float

    def __call__(self, t: float) -> float:
        change = max(t - self.t0, 0.0) * self.rate
        return max(self.start - change, self.end) if self.end < self.start else min(self.start + change, self.end)


@dataclass(frozen=True)
class YawMomentPulses:
    """A direct yaw moment (N*m, positive counter-clockwise) from rear torque vectoring: pulses of
    alternating sign, ``amplitude`` for 0.6 s every 2 s from t = 1.5 s (*assumption*: a
    torque-vectoring test pattern; no seed gives one). The rear wheels get -+ amplitude R / t_w
    (left, right) on top of the speed controller's torques, so M_z = t_w / 2 (F_x,rr - F_x,rl)."""

    amplitude: float = 0.0
    start: float = 1.5
    period: float = 2.0
    width: float = 0.6

    def __call__(self, t: float) -> float:
        if self.amplitude == 0.0 or t < self.start:
            return 0.0
        cycles, phase = divmod(t - self.start, self.period)
        return self.amplitude * (1.0 if cycles % 2 == 0 else -1.0) if phase < self.width else 0.0

    def torques(self, vehicle, speed_control):
        """Wheel torques (fl, fr, rl, rr) of ``speed_control`` plus the vectoring pair."""
        if self.amplitude == 0.0:
            return speed_control
        scale = vehicle["wheel_radius"] / vehicle["track_width"]

        def torques(t: float, state: np.ndarray) -> np.ndarray:
            delta = self(t) * scale
            return speed_control(t, state) + np.array([0.0, 0.0, -delta, delta])

        return torques


def _truth_run(config, rate_hz, course, speed, duration, mu, yaw_moment, progress, road, target=None) -> Run:
    """The plant driven along ``course`` at ``speed`` (m/s; or the speed profile ``target`` of
    time) by the path follower, on ``road``."""
    dt = 1.0 / (rate_hz * substeps(rate_hz))
    steer = PathFollower(driver_view(config), course.centre_line, dt, config.plant["driver_bandwidth"],
                         config.plant["driver_damping"])
    hold = SpeedHold(config.vehicle, config.plant, target or (lambda t: speed), dt, road=road)
    return simulate(config, rate_hz, duration, speed, steer, yaw_moment.torques(config.vehicle, hold), mu,
                    progress=progress, road=road)


def _drive(config, rate_hz, seed, course, speed, duration, mu, outliers, bias, progress,
           yaw_moment: YawMomentPulses = YawMomentPulses(),
           disturbances: Disturbances = NONE, road: Road | None = None,
           target: SpeedRamp | None = None) -> Log:
    """The path follower's drive along ``course``, on ``road`` (default: the disturbances'
    constant bank and grade), logged with the disturbances."""
    truth = disturbances.truth_car(config)
    road = disturbances.road(road or FLAT)
    key = (truth.truth_fingerprint(), rate_hz, course, speed, duration, mu, yaw_moment, road, target)
    run = RUNS.get(key, lambda: _truth_run(truth, rate_hz, course, speed, duration, mu, yaw_moment,
                                           progress, road, target))
    hit = course.outside(run.state("X"), run.state("Y"), _width(truth))
    return _log(truth, run, seed, outliers, bias, hit, yaw_moment, disturbances)


def _open_loop(config, rate_hz, seed, speed, mu, steer, duration, bias, progress,
               yaw_moment: YawMomentPulses = YawMomentPulses(),
               disturbances: Disturbances = NONE, road: Road = FLAT, outliers: bool = False) -> Log:
    """The plant steered by ``steer`` at held ``speed`` (m/s) on ``road`` (plus the disturbances'
    bank and grade), logged with the disturbances."""
    truth = disturbances.truth_car(config)
    dt = 1.0 / (rate_hz * substeps(rate_hz))
    road = disturbances.road(road)
    hold = SpeedHold(truth.vehicle, truth.plant, lambda t: speed, dt, road=road)
    run = simulate(truth, rate_hz, duration, speed, steer, yaw_moment.torques(truth.vehicle, hold),
                   _constant(mu), progress=progress, road=road)
    return _log(truth, run, seed, outliers, bias, np.zeros(len(run.t), dtype=bool), yaw_moment, disturbances)


def _log(config: VehicleConfig, run: Run, seed: int, outliers: bool, bias: bool,
         hit_cone: np.ndarray, yaw_moment: YawMomentPulses = YawMomentPulses(),
         disturbances: Disturbances = NONE) -> Log:
    """The log of ``run``; it has an ``mz`` column (the commanded moment) only when a direct yaw
    moment was applied (``mz`` is an optional column), and ``bank`` and ``grade`` columns (truth,
    rad) when the road is not flat."""
    spun = np.maximum.accumulate(np.abs(run.beta) > SPIN_SIDESLIP)
    moment = ({"mz": np.array([yaw_moment(t) for t in run.t])} if yaw_moment.amplitude else {})
    measured = sensors.measure(config, run, seed, bias, outliers, disturbances.mounting)
    measured = disturbances.apply(measured, run.t, seed) if disturbances.options else measured
    road = ({"bank_ref": run.input("bank"), "grade_ref": run.input("grade")}
            if np.any(run.input("bank")) or np.any(run.input("grade")) else {})
    columns = {"t": run.t, **measured, **moment, **road,
               "beta_ref": run.beta, "vx_ref": run.state("vx"), "vy_ref": run.state("vy"),
               "r_ref": run.state("r"), "mu": run.input("mu"),
               "off_course": (hit_cone | spun).astype(float)}
    notes = {
        "stayed in cones": "yes" if not hit_cone.any() else
        f"no (first cone at t = {run.t[np.argmax(hit_cone)]:.2f} s)",
        "spun": "no" if not spun.any() else f"yes (|beta| > 15 deg at t = {run.t[np.argmax(spun)]:.2f} s)",
        "peak |ay|": f"{np.abs(run.truth_of('ay')).max():.2f} m/s^2",
        "peak |beta|": f"{np.rad2deg(np.abs(run.beta)).max():.2f} deg",
    }
    return Log(columns, source="<simulated>", notes=notes)
