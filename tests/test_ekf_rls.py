"""Seed 001's EKF with RLS stiffness: wheel loads, the RLS block (convergence, wind-up bound,
clamp), the filtered derivative against scipy, the integral method alone, the plain-EKF variant,
the hold rule. On the generated C (double) and the symbolic blocks; equivalence to the reference
over every scenario is in verify."""

from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest
import scipy.signal

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.verify.equivalence import verify_estimator
from vsegen.model import filters, status
from vsegen.model.bicycle import GRAVITY
from vsegen.model.estimators import ekf_rls
from vsegen.model.params import parse_vehicle

NAME = "ekf_rls"


def run(config, case, rate=100.0):
    config = config.with_sample_time(1.0 / rate) if rate != 100.0 else config
    est, compiled = compile_estimator(config, NAME)
    log = case.simulate(config, rate)
    outputs, states = compiled.run(log.matrix(est.inputs.names))
    return est, log, outputs, states


def test_wheel_loads_sum_to_the_weight_and_shift_with_acceleration(config):
    v = config.vehicle
    ax, ay = ca.SX.sym("ax"), ca.SX.sym("ay")
    loads = ca.Function("loads", [ax, ay], [ca.vertcat(*ekf_rls.wheel_loads(v, ax, ay).values())])
    weight = v["mass"] * GRAVITY
    for a_x, a_y in ((0.0, 0.0), (2.0, 4.0), (-3.0, -5.0)):
        fl, fr, rl, rr = np.array(loads(a_x, a_y)).ravel()
        assert fl + fr + rl + rr == pytest.approx(weight, rel=1e-12)
        assert np.sign(fr - fl) == np.sign(a_y) or a_y == 0          # a left turn loads the right
    fl0, fr0, rl0, rr0 = np.array(loads(0.0, 0.0)).ravel()
    fl1, fr1, rl1, rr1 = np.array(loads(3.0, 0.0)).ravel()
    assert rl1 + rr1 > rl0 + rr0 and fl1 + fr1 < fl0 + fr0           # acceleration loads the rear
    assert min(np.array(loads(0.0, 30.0)).ravel()) == pytest.approx(0.05 * weight / 4)  # floor


def test_rls_converges_to_consistent_data_and_bounds_its_covariance():
    X, P = ca.SX.sym("X", 2), ca.SX.sym("P", 2, 2)
    y, A = ca.SX.sym("y", 2), ca.SX.sym("A", 2, 2)
    update = ca.Function("rls", [X, P, y, A], list(ekf_rls.rls_update(X, P, y, A, 0.9, 1e4)))
    rng = np.random.default_rng(1)
    truth = np.array([12.0, 20.0])
    x, p = np.array([17.8, 17.8]), 100.0 * np.eye(2)
    for _ in range(300):
        regressor = np.diag(rng.uniform(0.005, 0.05, 2))
        x, p = (np.array(v) for v in update(x, p, regressor @ truth, regressor))
        x = x.ravel()
    assert x == pytest.approx(truth, rel=1e-6)
    for _ in range(200):                                   # tiny regressor: P / tau grows ...
        x, p = (np.array(v) for v in update(x.ravel(), p, np.zeros(2), 1e-9 * np.eye(2)))
    assert np.trace(p) == pytest.approx(1e4, rel=1e-9)      # ... up to the bound, not for ever


def test_filtered_derivative_matches_scipy():
    T, tau = 0.001, 0.02
    n, d = filters.tustin_derivative(tau, T)
    (b0, b1), (_, a1) = scipy.signal.bilinear([1.0, 0.0], [tau, 1.0], fs=1.0 / T)
    assert (n, -n, d) == pytest.approx((b0, b1, a1), rel=1e-12)


def test_integral_only_is_the_free_integration_of_the_spec(variant):
    """weighting = integral_only: beta_k = beta_k-1 + T((a_y cos b - a_x sin b) / (vx / cos b) - r)
    [36], from beta_0 = 0."""
    config = variant(f"estimator.{NAME}", weighting="integral_only", roll_gradient=0.0)
    est, log, outputs, _ = run(config, Case.of("dlc", speed_kmh=80.0))
    beta = 0.0
    expected = []
    for vx, ax, ay, r in log.matrix(("vx", "ax", "ay", "r")):
        beta = beta + 0.01 * ((ay * np.cos(beta) - ax * np.sin(beta)) / (vx / np.cos(beta)) - r)
        expected.append(beta)
    assert np.allclose(outputs[:, 0], expected, rtol=1e-9, atol=1e-12)
    assert np.all(outputs[:, est.outputs.index("weight")] == 1.0)


def test_plain_ekf_keeps_the_vehicle_file_stiffness_and_never_blends(variant):
    config = variant(f"estimator.{NAME}", stiffness="constant")
    est, _, outputs, _ = run(config, Case.of("dlc", speed_kmh=80.0))
    assert np.all(outputs[:, est.outputs.index("c_front")] == config.vehicle["cornering_stiffness_front"])
    assert np.all(outputs[:, est.outputs.index("weight")] == 0.0)
    assert np.array_equal(outputs[:, 0], outputs[:, est.outputs.index("beta_ekf")])


def test_stiffness_stays_inside_its_clamp_and_the_weight_in_0_1(config):
    est, _, outputs, states = run(config, Case.of("dlc", speed_kmh=80.0, mu=0.5))
    c0 = ekf_rls.nominal_c0(config.vehicle)
    s = config.settings(NAME)
    for name in ("c0_1", "c0_2"):
        values = states[:, est.states.index(name)]
        assert values.min() >= s["stiffness_min"] * c0 - 1e-12
        assert values.max() <= s["stiffness_max"] * c0 + 1e-12
    weight = outputs[:, est.outputs.index("weight")]
    assert weight.min() >= 0.0 and weight.max() <= 1.0


def test_tyres_past_their_linear_range_raise_beyond_linear_range(vehicle_text):
    """linear_range and stiffness_drop_limit (beyond the paper): the bit follows |a_y| and the learned
    stiffness exactly as documented, the C equals the reference, and both off raise nothing."""
    text = with_settings(vehicle_text, "estimator.ekf_rls", stiffness_drop_limit=0.7, linear_range=6.0,
                         linear_range_hold=0.0)
    config = parse_vehicle(text, "flagged.toml", "c_class")
    case = Case.of("dlc", speed_kmh=100.0, mu=0.8)
    est, log, outputs, _ = run(config, case)
    flagged = (outputs[:, est.outputs.index("status")].astype(int) & status.BEYOND_LINEAR_RANGE) > 0
    ay = log["ay"] / (1 + GRAVITY * config.settings(NAME)["roll_gradient"])
    c_front, c_rear = (outputs[:, est.outputs.index(n)] for n in ("c_front", "c_rear"))
    v = config.vehicle
    expected = ((np.abs(ay) > 6.0) | (c_front < 0.7 * v["cornering_stiffness_front"])
                | (c_rear < 0.7 * v["cornering_stiffness_rear"]))
    assert flagged.any() and (c_front < 0.7 * v["cornering_stiffness_front"])[np.abs(ay) <= 6.0].any()
    np.testing.assert_array_equal(flagged, expected)
    (result,) = verify_estimator(config, NAME, cases=(case,))
    assert result.ok, result
    off = with_settings(vehicle_text, "estimator.ekf_rls", stiffness_drop_limit=0.0,   # shipped: 0.65, 6 m/s^2
                        linear_range=0.0)
    _, _, plain, _ = run(parse_vehicle(off, "plain.toml", "c_class"), case)
    assert not np.any(plain[:, est.outputs.index("status")].astype(int) & status.BEYOND_LINEAR_RANGE)


def test_low_speed_holds_every_state(config):
    est, log, outputs, states = run(config, Case.of("low_speed"))
    held = outputs[:, -1].astype(int) & status.LOW_SPEED > 0
    assert held.any()
    k = int(np.argmax(held))
    assert np.all(outputs[held, 0] == 0.0)
    kept = [i for i, name in enumerate(est.states.names) if name != "holding"]
    assert np.array_equal(states[k + 1, kept], states[k, kept])  # everything but the flag is kept


@pytest.mark.parametrize("edit, message", [
    ("indicator_high = 2.0 ", "indicator_high = 0.1: expected a rate above indicator_low = 0.5 1/s"),
    ("stiffness_max = 1.5", "stiffness_max = 0.1: expected a factor above stiffness_min = 0.3"),
])
def test_inverted_bands_are_one_line_errors(vehicle_text, edit, message):
    from vsegen.model.params import ParameterError

    key = edit.split(" = ")[0]
    with pytest.raises(ParameterError, match=re.escape(message)):
        parse_vehicle(vehicle_text.replace(edit, f"{key} = 0.1 "), "bad.toml", "c_class")


@pytest.fixture(scope="module")
def dlc_at_1khz(variant):
    """(estimator, log, outputs, states) of the vehicle file's ekf_rls (kinematic_slip) and of the
    paper's literal regressor on the 80 km/h DLC, mu 1.0, at the paper's 1 kHz."""
    from bench.seed001 import LITERAL

    runs = {}
    for label, keys in (("kinematic", {}), ("literal", LITERAL)):
        runs[label] = run(variant(f"estimator.{NAME}", **keys), Case.of("dlc", speed_kmh=80.0), 1000.0)
    return runs


def test_kinematic_slip_stiffness_tracks_the_truth_plant(dlc_at_1khz):
    """Over the DLC the estimated axle stiffness follows the truth plant's secant stiffness F_y / alpha
    (bench.seed001): on average within 10 %, correlated, and not pinned at a clamp; the paper's literal
    regressor (B2: biased by alpha_f / |alpha_f - alpha_r|) does not."""
    from bench.seed001 import secant_stiffness

    def tracking(label, key):
        est, log, outputs, _ = dlc_at_1khz[label]
        truth = secant_stiffness(est.parameters.config, log)[key == "c_rear"]
        known = np.isfinite(truth)
        estimate = outputs[known, est.outputs.index(key)]
        error = estimate / truth[known] - 1.0
        return abs(error.mean()), np.corrcoef(estimate, truth[known])[0, 1]

    for key in ("c_front", "c_rear"):
        bias, correlation = tracking("kinematic", key)
        assert bias < 0.10 and correlation > 0.5, (key, bias, correlation)
        literal_bias, literal_correlation = tracking("literal", key)
        assert literal_bias > 0.2 or literal_correlation < 0.3, (key, literal_bias, literal_correlation)


def test_kinematic_slip_low_passes_and_reseeds_only_while_lambda_is_zero(dlc_at_1khz):
    """States of kinematic_slip: each low-passed signal is y_k = y_k-1 + (1 - exp(-T / tau_d))
    (x_k - y_k-1) of its input (a_y roll-corrected); beta_kin is one Euler step of the integral
    method from the fused beta while the previous D <= D1 (lambda = 0), else from itself. Row k + 1
    of ``states`` is the state after input k."""
    est, log, outputs, states = dlc_at_1khz["kinematic"]
    config = est.parameters.config
    s, T = config.settings(NAME), config.sample_time
    column = {n: states[:, i] for i, n in enumerate(est.states.names)}
    u = {n: log.matrix(est.inputs.names)[:, i] for i, n in enumerate(est.inputs.names)}
    ay = u["ay"] / (1.0 + GRAVITY * s["roll_gradient"])
    share = 1.0 - np.exp(-T / s["derivative_time_constant"])
    for name, raw in (("ax_f", u["ax"]), ("ay_f", ay), ("r_f", u["r"]), ("delta_f", u["delta"])):
        expected = scipy.signal.lfilter([share], [1.0, share - 1.0], raw,
                                        zi=[(1.0 - share) * column[name][0]])[0]
        assert np.allclose(column[name][1:], expected, rtol=1e-9, atol=1e-12), name
    seeded = column["indicator"][:-1] <= s["indicator_low"]
    start = np.where(seeded, column["beta"][:-1], column["beta_kin"][:-1])
    step = start + T * ((ay * np.cos(start) - u["ax"] * np.sin(start)) / (u["vx"] / np.cos(start))
                        - u["r"])
    assert np.allclose(column["beta_kin"][1:], step, rtol=1e-9, atol=1e-14)
    assert seeded.any() and not seeded.all()          # both branches are exercised on the DLC
