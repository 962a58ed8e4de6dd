"""Seed 002's UKF and adaptive UKF: pair arithmetic, the UT weights and statistics, the unrolled
Cholesky and its repair, the 3-DOF HSRI model's signs and limits, Sage-Husa, the hold rule and the
non-positive-definite repair provoked by an input sequence, on the generated C (double and float)
and the reference. Equivalence over every scenario is in test_equivalence (verify)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.reference import REFERENCES
from vsegen.harness.reference.loop import run_reference
from vsegen.harness.sim.scenarios import VERIFICATION_SET, Case
from vsegen.harness.verify.compare import as_seen_by
from vsegen.harness.verify.equivalence import verify_estimator
from vsegen.model import input_monitors, status, three_dof, unscented
from vsegen.model.bicycle import GRAVITY
from vsegen.model.calibration import baked
from vsegen.model.estimators import DEFINITIONS, aukf
from vsegen.model.increments import Pair, fmax, lift, sqrt
from vsegen.model.params import ParameterError


def pair_function(f):
    """CasADi function (x, s) -> (F(x), odd, even) of f in pair arithmetic."""
    x, s = ca.SX.sym("x"), ca.SX.sym("s")
    result = lift(f(Pair(x, s, ca.SX(0))))
    return ca.Function("f", [x, s], [result.base, result.odd, result.even])


@pytest.mark.parametrize("x, s", [(1.7, 1e-3), (-0.4, 2e-2), (3.0, 1e-6)])
def test_pair_arithmetic_is_exact_on_a_cubic_and_a_quotient(x, s):
    base, odd, even = (float(v) for v in pair_function(lambda z: z * z * z)(x, s))
    assert base == pytest.approx(x ** 3, rel=1e-15)
    assert odd == pytest.approx(3 * x * x * s + s ** 3, rel=1e-14)     # exact odd part
    assert even == pytest.approx(3 * x * s * s, rel=1e-14)             # exact, not a difference
    f = lambda z: sqrt(z * z + 2.0) / (z + 5.0)                        # noqa: E731
    g = lambda z: np.sqrt(np.longdouble(z) ** 2 + 2) / (np.longdouble(z) + 5)  # noqa: E731
    _, odd, even = (float(v) for v in pair_function(f)(x, s))
    plus, minus, centre = g(x + s), g(x - s), g(x)
    assert odd == pytest.approx(float((plus - minus) / 2), rel=1e-9)
    assert even == pytest.approx(float((plus + minus) / 2 - centre), rel=1e-6, abs=1e-18)


def test_pair_fmax_switching_inside_the_pair_gives_the_two_values():
    _, odd, even = (float(v) for v in pair_function(lambda z: fmax(z, 0.5))(0.5, 0.1))
    assert (0.5 + odd + even, 0.5 - odd + even) == pytest.approx((0.6, 0.5), abs=1e-15)


def test_ut_weights_are_the_spec_numbers():
    w = unscented.Weights(6, 0.001, 2.0, 0.0)
    assert w.spread == pytest.approx(6.0e-6, rel=1e-12)
    assert w.mean0 == pytest.approx(-999999.0, rel=1e-12)
    assert w.cov0 == pytest.approx(-999996.000001, rel=1e-12)   # the spec rounds to -999 996.0
    assert w.other == pytest.approx(83333.33, rel=1e-6)
    assert w.mean0 + 12 * w.other == pytest.approx(1.0, abs=1e-9)


def test_statistics_equal_the_printed_weighted_sums():
    """With a well-conditioned alpha the increment form equals the printed sums (10)-(12)."""
    weights = unscented.Weights(3, 0.5, 2.0, 0.0)
    rng = np.random.default_rng(3)
    x0, A = rng.normal(size=3), rng.normal(size=(3, 3))
    P0 = A @ A.T + 0.1 * np.eye(3)

    def F(v):
        return [v[0] * v[1], v[1] / (v[2] + 3.0), sqrt(v[0] * v[0] + 1.0) + v[2]]

    x, P = ca.SX.sym("x", 3), ca.SX.sym("P", 3, 3)
    L, _ = unscented.cholesky_repaired(P)
    centre = ca.vertcat(*F([x[i] for i in range(3)]))
    pairs = []
    for offset in unscented.sigma_offsets(L, weights):
        moved = F([Pair(x[i], offset[i], ca.SX(0)) for i in range(3)])
        pairs.append((ca.vertcat(*[lift(v).odd for v in moved]),
                      ca.vertcat(*[lift(v).even for v in moved])))
    mean, cov = (np.array(v) for v in ca.Function("s", [x, P], list(
        unscented.statistics(centre, pairs, weights)))(x0, P0))
    f_num = lambda v: np.array([v[0] * v[1], v[1] / (v[2] + 3), np.sqrt(v[0] ** 2 + 1) + v[2]])  # noqa: E731
    root = np.linalg.cholesky(P0 + 1e-9 * np.diag(np.maximum(1, np.diag(P0)))) * np.sqrt(weights.spread)
    points = [x0] + [x0 + root[:, i] for i in range(3)] + [x0 - root[:, i] for i in range(3)]
    Y = np.array([f_num(p) for p in points]).T
    wm = np.array([weights.mean0] + [weights.other] * 6)
    wc = np.array([weights.cov0] + [weights.other] * 6)
    y = Y @ wm
    assert mean.ravel() == pytest.approx(y, rel=1e-12)
    assert cov == pytest.approx(((Y - y[:, None]) * wc) @ (Y - y[:, None]).T, rel=1e-10)


def test_cholesky_factors_and_repairs():
    P = ca.SX.sym("P", 3, 3)
    chol = ca.Function("c", [P], list(unscented.cholesky_repaired(P)))
    good = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]])
    L, repaired = chol(good)
    assert float(repaired) == 0
    assert np.array(L) @ np.array(L).T == pytest.approx(good + 1e-9 * np.diag(np.diag(good)),
                                                        rel=1e-12)
    bad = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, -3.0]])   # indefinite
    L, repaired = chol(bad)
    assert float(repaired) == 1
    assert np.array(L) == pytest.approx(np.diag(np.sqrt([1.0 + 1e-9, 1.0 + 1e-9, 1e-9])))
    L, repaired = chol(np.zeros((3, 3)))                                   # the paper's P_0 = 0
    assert float(repaired) == 0 and np.array(L) == pytest.approx(np.sqrt(1e-9) * np.eye(3))


def model_step(config, name="ukf"):
    """Function (X, delta, r omega) -> X_k+1 of the estimator's process model."""
    model = aukf.process_model(baked(config), name)
    x, delta, w = ca.SX.sym("x", 6), ca.SX.sym("d"), ca.SX.sym("w", 4)
    nxt = model.step([x[i] for i in range(6)], delta, ca.cos(delta), ca.sin(delta),
                     [w[i] for i in range(4)] if model.wheel_speeds else None)
    return ca.Function("F", [x, delta, w], [ca.vertcat(*nxt)]), model


def test_process_model_signs_and_linear_range(config):
    F, model = model_step(config)
    u = 20.0
    rolling = np.full(4, u)
    nxt = np.array(F([u, 0, 0, 0, 0, 0], 0.01, rolling)).ravel()
    assert nxt[5] > 0 and nxt[3] > 0            # left steer: lateral force and yaw moment to the left
    assert nxt[0] == pytest.approx(u) and nxt[1] == 0 and nxt[2] == 0
    # small steer, free rolling: F_y,f = C_y tan(alpha) per tyre, so a_y = C_f delta / m
    assert nxt[5] == pytest.approx(config.vehicle["cornering_stiffness_front"] * np.sin(0.01)
                                   * np.cos(0.01) / config.vehicle["mass"], rel=1e-3)
    driving = np.array(F([u, 0, 0, 0, 0, 0], 0.0, rolling * 1.01)).ravel()
    assert driving[4] == pytest.approx(4 * model.longitudinal * 0.01 / 1.01 / model.mass, rel=1e-9)


def test_hsri_saturates_at_the_friction_limit(config):
    F, model = model_step(config)
    v = config.vehicle
    for slip in (0.3, 1.0, 3.0):                # lateral speed of the whole car: every tyre slides
        nxt = np.array(F([20.0, -20.0 * slip, 0, 0, 0, 0], 0.0, np.full(4, 20.0))).ravel()
        assert nxt[5] <= model.friction * GRAVITY * (1 + 1e-12)
    far = np.array(F([20.0, -200.0, 0, 0, 0, 0], 0.0, np.full(4, 20.0))).ravel()
    assert far[5] == pytest.approx(model.friction * GRAVITY, rel=0.02)
    loads = ca.Function("l", [], [ca.vertcat(*model.loads(0.0, 0.0))])()
    assert float(ca.sum1(loads["o0"])) == pytest.approx(v["mass"] * GRAVITY, rel=1e-12)
    lifted = float(ca.Function("l", [], [model.loads(0.0, 25.0)[0]])()["o0"])
    assert lifted < -1000.0                       # the inner wheel would carry a negative load...
    grip = float(three_dof.adhesion(ca.SX(model.friction * lifted)))
    f_x, f_y = (float(f) for f in ca.Function("t", [], list(model.tyre(0.2, 0.1, lifted, 4e4)))().values())
    assert grip < 5.0 and np.hypot(f_x, f_y) <= grip * (1 + 1e-12)   # ...so its tyre has a few N of grip


def test_adhesion_is_smooth_where_a_wheel_lifts():
    """The guard max(mu F_z, 1 N) rounded over ADHESION_ROUNDING: within W/2 of the kinked guard,
    equal to mu F_z far above it, and its even part over a pair of sigma points straddling the
    bend is second order (1/2 f'' s^2), so the rounding of the load's base does not enter it at
    first order (the kink did, amplified by the UT's 1/(alpha^2 (n + kappa)))."""
    grips = np.linspace(-3000.0, 3000.0, 601)
    values = np.array([float(three_dof.adhesion(ca.SX(g))) for g in grips])
    kinked = np.maximum(grips, three_dof.LOAD_GUARD)
    assert np.all(values >= kinked) and np.all(values - kinked <= three_dof.ADHESION_ROUNDING / 2)
    assert float(three_dof.adhesion(ca.SX(3000.0))) == pytest.approx(3000.0, abs=1.0)
    _, odd, even = (float(v) for v in pair_function(three_dof.adhesion)(three_dof.LOAD_GUARD, 2.0))
    W = three_dof.ADHESION_ROUNDING
    assert odd == pytest.approx(1.0, rel=1e-3)                      # f' = 1/2 at the bend
    assert even == pytest.approx(2.0 ** 2 / (4 * W), rel=1e-3)     # 1/2 f'' s^2, f'' = 1/(2W)


def steady_turn(config, est, n=600, vx=20.0, delta=0.02):
    """Noise-free steady cornering: the same sample n times."""
    v = config.vehicle
    r = vx * delta / v["wheelbase"]
    half = v["track_width"] / 2 * r
    row = {"delta": delta, "vx": vx, "ax": 0.0, "ay": vx * r, "r": r,
           "omega_fl": (vx - half) / v["wheel_radius"], "omega_fr": (vx + half) / v["wheel_radius"],
           "omega_rl": (vx - half) / v["wheel_radius"], "omega_rr": (vx + half) / v["wheel_radius"]}
    return np.tile([row[k] for k in est.inputs.names], (n, 1))


@pytest.mark.parametrize("real", ["double", "float"])
def test_non_positive_definite_covariance_is_repaired_and_flagged(variant, real):
    """The classic Sage-Husa failure: noise-free steady driving makes the bracket of (15b)
    negative. Without the floor Q turns negative, the covariance loses positive definiteness and
    the repair must catch it, in C and reference alike, with finite states; with the floor (the
    default) it never happens."""
    literal = variant("estimator.aukf", noise_safeguard="none")
    est, c = compile_estimator(literal, "aukf", real)
    inputs = as_seen_by(real, steady_turn(literal, est))
    out, states = c.run(inputs)
    repaired = (out[:, -1].astype(int) & status.COVARIANCE_REPAIRED) > 0
    assert repaired.sum() > 100 and np.all(np.isfinite(states)) and np.all(np.isfinite(out))
    assert min(states[-1, est.states.index(f"qvar_{n}")] for n in aukf.X_NAMES) < 0
    ref_out, _ = run_reference(REFERENCES["aukf"], literal, inputs)
    assert np.array_equal(ref_out[:, -1], out[:, -1])                # same steps flagged
    assert out[:, 0] == pytest.approx(ref_out[:, 0], abs=1e-9 if real == "double" else 1e-4)
    default = variant("estimator.aukf")
    est, c = compile_estimator(default, "aukf", real)
    out, _ = c.run(as_seen_by(real, steady_turn(default, est)))
    assert not np.any(out[:, -1].astype(int) & status.COVARIANCE_REPAIRED)


def test_sage_husa_keeps_q_between_floor_and_ceiling(config):
    est, c = compile_estimator(config, "aukf")
    log = Case.of("dlc", speed_kmh=120.0).simulate(config, 100.0)
    _, states = c.run(log.matrix(est.inputs.names))
    s = config.settings("aukf")
    Q = states[:, [est.states.index(f"qvar_{n}") for n in aukf.X_NAMES]]
    assert np.all(Q >= 1e-3 * np.array(s["process_noise"]) * (1 - 1e-12))
    assert np.all(Q <= np.array(s["process_noise_max"]))
    fading = states[:, est.states.index("fading")]
    assert fading[0] == s["forgetting_factor"]
    assert fading[10] == pytest.approx(s["forgetting_factor"] ** 11, rel=1e-12)
    assert Q[1:, 3].max() > 100 * s["process_noise"][3]        # it adapts: the paper's Q is too small


@pytest.mark.parametrize("name", ["ukf", "aukf"])
def test_abusive_inputs_stay_finite(config, name):
    est, c = compile_estimator(config, name)
    log = Case.of("dlc", speed_kmh=80.0).simulate(config, 100.0)
    inputs = log.matrix(est.inputs.names)
    column = est.inputs.index("ay")
    inputs[300:500:2, column], inputs[301:500:2, column] = 25.0, -25.0     # plausible, absurd
    out, states = c.run(inputs)
    assert np.all(np.isfinite(states)) and np.abs(states).max() < 1e12


def test_low_speed_restarts_from_the_current_sample_and_invalid_input_holds(config):
    est, c = compile_estimator(config, "ukf")
    log = Case.of("low_speed").simulate(config, 100.0)
    inputs = log.matrix(est.inputs.names)
    out, states = c.run(inputs)
    low = (out[:, -1].astype(int) & status.LOW_SPEED) > 0
    assert low.any() and np.all(out[low, 0] == 0.0)
    k = np.flatnonzero(low)[5]
    holding = est.states.index("hold_reason")
    assert np.array_equal(np.delete(states[k + 1], holding), np.delete(states[k], holding))
    assert states[k + 1, holding] == 2                               # held, marked low speed
    resumed = np.flatnonzero(low[:-1] & ~low[1:])[0] + 1             # restarts from this sample
    expected, _ = est.step(est.init(inputs[resumed]), inputs[resumed])
    watching = [est.states.index(s.name) for s in input_monitors.states(config.settings("ukf"), est.inputs.names)]
    assert np.delete(states[resumed + 1], watching) == pytest.approx(
        np.delete(np.array(expected).ravel(), watching), rel=1e-12, abs=1e-15)
    assert abs(out[resumed, 1] - inputs[resumed, est.inputs.index("vx")]) < 0.2
    bad = Case.of("invalid_inputs").simulate(config, 100.0)
    inputs = bad.matrix(est.inputs.names)
    out, states = c.run(inputs)
    k = np.flatnonzero(~np.isfinite(inputs[:, est.inputs.index("omega_fl")]))[0]
    assert out[k, -1] == status.INVALID_INPUT and states[k + 1, holding] == 1
    assert np.array_equal(np.delete(states[k + 1], holding), np.delete(states[k], holding))


def test_wheel_speed_mode_tracks_speed_and_free_rolling_does_not_need_wheels(config, variant):
    """Free rolling reads no wheel speed for its model; with the yaw-rate check on, only the
    checked (rear) axle's."""
    log = Case.of("dlc", speed_kmh=120.0).simulate(config, 100.0)
    est, c = compile_estimator(config, "ukf")
    out, _ = c.run(log.matrix(est.inputs.names))
    assert np.abs(out[:, 1] - log["vx_ref"]).max() < 0.2
    free = variant("estimator.ukf", longitudinal_force="free_rolling")
    assert [n for n in compile_estimator(free, "ukf")[0].inputs.names if n.startswith("omega")] == [
        "omega_rl", "omega_rr"]
    free = variant("estimator.ukf", longitudinal_force="free_rolling", wheel_check_limit=0.0)
    est, c = compile_estimator(free, "ukf")
    assert not any(n.startswith("omega") for n in est.inputs.names)
    out, states = c.run(log.matrix(est.inputs.names))
    assert np.all(np.isfinite(out))


@pytest.mark.parametrize("edit, message", [
    ({"forgetting_factor": 0.999}, "forgetting_factor = 0.999: expected a number between 0.95 and 0.99"),
    ({"process_noise": [1e-5, 1e-5]}, "expected a list of 6 numbers > 0"),
    ({"process_noise_max": [1e-6, 1, 1, 1, 1, 1]}, "expected every entry above its process_noise entry"),
])
def test_settings_errors_are_one_line(variant, edit, message):
    with pytest.raises(ParameterError) as error:
        variant("estimator.aukf", **edit)
    assert message in str(error.value) and "\n" not in str(error.value)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ukf", "aukf"])
def test_float_code_keeps_the_speed_within_a_millimetre_per_second(config, name):
    """The pair arithmetic keeps float32 within the float tolerance at alpha = 0.001 (the spec's
    C6 reports tenths of a m/s lost on u by the printed weighted sums)."""
    results = verify_estimator(config, name, real="float")
    assert len(results) == len(VERIFICATION_SET)
    for result in results:
        assert result.ok, result
        assert result.outputs[1].name == "vx" and result.outputs[1].max_abs < 1e-3


def test_an_estimate_outside_the_envelope_restarts_the_filter(config, variant):
    """Beyond the spec: when u leaves the measured v_x by more than restart_speed_error the filter
    restarts from that sample and says so; with 0 it never does."""
    est, c = compile_estimator(config, "ukf")
    log = Case.of("dlc", speed_kmh=80.0).simulate(config, 100.0)
    inputs = log.matrix(est.inputs.names)
    inputs[300:, est.inputs.index("vx")] += 8.0          # the ECU speed jumps away from the wheels
    out, states = c.run(inputs)
    flagged = (out[:, -1].astype(int) & status.FILTER_RESTARTED) > 0
    assert not flagged[:300].any() and flagged[300]
    restart = np.array(est.init(inputs[300])).ravel()
    restart[est.states.index("hold_reason")] = 0
    assert states[301][est.states.index("residual")] > 0.0    # the consistency monitor's mean carries on,
    block = DEFINITIONS["ukf"].monitors(config.settings("ukf"))
    for entry in (*block.states, *block.segment):                  # as every check's entries do
        restart[est.states.index(entry.name)] = states[301][est.states.index(entry.name)]
    assert states[301] == pytest.approx(restart, rel=1e-12, abs=1e-15)
    assert out[300, 1] == inputs[300, est.inputs.index("vx")] and out[300, 0] == 0.0
    never = variant("estimator.ukf", restart_speed_error=0.0, restart_sideslip=0.0,
                    residual_window=0.0)
    est, c = compile_estimator(never, "ukf")
    out, _ = c.run(inputs)
    assert not np.any(out[:, -1].astype(int) & status.FILTER_RESTARTED)
