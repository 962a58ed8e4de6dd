"""Seed 004's ARX dual Kalman filter: priors from the bicycle model (the spec's worked example),
KF1 and KF2 blocks, the E5 safeguards, invalid inputs, an absent ``mz`` column, and the spec's
acceptance (filtered yaw rate better than the gyro, no lag). Run on the generated C (double);
equivalence to the reference over every scenario is in verify."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.logs.table import Log
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.model import status

NAME = "arx_dual_kf"


def test_priors_reproduce_the_worked_example_of_the_spec(vehicle_text, variant):
    """§2.5: placeholder C_f = 1.2e5, C_r = 1.0e5 N/rad, 120 km/h, T = 0.01 s gives
    a1 = 1.88016, a2 = -0.88651, b1 = 4.905e-6, b_delta = 0.60163; and Phi, Gamma agree with
    scipy's ZOH."""
    text = with_settings(vehicle_text, "vehicle", cornering_stiffness_front=1.2e5,
                         cornering_stiffness_rear=1.0e5)
    config = variant(f"estimator.{NAME}", text, exogenous="mz_delta")
    est, c = compile_estimator(config, NAME)
    state = c.run(np.array([[0.0, 120 / 3.6, 0.0, 0.0]]))[1][0]      # the state after init
    theta = {n: state[est.states.index(n)] for n in ("a1", "a2", "b_mz", "b_delta")}
    assert theta["a1"] == pytest.approx(1.88016, abs=5e-6)
    assert theta["a2"] == pytest.approx(-0.88651, abs=5e-6)
    assert theta["b_mz"] == pytest.approx(4.905e-6, rel=1e-3)
    assert theta["b_delta"] == pytest.approx(0.60163, abs=5e-6)
    v, vx = config.vehicle, 120 / 3.6
    m, iz, a, b = v["mass"], v["yaw_inertia"], v["cg_to_front_axle"], v["cg_to_rear_axle"]
    cf, cr = v["cornering_stiffness_front"], v["cornering_stiffness_rear"]
    A = np.array([[-(cf + cr) / (m * vx), (b * cr - a * cf) / (m * vx) - vx],
                  [(b * cr - a * cf) / (iz * vx), -(a * a * cf + b * b * cr) / (iz * vx)]])
    B = np.array([[cf / m, 0.0], [a * cf / iz, 1.0 / iz]])
    Phi, Gamma, *_ = scipy.signal.cont2discrete((A, B, np.eye(2), np.zeros((2, 2))), 0.01)
    assert theta["a1"] == pytest.approx(np.trace(Phi), rel=1e-12)
    assert theta["a2"] == pytest.approx(-np.linalg.det(Phi), rel=1e-12)
    assert theta["b_mz"] == pytest.approx(Gamma[1, 1], rel=1e-12)
    assert theta["b_delta"] == pytest.approx(Gamma[1, 0], rel=1e-12)


def synthetic(theta, samples=3000, seed=3, noise=0.01745):
    """A true ARX(2) yaw-rate process driven by yaw-moment pulses, measured with gyro noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(samples) * 0.01
    mz = 1000.0 * np.sign(np.sin(2 * np.pi * 0.4 * t)) * (t > 0.5)
    x = np.zeros(samples)
    for n in range(2, samples):
        x[n] = theta[0] * x[n - 1] + theta[1] * x[n - 2] + theta[2] * mz[n - 1]
    inputs = np.column_stack([np.zeros(samples), np.full(samples, 20.0),
                              x + rng.normal(0, noise, samples), mz])
    return x, inputs


def test_kf2_identifies_the_parameters_of_a_true_arx_process(config):
    """KF2 moves the parameters from the bicycle-model prior towards those of the process that
    generates the data: the static gain b / (1 - a1 - a2) within 12 % (the prior is 42 % off).
    The single coefficients keep a bias (errors in variables: the regressor is built from KF1's
    noisy outputs, E4), so they are not asserted one by one. KF1's output beats the gyro."""
    truth = (1.88, -0.89, 8.0e-6)
    x, inputs = synthetic(truth, samples=6000)
    est, c = compile_estimator(config, NAME)
    outputs, states = c.run(inputs)

    def static_gain(a1, a2, b):
        return b / (1 - a1 - a2)

    true_gain = static_gain(*truth)
    prior = static_gain(*states[0, [est.states.index(n) for n in ("a1", "a2", "b_mz")]])
    final = static_gain(*outputs[-1000:, [est.outputs.index(n) for n in ("a1", "a2", "b_mz")]]
                        .mean(axis=0))
    assert abs(prior / true_gain - 1) > 0.3
    assert final == pytest.approx(true_gain, rel=0.12)
    error = outputs[500:, est.outputs.index("r")] - x[500:]
    gyro = inputs[500:, 2] - x[500:]
    assert np.sqrt(np.mean(error ** 2)) < 0.75 * np.sqrt(np.mean(gyro ** 2))


def test_kf1_gain_and_the_gyro_update(config):
    """[B4]: K1 = P-_11 / (P-_11 + R) from the companion-form prior covariance [B3]."""
    est, c = compile_estimator(config, NAME)
    _, inputs = synthetic((1.9, -0.905, 8e-6), samples=50)
    outputs, states = c.run(inputs)
    i = {n: est.states.index(n) for n in est.states.names}
    R, Q = config.settings(NAME)["measurement_noise"], config.settings(NAME)["model_noise"]
    for k in (1, 10, 40):
        s = states[k]
        A = np.array([[s[i["a1"]], s[i["a2"]], ], [1.0, 0.0]])
        P = np.array([[s[i["P_x_1_x_1"]], s[i["P_x_1_x_2"]]], [s[i["P_x_1_x_2"]], s[i["P_x_2_x_2"]]]])
        P_pred = A @ P @ A.T + np.diag([Q, 0.0])
        assert outputs[k, est.outputs.index("gain")] == pytest.approx(
            P_pred[0, 0] / (P_pred[0, 0] + R), rel=1e-12)
        prediction = s[i["a1"]] * s[i["x_1"]] + s[i["a2"]] * s[i["x_2"]] + s[i["b_mz"]] * s[i["mz_prev"]]
        gain = P_pred[0, 0] / (P_pred[0, 0] + R)
        assert outputs[k, 0] == pytest.approx(prediction + gain * (inputs[k, 2] - prediction), rel=1e-12)


def test_unstable_update_is_projected_onto_the_stability_radius(config):
    """E5: parameters pushed outside radius 0.999 are scaled back onto it, status bit set."""
    est, c = compile_estimator(config, NAME)
    state = c.run(np.array([[0.0, 20.0, 0.0, 0.0]]))[1][0]
    state[est.states.index("a1")], state[est.states.index("a2")] = 2.2, -1.1
    state[est.states.index("x_1")], state[est.states.index("x_2")] = 0.2, 0.1
    _, output = c.step(state, np.array([0.0, 20.0, 0.3, 0.0]))
    a1, a2 = output[est.outputs.index("a1")], output[est.outputs.index("a2")]
    rho = max(abs(np.roots([1.0, -a1, -a2])))
    assert rho == pytest.approx(0.999, rel=1e-9)
    assert int(output[-1]) & status.PARAMETERS_PROJECTED


def test_invalid_gyro_predicts_only_and_invalid_moment_counts_as_zero(config):
    est, c = compile_estimator(config, NAME)
    _, inputs = synthetic((1.9, -0.905, 8e-6), samples=40)
    inputs[20, 2] = np.nan
    inputs[30, 3] = np.inf
    outputs, states = c.run(inputs)
    theta = [est.states.index(n) for n in ("a1", "a2", "b_mz")]
    assert outputs[20, est.outputs.index("gain")] == 0.0
    assert np.array_equal(states[21, theta], states[20, theta])      # KF2 skipped
    assert int(outputs[20, -1]) == status.INVALID_INPUT and np.isfinite(outputs[20, 0])
    assert states[31, est.states.index("mz_prev")] == 0.0
    assert int(outputs[30, -1]) == status.INVALID_INPUT
    assert np.all(np.isfinite(outputs))


def test_low_speed_pauses_the_parameter_filter(config):
    est, c = compile_estimator(config, NAME)
    _, inputs = synthetic((1.9, -0.905, 8e-6), samples=60)
    inputs[30:, 1] = 2.0
    outputs, states = c.run(inputs)
    theta = [est.states.index(n) for n in ("a1", "a2", "b_mz")]
    assert np.array_equal(states[60, theta], states[31, theta])
    assert np.all(outputs[30:, -1].astype(int) == status.LOW_SPEED)
    assert not np.array_equal(states[30, theta], states[5, theta])   # it was adapting before


def test_a_log_without_mz_runs_as_with_zero_moment(config):
    from vsegen.harness.host.run_log import run_estimator

    log = Case.of("dlc", speed_kmh=80.0).simulate(config, 100.0)
    assert "mz" not in log
    with_zeros = Log({**log.columns, "mz": np.zeros(len(log))}, "zeros")
    a, b = run_estimator(config, NAME, log), run_estimator(config, NAME, with_zeros)
    assert np.array_equal(a["r"], b["r"]) and np.all(np.isfinite(a["r"]))


@pytest.mark.parametrize("case", [Case.of("dlc", speed_kmh=80.0, yaw_moment=1000.0),
                                  Case.of("sine_steer", yaw_moment=1000.0)])
@pytest.mark.parametrize("exogenous, max_lag", [("mz", 2), ("mz_delta", 1)])
def test_filtered_yaw_rate_beats_the_gyro(variant, case, exogenous, max_lag):
    """§4 acceptance: RMSE(x) < RMSE(gyro); the cross-correlation with the truth peaks at lag
    0 +- 1 sample with the steer angle as input (E2). The patent's form (mz only) cannot explain
    steer-induced yaw and lags by 2 samples (20 ms) on these manoeuvres: measured, not hidden."""
    from vsegen.harness.host.run_log import run_estimator

    config = variant(f"estimator.{NAME}", exogenous=exogenous)
    log = case.simulate(config, 100.0)
    estimate = run_estimator(config, NAME, log)["r"]
    truth = log["r_ref"]
    assert np.sqrt(np.mean((estimate - truth) ** 2)) < np.sqrt(np.mean((log["r"] - truth) ** 2))
    lags = np.arange(-10, 11)
    centred = estimate - estimate.mean(), truth - truth.mean()
    correlation = [np.dot(centred[0][10 + k:len(truth) - 10 + k], centred[1][10:len(truth) - 10])
                   for k in lags]
    assert abs(lags[int(np.argmax(correlation))]) <= max_lag
