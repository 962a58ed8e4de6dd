"""The Kalman filter's saturating tyre model (model.tyres, tyre_model = "saturating"): its Jacobians,
its linear limit, its bound, its C against the reference, and what it buys on the real race lap."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from locations import REVS

from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.reference import bicycle_kf
from vsegen.harness.reference import kf2dof as reference
from vsegen.harness.reference.loop import run_reference
from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.verify.equivalence import verify_estimator
from vsegen.harness.verify.fuzz import fuzz_estimator
from vsegen.model.bicycle import GRAVITY
from vsegen.model.calibration import baked
from vsegen.model.estimators.kf2dof import dynamic_update
from vsegen.model.params import parse_vehicle
from vsegen.model.tyres import Friction, saturating_bicycle


def saturating(text: str, friction=(1.0, 1.0), tables=("kf2dof",), name="c_class", estimated=False) -> str:
    """``text`` with the saturating tyre model and ``friction`` in each of ``tables`` (set where the
    table has them, added where it has not), the friction also estimated as the shipped fusion
    estimates it where ``estimated``."""
    estimate = {"friction_noise": 0.01, "friction_time": 1.0} if estimated else {}
    for table in tables:
        body = text[text.index(f"[estimator.{table}]\n"):].split("\n[", 1)[0]
        if "\ntyre_model = " in body:
            text = with_settings(text, f"estimator.{table}", tyre_model="saturating", tyre_friction=list(friction))
        else:
            text = text.replace(f"[estimator.{table}]\n", f'[estimator.{table}]\ntyre_model = "saturating"\n'
                                                          f"tyre_friction = {list(friction)}\n", 1)
        if estimate and "\nfriction_noise = " not in body:
            text = text.replace(f"[estimator.{table}]\n", f"[estimator.{table}]\n"
                                + "".join(f"{k} = {v}\n" for k, v in estimate.items()), 1)
    return text


def test_jacobians_are_the_derivatives_of_the_model(config):
    x, delta, vx = ca.SX.sym("x", 2), 0.03, 17.0
    model = saturating_bicycle(config.vehicle, Friction([0.9, 1.1], [0.9, 1.1]), x, delta, vx)
    jacobian = ca.Function("j", [x], [model.A - ca.jacobian(model.f, x),
                                      model.H - ca.jacobian(ca.vertcat(model.ay, x[1]), x)])
    for point in ([0.0, 0.0], [0.4, 0.2], [-1.5, 0.6]):     # linear, near and far beyond the peak
        for gap in jacobian(point):
            assert np.abs(np.array(gap)).max() < 1e-12


def test_the_reference_twin_computes_the_same_model(config):
    x = ca.SX.sym("x", 2)
    axles = Friction([0.8, 1.2], [0.8, 1.2])
    model = ca.Function("m", [x], [saturating_bicycle(config.vehicle, axles, x, 0.05, 12.0).f])
    for point in ([0.1, 0.3], [-0.9, -0.4]):
        f, _, _, _ = bicycle_kf.saturating(config.vehicle, (0.8, 1.2), np.array(point), 0.05, 12.0)
        np.testing.assert_allclose(np.array(model(point)).ravel(), f, rtol=1e-14)


def test_lateral_force_is_bounded_by_the_friction(config):
    """However large the slip, a_y stays within (mu_f F_zf + mu_r F_zr) / m."""
    v = config.vehicle
    l = v["cg_to_front_axle"] + v["cg_to_rear_axle"]
    mu_f, mu_r = 0.7, 0.9
    bound = GRAVITY * (mu_f * v["cg_to_rear_axle"] + mu_r * v["cg_to_front_axle"]) / l
    for vy in (-30.0, -3.0, 3.0, 30.0):
        _, _, ay, _ = bicycle_kf.saturating(v, (mu_f, mu_r), np.array([vy, 0.0]), 0.0, 10.0)
        assert abs(ay) <= bound * (1 + 1e-12)
    _, _, ay, _ = bicycle_kf.saturating(v, (mu_f, mu_r), np.array([-30.0, 0.0]), 0.0, 10.0)
    assert ay == pytest.approx(bound, rel=1e-6)


@pytest.mark.parametrize("method", ["zoh", "euler", "tustin"])
def test_with_unbounded_friction_the_extended_kf_is_the_linear_kf(vehicle_text, method):
    """The EKF's x + Gamma_I f(x) with linear forces is Phi x + Gamma delta, for every method."""
    text = vehicle_text.replace('discretisation = "zoh"', f'discretisation = "{method}"', 1)
    linear = dynamic_update(baked(parse_vehicle(text, "linear.toml", "c_class")))
    extended = dynamic_update(baked(parse_vehicle(saturating(text, friction=(1e6, 1e6)), "sat.toml",
                                                  "c_class")))
    args = dict(x=[0.3, 0.12], P=[0.02, 0.001, 0.003], delta_prev=0.02, vx_prev=18.0, delta=0.025,
                vx=18.2, ay=2.5, r_meas=0.13)
    a, b = linear(**args), extended(**args)
    for key in ("x_next", "P_next", "innovation"):
        np.testing.assert_allclose(np.array(b[key]), np.array(a[key]), rtol=1e-9, atol=1e-15)


KF_ESTIMATORS = ("kf2dof", "switching", "fusion")


@pytest.fixture(scope="module")
def saturating_car(vehicle_text):
    """The default car with saturating tyres and the friction estimate in every Kalman filter, the
    rear's friction below the front's (the model's spin mode amplifies rounding most)."""
    return parse_vehicle(saturating(vehicle_text, (1.0, 0.9), KF_ESTIMATORS, estimated=True), "saturating.toml",
                         "c_class")


VARIANT_KFS = ("kf2dof", "switching")
"""The KF estimators the tests below verify and fuzz on :func:`saturating_car`: kf2dof ships the
linear KF, switching the saturating one with the friction estimate but equal axle frictions (here
the rear's is lower). Fusion and switching are verified in every form and fuzzed as shipped
(tests/test_equivalence.py, tests/test_fuzz.py)."""


@pytest.mark.slow
@pytest.mark.parametrize("name,real,params", [
    ("kf2dof", "double", "baked"), ("kf2dof", "float", "calibratable"), ("switching", "double", "baked")])
def test_generated_c_equals_the_reference_in_every_form(saturating_car, name, real, params):
    """Double baked and the most demanding form, float calibratable, of each estimator running the
    KF on every scenario (every form of all three verified when the option was added); switching's
    float form: below."""
    results = verify_estimator(saturating_car, name, real=real, params=params)
    assert results and all(r.ok for r in results), [r for r in results if not r.ok]


@pytest.mark.slow
def test_switching_with_the_friction_estimate_in_float_on_input_extremes(saturating_car):
    """Float calibratable on input_extremes, where the alternating hand-overs at inputs beyond any
    road keep the friction scale's rounding: within tolerance with the shipped Q_c (5.7e-5 of the
    reference, tolerance 1e-4); with the paper's Q_c = diag(0.25, 0.01) its v_y drifted 1.2e-4."""
    case = next(c for c in VERIFICATION_SET if c.label == "input_extremes")
    (result,) = verify_estimator(saturating_car, "switching", cases=(case,), real="float", params="calibratable")
    assert result.ok, result


@pytest.mark.parametrize("name", ["kf2dof", "switching"])
def test_generated_c_equals_the_reference_after_a_hand_over_from_a_drifted_integrator(saturating_car, name):
    """The scenario with the gyro frozen, where switching hands its KF a kinematic state far beyond
    the tyres' peak (the slope once computed as C (1 - tanh^2) kept only rounding there)."""
    case = next(c for c in VERIFICATION_SET if "freeze=r" in c.label)
    for real in ("double", "float"):
        (result,) = verify_estimator(saturating_car, name, cases=(case,), real=real)
        assert result.ok, result


@pytest.mark.parametrize("name", ["kf2dof", *(pytest.param(n, marks=pytest.mark.slow) for n in VARIANT_KFS[1:])])
@pytest.mark.parametrize("real", ["double", "float"])
def test_a_million_adversarial_steps(saturating_car, name, real):
    report = fuzz_estimator(saturating_car, name, real, 1_000_000, seed=7)
    assert report.ok, report.message


def lap_errors(revs_lap) -> dict[str, float]:
    """beta RMSE (deg) of kf2dof's reference on a hard half minute of the Revs lap's scoring half
    (|a_y| beyond 10 m/s^2), by tyre model and friction, at about the stiffnesses identify finds
    with the reference on the first half."""
    base = with_settings((REVS / "car.toml").read_text(), "vehicle", cornering_stiffness_front=70000.0,
                         cornering_stiffness_rear=125000.0)
    piece = revs_lap.window(555.0, 585.0)
    assert np.abs(piece["ay"]).max() > 10.0
    inputs = piece.matrix(reference.INPUTS)
    variants = {"linear": dict(tyre_model="linear"), "saturating": dict(tyre_friction=[1.05, 1.1]),
                "too low, no floor": dict(tyre_friction=[0.5, 0.5], friction_floor=0.0),
                "too low": dict(tyre_friction=[0.5, 0.5])}
    errors = {}
    for name, settings in variants.items():
        config = parse_vehicle(with_settings(base, "estimator.kf2dof", **settings), "car.toml", "revs")
        outputs, _ = run_reference(reference, config, inputs)
        errors[name] = float(np.degrees(np.sqrt(np.mean((outputs[:, 0] - piece["beta_ref"]) ** 2))))
    return errors


def test_right_at_the_limit_of_the_real_lap_and_never_below_the_measured_friction(revs_lap):
    """The same stiffnesses score a smaller beta error with saturating axles than with linear ones.
    A friction set far too low (0.5 on a dry track the car drives at 1.1 g): without the floor the
    model cannot produce the measured a_y and reads it as a runaway slip angle; with it, beta stays
    about as right as with the right friction. (One test: the runs take 20 s.)"""
    errors = lap_errors(revs_lap)
    assert errors["saturating"] < 0.8 * errors["linear"], errors
    assert errors["too low, no floor"] > 3 * errors["saturating"], errors
    assert errors["too low"] < 1.5 * errors["saturating"], errors
