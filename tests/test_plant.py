"""Truth-plant validation: linear region, saturation, coast-down, symmetry, tyre consistency."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from vsegen.harness.reference import blocks
from vsegen.harness.sim import tyre
from vsegen.harness.sim.driver import SpeedHold
from vsegen.harness.sim.simulate import simulate
from vsegen.harness.sim.two_track import INPUT, STATE, build_plant, equations

RATE = 100.0


def run_open_loop(config, speed, steer, duration, mu=1.0, torques=None):
    dt = 1e-3
    hold = torques or SpeedHold(config.vehicle, config.plant, lambda t: speed, dt)
    return simulate(config, RATE, duration, speed, steer, hold, lambda t, s: mu)


def test_zero_slip_slope_matches_vehicle_file(config):
    """docs/methods.md, seed 000 A4: the [vehicle] axle stiffness is the plant tyres' zero-slip slope."""
    plant = build_plant(config.vehicle, config.plant, 1e-3)
    alpha = ca.SX.sym("alpha")
    for load, stiffness in zip(plant.static_loads(), ("cornering_stiffness_front",
                                                      "cornering_stiffness_rear")):
        _, fy = tyre.forces(config.plant, load, 1.0, 0.0, alpha)
        slope = float(ca.Function("s", [alpha], [ca.jacobian(fy, alpha)])(0.0))
        assert 2 * slope == pytest.approx(config.vehicle[stiffness], rel=1e-3)


@pytest.mark.parametrize("speed", [15.0, 25.0])
def test_small_lateral_acceleration_matches_linear_bicycle(config, speed):
    delta = 0.004
    run = run_open_loop(config, speed, lambda t, s: delta, 8.0)
    ay = run.truth_of("ay")[-1]
    assert 0.2 < ay < 1.5, "the test must stay in the linear region"
    A, B, _, _ = blocks.bicycle(config.vehicle, speed)
    vy_lin, r_lin = (-np.linalg.solve(A, B) * delta).ravel()
    assert run.state("r")[-1] == pytest.approx(r_lin, rel=0.05)
    assert np.arctan2(run.state("vy")[-1], run.state("vx")[-1]) == pytest.approx(vy_lin / speed, rel=0.05)


def test_tyre_force_saturates_at_mu_times_load(config):
    load, mu = 4000.0, 0.7
    alpha, kappa = ca.SX.sym("alpha"), ca.SX.sym("kappa")
    fx, fy = tyre.forces(config.plant, load, mu, kappa, alpha)
    fn = ca.Function("f", [kappa, alpha], [fx, fy])
    alphas = np.deg2rad(np.linspace(-30, 30, 241))
    lateral = np.array([float(fn(0.0, a)[1]) for a in alphas])
    assert np.abs(lateral).max() <= mu * load * (1 + 1e-12)
    assert np.abs(lateral).max() >= 0.98 * mu * load
    assert np.all(np.sign(lateral[alphas > 0]) > 0)  # alpha > 0 pushes left
    for k in (-0.5, -0.1, 0.05, 0.2, 1.0):
        for a in np.deg2rad([-20, -3, 0.5, 8, 25]):
            fx_, fy_ = (float(v) for v in fn(k, a))
            assert np.hypot(fx_, fy_) <= mu * load * (1 + 1e-12)


def test_vehicle_lateral_acceleration_limited_by_friction(config):
    mu = 0.5
    run = run_open_loop(config, 22.0, lambda t, s: 0.08 * min(t / 0.5, 1.0), 4.0, mu=mu)
    assert np.abs(run.truth_of("ay")).max() <= mu * 9.81 * 1.02


def test_coast_down_loses_speed_monotonically(config):
    run = run_open_loop(config, 30.0, lambda t, s: 0.0, 20.0, torques=lambda t, s: np.zeros(4))
    vx = run.state("vx")
    assert np.all(np.diff(vx) < 0)
    assert 20.0 < vx[-1] < 29.0


def test_symmetric_input_gives_symmetric_response(config):
    def steer(sign):
        return lambda t, s: sign * 0.03 * np.sin(2 * np.pi * 0.7 * t)

    left, right = (run_open_loop(config, 25.0, steer(sign), 5.0) for sign in (1.0, -1.0))
    for name in ("vy", "r", "Y", "psi"):
        scale = np.abs(left.state(name)).max()
        assert scale > 0
        np.testing.assert_allclose(left.state(name), -right.state(name), atol=1e-9 * scale)
    np.testing.assert_allclose(left.state("vx"), right.state("vx"), rtol=1e-12)


def test_driven_wheels_spin_up_under_traction(config):
    run = run_open_loop(config, 20.0, lambda t, s: 0.0, 3.0,
                        torques=lambda t, s: np.array([400.0, 400.0, 0.0, 0.0]))
    front = run.state("omega_fl")[-1] * config.vehicle["wheel_radius"]
    rear = run.state("omega_rl")[-1] * config.vehicle["wheel_radius"]
    assert front > rear * 1.001 and run.state("vx")[-1] > 20.0


def test_roll_mode_has_the_configured_frequency_and_damping(config):
    """The roll states' linearisation is the damped oscillator of [plant] roll_frequency and
    roll_damping_ratio: eigenvalues -zeta w_n +- j w_n sqrt(1 - zeta^2)."""
    params = {**config.plant, "roll_frequency": 1.4, "roll_damping_ratio": 0.35}
    x, u = ca.SX.sym("x", len(STATE)), ca.SX.sym("u", len(INPUT))
    jacobian = ca.Function("j", [x, u], [ca.jacobian(equations(config.vehicle, params, x, u)[0], x)])
    state = build_plant(config.vehicle, params, 1e-3).initial_state(20.0)
    roll = [STATE.index("phi"), STATE.index("phi_rate")]
    block = np.asarray(jacobian(state, [0.0, 0, 0, 0, 0, 1.0, 0, 0, 0]))[np.ix_(roll, roll)]
    poles = np.linalg.eigvals(block)
    assert np.abs(poles) == pytest.approx(2 * np.pi * 1.4, rel=1e-9)
    assert -poles.real / np.abs(poles) == pytest.approx(0.35, rel=1e-9)


@pytest.mark.parametrize("frequency", [0.0, 1.4])
def test_steady_cornering_rolls_by_the_roll_gradient(config, frequency):
    """In steady cornering both roll models settle at phi = roll_gradient * ay."""
    params = {**config.plant, "roll_frequency": frequency}
    run = run_open_loop(replace(config, plant=params), 20.0, lambda t, s: 0.03, 6.0)
    ay, roll = run.truth_of("ay")[-1], run.truth_of("roll")[-1]
    assert ay > 3.0
    assert roll == pytest.approx(params["roll_gradient"] * ay, rel=1e-3)


def test_roll_mode_overshoots_a_steer_step_and_quasi_static_roll_does_not(config):
    """An underdamped roll mode overshoots the steady roll angle after a steer step."""
    peaks = {}
    for frequency in (0.0, 1.0):
        params = {**config.plant, "roll_frequency": frequency, "roll_damping_ratio": 0.2}
        run = run_open_loop(replace(config, plant=params), 20.0,
                            lambda t, s: 0.03 if t > 0.5 else 0.0, 6.0)
        roll = run.truth_of("roll")
        peaks[frequency] = roll.max() / roll[-1]
    assert peaks[0.0] < 1.02 < 1.1 < peaks[1.0]
