"""Bank and grade in the truth plant and its sensors, against hand calculations."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from vsegen.harness.sim.road import Road, slope_angle
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.sim.sensor_model import specific_force
from vsegen.harness.sim.two_track import GRAVITY, INPUT, STATE, TRUTH, build_plant, equations


def _plant(config):
    return build_plant(dict(config.vehicle), dict(config.plant), 1e-3)


def _inputs(bank=0.0, grade=0.0, curvature=0.0):
    u = np.zeros(len(INPUT))
    u[INPUT.index("mu")] = 1.0
    u[INPUT.index("bank")], u[INPUT.index("grade")] = bank, grade
    u[INPUT.index("vertical_curvature")] = curvature
    return u


def _derivative(plant, state, u):
    """The plant's state derivative at ``state`` with ``u`` (its equations, not a step)."""
    x, w = ca.SX.sym("x", len(STATE)), ca.SX.sym("u", len(INPUT))
    rates = ca.Function("rates", [x, w], [equations(plant.vehicle, plant.params, x, w)[0]])
    return np.asarray(rates(state, u)).ravel()


def test_a_car_at_rest_on_a_bank_slides_down_it_at_g_sin_bank(config):
    """Wheels locked at rest, no tyre force yet: the first instant, gravity's component along the
    road pulls the car right (bank positive: left edge up) at g sin(bank) cos(grade), back at
    g sin(grade); the loads carry g cos(bank) cos(grade)."""
    plant = _plant(config)
    bank, grade = slope_angle(6.0), slope_angle(2.5)
    state = plant.initial_state(0.0)
    rates = _derivative(plant, state, _inputs(bank, grade))
    assert rates[STATE.index("vy")] == pytest.approx(-GRAVITY * np.sin(bank) * np.cos(grade), rel=1e-6)
    assert rates[STATE.index("vx")] == pytest.approx(-GRAVITY * np.sin(grade), rel=1e-6)
    truth = dict(zip(TRUTH, plant.truth(state, _inputs(bank, grade))))
    loads = sum(truth[f"fz_{w}"] for w in ("fl", "fr", "rl", "rr"))
    assert loads == pytest.approx(config.vehicle["mass"] * GRAVITY * np.cos(bank) * np.cos(grade), rel=1e-12)
    assert truth["az"] == pytest.approx(GRAVITY * np.cos(bank) * np.cos(grade), rel=1e-12)


def test_a_sag_loads_the_car_and_a_crest_lightens_it_by_v_squared_kappa(config):
    plant = _plant(config)
    state = plant.initial_state(25.0)
    for curvature in (1 / 500.0, -1 / 500.0):
        truth = dict(zip(TRUTH, plant.truth(state, _inputs(curvature=curvature))))
        assert truth["az"] == pytest.approx(GRAVITY + 25.0**2 * curvature, rel=1e-12)


def test_a_flat_road_changes_nothing(config):
    """The road inputs at zero give the flat plant's step, bit for bit."""
    plant = _plant(config)
    state = plant.initial_state(22.0)
    state[STATE.index("vy")], state[STATE.index("r")] = 0.3, 0.2
    u = _inputs()
    u[INPUT.index("delta")] = 0.03
    step = plant.step(state, u)
    assert step[STATE.index("vx")] != state[STATE.index("vx")]
    assert dict(zip(TRUTH, plant.truth(state, u)))["az"] == GRAVITY


def test_the_accelerometer_on_a_banked_straight_reads_the_bank(config):
    """Driving straight across a 3 degree bank, the tyres hold the car against gravity: the body's
    a_y sensor reads g sin(3 deg) = 0.51 m/s^2 (plus the body's roll on its suspension) while
    the car does not accelerate sideways."""
    bank = np.deg2rad(3.0)
    fx, fy, fz = GRAVITY * 0.0, GRAVITY * np.sin(bank), GRAVITY * np.cos(bank)
    _, ay, _ = specific_force(fx, fy, fz, 0.0, 0.0)
    assert ay == pytest.approx(0.513, abs=1e-3)


def test_road_profiles_interpolate_and_reject_bad_geometry():
    road = Road((0.0, 100.0, 200.0), (0.0, 0.1, 0.1), (0.0, 0.0, 0.05))
    assert road(50.0) == pytest.approx([0.05, 0.0, 0.0])
    assert road(150.0) == pytest.approx([0.1, 0.025, 0.05 / 100.0])
    assert road(250.0) == pytest.approx([0.1, 0.05, 0.0])
    with pytest.raises(ValueError, match="stations must increase"):
        Road((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))
    with pytest.raises(ValueError, match="below 45 degrees"):
        Road.constant(bank=1.0)


def _mean_tail(log, column, seconds=3.0):
    t = log.columns["t"]
    return float(np.mean(log.columns[column][t >= t[-1] - seconds]))


def test_a_superelevated_bend_needs_less_tyre_force_and_the_accelerometer_shows_it(config):
    """R 400 m at 100 km/h on 6 % superelevation: the tyres supply v^2/R - g sin(atan 0.06)
    = 1.93 - 0.59 = 1.34 m/s^2, and the body-fixed a_y reads that times (1 + k_phi g) for the
    body's roll on its suspension (3 s means of noisy samples: 0.3 / sqrt(300) = 0.02)."""
    k_roll = config.plant["roll_gradient"]
    for superelevation in (6.0, 0.0):
        log = Case.of("banked_curve", superelevation=superelevation).simulate(config, 100.0)
        v, r = _mean_tail(log, "vx_ref"), _mean_tail(log, "r_ref")
        assert r == pytest.approx(v / 400.0, rel=2e-3)
        tyres = v * v / 400.0 - GRAVITY * np.sin(slope_angle(superelevation))
        assert _mean_tail(log, "ay") == pytest.approx(tyres * (1 + k_roll * GRAVITY), abs=0.06)
        if superelevation:
            assert log.columns["bank_ref"][-1] == pytest.approx(-slope_angle(superelevation), abs=1e-12)


def test_uphill_at_constant_speed_the_accelerometer_reads_the_grade(config):
    """Speed held up a 5 % grade: no kinematic acceleration, the drive force holds the car, so
    a_x reads g sin(atan 0.05) (times 1 + k_theta g for the body's pitch), 0.49 m/s^2."""
    log = Case.of("step_steer", grade=5.0, t_step=3.0).simulate(config, 100.0)
    t = log.columns["t"]
    expected = GRAVITY * np.sin(slope_angle(5.0)) * (1 + config.plant["pitch_gradient"] * GRAVITY)
    assert np.mean(log.columns["ax"][(t > 1.0) & (t < 3.0)]) == pytest.approx(expected, abs=0.05)
    assert np.ptp(log.columns["vx_ref"][(t > 1.0) & (t < 3.0)]) < 0.05
