"""The Kalman filter's friction estimate (friction_noise > 0 with tyre_model = "saturating"): the
model's friction columns and their reference twin, what the estimate finds on our plant, the linear
range it scales and the accuracy it buys on slippery roads."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from locations import REPO

from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.reference import bicycle_kf
from vsegen.harness.reference import fusion as reference
from vsegen.harness.reference.loop import run_reference
from vsegen.harness.score.metrics import SPIN_SIDESLIP, silent_error_time
from vsegen.harness.sim.scenarios import Case
from vsegen.model.estimators.kf2dof import friction_estimated
from vsegen.model.params import parse_vehicle
from vsegen.model.tyres import friction, saturating_bicycle


def test_the_shipped_fusion_estimates_the_friction(config):
    assert friction_estimated(config.settings("fusion"))


@pytest.mark.parametrize("ay", [0.5, 9.0])     # the floor below and above the scaled friction
def test_friction_columns_are_the_derivatives_of_the_model(config, ay):
    x, scale = ca.SX.sym("x", 2), ca.SX.sym("rho")
    axles = friction([0.9, 1.1], 1.15, ay, scale)
    model = saturating_bicycle(config.vehicle, axles, x, 0.03, 17.0)
    gap = ca.Function("g", [x, scale], [model.f_friction - ca.jacobian(model.f, scale),
                                        model.ay_friction - ca.jacobian(model.ay, scale)])
    for point in ([0.0, 0.0], [0.4, 0.2], [-1.5, 0.6]):     # linear, near and far beyond the peak
        for value in gap(point, 0.8):
            assert np.abs(np.array(value)).max() < 1e-9


def test_the_reference_twin_computes_the_same_friction_columns(config):
    x = ca.SX.sym("x", 2)
    mu, slope = [0.8, 1.2], [0.8, 1.2]
    axles = friction(mu, 0.0, 0.0)
    model = ca.Function("m", [x], [saturating_bicycle(config.vehicle, axles, x, 0.05, 12.0).f_friction])
    for point in ([0.1, 0.3], [-0.9, -0.4]):
        df, _ = bicycle_kf.friction_sensitivity(config.vehicle, mu, slope, np.array(point), 0.05, 12.0)
        np.testing.assert_allclose(np.array(model(point)).ravel(), df, rtol=1e-12)


def friction_track(config, case: Case) -> tuple[np.ndarray, object]:
    """(the friction scale of fusion's reference at every sample, the log) on ``case``."""
    log = case.simulate(config, 1.0 / config.sample_time, 1)
    inputs, states, _ = reference.names(config)
    _, trajectory = run_reference(reference, config, log.matrix(inputs))
    return trajectory[1:, states.index("friction")], log


def test_the_estimate_finds_the_roads_friction_where_the_tyres_saturate(config):
    """A step steer on mu 0.5: the scale falls to the road's friction (the file says 1.0) within
    15 %, once the tyres saturate; on a gentle sine steer at mu 1 the tyres never do, and it stays."""
    scale, log = friction_track(config, Case.of("step_steer", mu=0.5))
    settled = log["t"] > log["t"][-1] - 1.0
    assert np.median(scale[settled]) == pytest.approx(0.5, rel=0.15)
    scale, _ = friction_track(config, Case.of("sine_steer"))
    assert np.abs(scale - 1.0).max() < 0.05


def beta_rmse(config, name: str, log) -> float:
    """beta RMSE (deg) up to a spin (|beta| > 15 deg: not scored, as everywhere)."""
    kept = ~np.maximum.accumulate(np.abs(log["beta_ref"]) > SPIN_SIDESLIP)
    error = (run_estimator(config, name, log)["beta"] - log["beta_ref"])[kept]
    return float(np.degrees(np.sqrt(np.mean(error**2))))


def test_on_a_slippery_road_the_estimate_buys_accuracy_and_stays_flagged():
    """rwd_saloon's file, fusion, DLC at 80 km/h on mu 0.35: the friction estimate more than halves
    the beta error of the KF that believes the file's friction (2.6 deg), and where the estimate is
    wrong it says so (the linear range shrinks with the estimated friction): no silent stretch."""
    text = (REPO / "vehicles" / "rwd_saloon.toml").read_text()
    config = parse_vehicle(text, "rwd_saloon.toml", "rwd_saloon")
    believing = parse_vehicle(with_settings(text, "estimator.fusion", friction_noise=0.0), "off.toml",
                              "rwd_saloon")
    log = Case.of("dlc", speed_kmh=80.0, mu=0.35).simulate(config, 1.0 / config.sample_time, 1)
    assert beta_rmse(config, "fusion", log) < 0.5 * beta_rmse(believing, "fusion", log)
    assert silent_error_time(log, run_estimator(config, "fusion", log))[0] <= 0.5
