"""Scenarios and the sensor model: names, columns, reports, determinism, sensor effects."""

from __future__ import annotations

import numpy as np
import pytest
from locations import VEHICLES
from scipy.spatial.transform import Rotation

from vsegen.harness.logs.table import REQUIRED, TRUTH
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim import sensor_model as sensors
from vsegen.harness.sim.scenarios import SCENARIOS, Case, ScenarioError, parse_option
from vsegen.harness.sim.two_track import GRAVITY

STABLE_NAMES = {"dlc", "continuous_dlc", "step_steer", "sine_steer", "fishhook"}


def test_stable_names():
    assert STABLE_NAMES <= set(SCENARIOS)


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_every_scenario_gives_a_complete_log(config, name):
    log = Case.of(name).simulate(config, 100.0)
    road = ("bank_ref", "grade_ref")          # only where the road is not flat
    for column in (*REQUIRED, *(c for c in TRUTH if c not in road)):
        assert column in log, column
    flat = name in ("dlc", "continuous_dlc", "step_steer", "sine_steer", "fishhook", "hil_sine",
                    "low_speed", "invalid_inputs", "input_extremes")
    assert all((c in log) != flat for c in road), sorted(log.columns)
    assert np.allclose(np.diff(log["t"]), 0.01)
    for column in ("beta_ref", "vx_ref", "vy_ref", "r_ref", "mu"):
        assert np.all(np.isfinite(log[column]))
    if name != "invalid_inputs":
        assert all(np.all(np.isfinite(log[c])) for c in REQUIRED)


@pytest.mark.parametrize("car", ["c_class", "rwd_saloon"])
def test_dlc_reports_cones_and_spin(config, car):
    """The default DLC (80 km/h) of every shipped truth car stays inside the cones (the saloon's
    calmer simulated driver, [plant] driver_bandwidth; before, it touched a cone of the offset lane
    at 4.09 s); a 120 km/h one on ice does not."""
    car_config = load_vehicle(VEHICLES / f"{car}.toml")
    clean = Case.of("dlc").simulate(car_config, 100.0)
    assert clean.notes["stayed in cones"] == "yes" and clean.notes["spun"] == "no"
    assert not clean["off_course"].any()
    hard = Case.of("dlc", speed_kmh=120.0, mu=0.35).simulate(config, 100.0)
    assert hard.notes["stayed in cones"].startswith("no") and hard["off_course"].any()


def test_continuous_dlc_friction_steps(config):
    log = Case.of("continuous_dlc").simulate(config, 100.0)
    assert log["t"][-1] == pytest.approx(30.0)
    mu = log["mu"]
    assert set(np.unique(mu)) == {0.35, 0.5, 0.85}
    assert mu[int(8.9 * 100)] == 0.85 and mu[int(9.1 * 100)] == 0.5 and mu[int(18.1 * 100)] == 0.35
    assert log.notes["stayed in cones"] == "yes" and log.notes["spun"] == "no"
    assert log["vx_ref"].min() > 32.5  # speed held at 120 km/h


@pytest.mark.parametrize("mu", [0.85, 0.35])
def test_hil_sine_speed_rises_and_steering_grows(config, mu):
    """Seed 000 §4.3 reconstructed: vx from 12.5 m/s upwards, growing sine-like demand up to
    0.7 mu g (the lateral acceleration follows it: below the limit, no spin)."""
    log = Case.of("hil_sine", mu=mu).simulate(config, 100.0)
    vx, t = log["vx_ref"], log["t"]
    assert vx[0] == pytest.approx(12.5, abs=0.05) and vx[-1] > 25.0
    assert np.all(np.diff(vx[t > 2.0]) > -1e-3)  # the pedal is held: vx never falls
    ay = np.abs(log["vx_ref"] * log["r_ref"])
    early, late = ay[(t > 1) & (t < 9)].max(), ay[t > 32].max()
    assert late > 2.5 * early and late > 0.5 * mu * 9.81
    assert np.all(log["mu"] == mu) and log.notes["spun"] == "no"


def test_sensor_noise_is_seeded(config):
    a = Case.of("sine_steer").simulate(config, 100.0, seed=3)
    b = Case.of("sine_steer").simulate(config, 100.0, seed=3)
    c = Case.of("sine_steer").simulate(config, 100.0, seed=4)
    np.testing.assert_array_equal(a["ay"], b["ay"])
    assert not np.array_equal(a["ay"], c["ay"])
    noise = a["r"] - a["r_ref"]
    assert np.std(noise) == pytest.approx(config.sensors["gyro_noise"], rel=0.1)


def test_outliers_and_bias(config):
    log = Case.of("dlc", speed_kmh=120.0, outliers=True).simulate(config, 100.0)
    assert log["r"][200] == 0.47 and log["r"][700] == 0.84
    plain = Case.of("step_steer").simulate(config, 100.0)
    biased = Case.of("step_steer", bias=True).simulate(config, 100.0)
    np.testing.assert_allclose(np.mean(biased["ay"] - plain["ay"]), config.sensors["accel_bias"])
    np.testing.assert_allclose(np.mean(biased["r"] - plain["r"]), config.sensors["gyro_bias"])


def test_body_roll_shows_in_lateral_accelerometer(config):
    """In a steady left turn the rolled accelerometer reads more than the CG acceleration."""
    log = Case.of("step_steer").simulate(config, 100.0)
    steady = slice(400, 600)
    ay_true = log["vx_ref"][steady] * log["r_ref"][steady]  # steady state: ay = vx r
    excess = np.mean(log["ay"][steady]) - np.mean(ay_true)
    expected = 9.81 * np.sin(config.plant["roll_gradient"] * np.mean(ay_true))
    assert excess == pytest.approx(expected, rel=0.15)
    assert excess > 0.3  # "several tenths of m/s^2"


def test_vx_from_rear_wheels(config):
    log = Case.of("dlc").simulate(config, 100.0)
    vx = 0.5 * (log["omega_rl"] + log["omega_rr"]) * config.vehicle["wheel_radius"]
    np.testing.assert_array_equal(log["vx"], vx)
    assert np.abs(log["vx"] - log["vx_ref"]).max() < 0.1


@pytest.mark.parametrize("text,fragment", [
    ("speed=3", "unknown option 'speed=3'"),
    ("speed_kmh", "unknown option"),
    ("speed_kmh=fast", "speed_kmh = 'fast': expected a float"),
    ("outliers=maybe", "expected a bool"),
])
def test_option_errors(text, fragment):
    with pytest.raises(ScenarioError, match=fragment.replace("(", r"\(").replace("'", "'")):
        parse_option("dlc", text)


def test_option_parsing():
    assert parse_option("dlc", "speed_kmh=120") == ("speed_kmh", 120.0)
    assert parse_option("dlc", "outliers=true") == ("outliers", True)


def test_friction_by_distance(config):
    log = Case.of("continuous_dlc", switch_by="distance", switch_times="300,600").simulate(config, 100.0)
    travelled = np.cumsum(log["vx_ref"]) * 0.01
    assert np.all(log["mu"][travelled < 295] == 0.85)
    assert np.all(log["mu"][(travelled > 305) & (travelled < 595)] == 0.5)
    assert np.all(log["mu"][travelled > 605] == 0.35)


def test_logs_do_not_share_memory_with_cached_runs(config):
    first = Case.of("dlc", speed_kmh=90.0).simulate(config, 100.0, seed=5)
    first.columns["delta"][:] = np.nan
    again = Case.of("dlc", speed_kmh=90.0).simulate(config, 100.0, seed=6)
    assert np.all(np.isfinite(again["delta"]))


def test_accelerometers_read_the_specific_force_of_the_rotated_body():
    """sensors.specific_force against scipy's rotations: R = Rz(psi) Ry(theta) Rx(phi), f_body =
    R^T (a_world + [0, 0, g])."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        psi, theta, phi = rng.uniform(-0.3, 0.3, 3)
        ax, ay = rng.uniform(-8, 8, 2)
        yaw = Rotation.from_euler("z", psi)
        body = Rotation.from_euler("ZYX", [psi, theta, phi])
        world = yaw.apply([ax, ay, 0.0]) + [0.0, 0.0, GRAVITY]
        np.testing.assert_allclose(sensors.specific_force(ax, ay, GRAVITY, phi, theta),
                                   body.inv().apply(world), atol=1e-12)


def test_yaw_gyro_reads_the_body_rate():
    """sensors.body_yaw_rate against the body rate of R(t): skew(w) = R^T R' (central difference)."""
    def attitude(t):
        return Rotation.from_euler("ZYX", [0.4 * t, 0.05 * np.sin(2 * t), 0.1 * np.sin(3 * t)])
    t, h = 0.7, 1e-6
    rate = (attitude(t).inv() * attitude(t + h)).as_rotvec() / (2 * h) \
        - (attitude(t).inv() * attitude(t - h)).as_rotvec() / (2 * h)
    theta, phi = 0.05 * np.sin(2 * t), 0.1 * np.sin(3 * t)
    assert sensors.body_yaw_rate(0.4, phi, theta, 0.1 * np.cos(2 * t)) == pytest.approx(rate[2], abs=1e-7)


def test_lever_arm_of_a_sensor_above_the_cg():
    """A sensor z above the CG of a body rolling with phi'' reads -phi'' z laterally; one x ahead
    of it reads r' x laterally and -r^2 x longitudinally."""
    roll_acc, yaw_acc, r = 2.0, 0.5, 0.4
    lateral_z = sensors.lever_arm_acceleration(np.array([0.0, 0.0, 0.3]), np.zeros((3, 1)),
                                               np.array([[roll_acc], [0.0], [0.0]]))
    assert lateral_z[:, 0] == pytest.approx([0.0, -roll_acc * 0.3, 0.0])
    ahead = sensors.lever_arm_acceleration(np.array([0.5, 0.0, 0.0]), np.array([[0.0], [0.0], [r]]),
                                           np.array([[0.0], [0.0], [yaw_acc]]))
    assert ahead[:, 0] == pytest.approx([-r * r * 0.5, yaw_acc * 0.5, 0.0])
