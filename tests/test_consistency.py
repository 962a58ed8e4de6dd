"""The consistency monitor (model.consistency) and the "never silently wrong" rule (harness.score.metrics)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from locations import VEHICLES

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.logs.table import Log
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.score.metrics import SILENT_DURATION, silent_error_time, worse_than_zero
from vsegen.harness.sim.scenarios import SCORED_SET, Case
from vsegen.model import consistency
from vsegen.model.estimators import DEFINITIONS, build
from vsegen.model.status import BEYOND_LINEAR_RANGE, DEAD_RECKONING, MODEL_INCONSISTENT

SETTINGS = {"residual_window": 0.2, "residual_limit": 6.0, "sensor_noise": (0.3, 0.3, 0.0175)}


def test_monitor_mean_follows_its_definition():
    """m_k = a m_k-1 + (1 - a) mean(min(nu^2 / sigma^2, 100)), a = exp(-T / window)."""
    nu = ca.SX.sym("nu", 3)
    previous = ca.SX.sym("m")
    f = ca.Function("m", [previous, nu], [consistency.averaged(previous, nu, SETTINGS, 0.01)])
    a = math.exp(-0.01 / 0.2)
    for innovation in ([0.3, -0.6, 0.0175], [0.0, 0.0, 1.0], [10.0, 0.1, 0.0]):
        ratios = np.minimum(np.square(innovation) / np.square(SETTINGS["sensor_noise"]), 100.0)
        expected = a * 2.0 + (1 - a) * ratios.mean()
        assert float(f(2.0, innovation)) == pytest.approx(expected, rel=1e-12)


def _log(t, beta_ref, beta, status):
    return (Log({"t": t, "beta_ref": beta_ref}, source="<truth>"),
            Log({"t": t, "beta": beta, "status": status}, source="<estimate>"))


def test_silent_error_time_counts_only_unflagged_wrong_samples_before_a_spin():
    t = np.arange(0.0, 4.0, 0.01)
    truth = np.zeros_like(t)
    estimate = np.where((t >= 1.0) & (t < 2.0), np.deg2rad(3.0), 0.0)   # 1 s wrong by 3 deg
    status = np.zeros_like(t)
    log, estimates = _log(t, truth, estimate, status)
    assert silent_error_time(log, estimates) == pytest.approx((1.0, 1.0))
    status[(t >= 1.4) & (t < 1.5)] = 128                                # flagged in the middle
    longest, start = silent_error_time(*_log(t, truth, estimate, status))
    assert longest == pytest.approx(0.5) and start == pytest.approx(1.5)
    spun = np.where(t >= 1.2, np.deg2rad(20.0), 0.0)                    # the car spins at 1.2 s
    longest, _ = silent_error_time(*_log(t, spun, estimate + spun, np.zeros_like(t)))
    assert longest == pytest.approx(0.2)
    nan = np.where(t >= 3.0, np.nan, 0.0)                               # a NaN is wrong
    assert silent_error_time(*_log(t, truth, nan, np.zeros_like(t)))[0] == pytest.approx(1.0)


def test_worse_than_zero_binds_the_run_or_else_its_unflagged_samples():
    t = np.arange(0.0, 4.0, 0.01)
    truth = np.deg2rad(2.0) * np.sin(t)                                 # RMS 1.4 deg: bound about 1 deg
    status = np.zeros_like(t)
    assert worse_than_zero(*_log(t, truth, truth + np.deg2rad(0.5), status)) is None
    assert worse_than_zero(*_log(t, truth, np.zeros_like(t), status)) is not None      # answering beta = 0 itself
    wrong = truth + np.where(t >= 2.0, np.deg2rad(5.0), 0.0)           # 5 deg off for 2 s
    rmse, bound = worse_than_zero(*_log(t, truth, wrong, status))
    assert np.degrees(rmse) == pytest.approx(5.0 / np.sqrt(2.0), rel=1e-6)  # half the run 5 deg off
    assert bound == pytest.approx(0.7 * np.sqrt(np.mean(truth**2)))     # unflagged: every sample
    status[t >= 2.0] = 256                                              # flagged where it is wrong
    assert worse_than_zero(*_log(t, truth, wrong, status)) is None
    straight = np.zeros_like(t)                                         # straight: the 0.1 deg floor
    assert worse_than_zero(*_log(t, straight, straight + np.deg2rad(0.09), np.zeros_like(t))) is None
    assert worse_than_zero(*_log(t, straight, straight + np.deg2rad(0.2), np.zeros_like(t))) is not None


MONITORED = tuple(name for name in DEFINITIONS if "beta" in build(name, load_vehicle(VEHICLES / "c_class.toml"))
                  .outputs.names)
"""Every sideslip estimator: the rule holds for each on both truth cars (docs/silent.md)."""


@pytest.mark.slow
@pytest.mark.parametrize("name", MONITORED)
@pytest.mark.parametrize("vehicle", ["c_class", "rwd_saloon"])
def test_never_silently_wrong(name, vehicle):
    """On every verification scenario, |beta error| > 2 deg lasts at most 0.5 s with status 0
    (samples after the car spins are not scored)."""
    config = load_vehicle(VEHICLES / f"{vehicle}.toml")
    for case in SCORED_SET:
        log = case.simulate(config, 1.0 / config.sample_time, 1)
        longest, start = silent_error_time(log, run_estimator(config, name, log))
        assert longest <= SILENT_DURATION, f"{case.label}: silently wrong for {longest:.2f} s from {start:.2f} s"


@pytest.mark.slow
@pytest.mark.parametrize("name,case,off,on,bit", [
    # at mu = 0.5 (the ukf assumes 1.0) the consistency monitor alone flags the ukf
    ("ukf", Case.of("dlc", speed_kmh=120.0, mu=0.5), {"residual_window": 0.0, "linear_range": 0.0},
     {"residual_window": 0.2, "linear_range": 0.0}, MODEL_INCONSISTENT),
    # the aukf's Sage-Husa noise estimate absorbed the innovations, and its monitor stayed quiet while
    # beta was wrong by up to 10 deg; now that it learns nothing from a flagged sample, the monitor
    # alone flags it, and so does linear_range (the road may be at its friction limit) alone
    ("aukf", Case.of("dlc", speed_kmh=120.0, mu=0.5), {"residual_window": 0.0, "linear_range": 0.0},
     {"residual_window": 0.2, "linear_range": 0.0}, MODEL_INCONSISTENT),
    ("aukf", Case.of("dlc", speed_kmh=120.0, mu=0.5), {"residual_window": 0.0, "linear_range": 0.0},
     {"residual_window": 0.0, "linear_range": 4.0}, BEYOND_LINEAR_RANGE),
    # v_y is never measured by the particle filters: on the hill sine pf_adaptive's and on the
    # low-speed scenario pf_improved's beta drifts past 2 deg; the drift bound flags it
    ("pf_adaptive", Case.of("hil_sine", mu=0.85), {"drift_acceleration": 0.0, "drift_yaw_rate": 0.0},
     {"drift_acceleration": 0.05, "drift_yaw_rate": 0.015}, DEAD_RECKONING),
    ("pf_improved", Case.of("low_speed"), {"drift_acceleration": 0.0, "drift_yaw_rate": 0.0},
     {"drift_acceleration": 0.05, "drift_yaw_rate": 0.015}, DEAD_RECKONING),
])
def test_each_safeguard_turns_a_silent_error_into_a_status(variant, name, case, off, on, bit):
    """Without the safeguard the estimator is silently wrong for more than 0.5 s; with it, the
    status carries its bit and the silent stretch is within the rule."""
    silent = []
    for settings in (off, on):
        config = variant(f"estimator.{name}", **settings)
        log = case.simulate(config, 100.0, 1)
        estimates = run_estimator(config, name, log)
        silent.append(silent_error_time(log, estimates)[0])
        assert ((estimates["status"].astype(int) & bit) > 0).any() == (settings is on)
    assert silent[0] > SILENT_DURATION >= silent[1]


def test_the_drift_bound_grows_with_speed_and_time_from_the_initial_spread(variant):
    """The state's bound: 3 sigma of the initial v_y spread at the draw, then
    (drift_acceleration + |v_x| drift_yaw_rate) T per active sample, v_x the filter's estimate."""
    config = variant("estimator.pf_adaptive", drift_acceleration=0.05, drift_yaw_rate=0.01, particles=20)
    log = Case.of("sine_steer").simulate(config, 100.0, 1)
    estimator, compiled = compile_estimator(config, "pf_adaptive")
    outputs, states = compiled.run(log.matrix(estimator.inputs.names))
    drift = states[:, estimator.states.names.index("drift")]
    vx = outputs[:, estimator.outputs.names.index("vx")]
    spread = config.settings("pf_adaptive")["initial_spread"][1]
    expected = 3 * spread + np.cumsum(0.01 * (0.05 + 0.01 * np.abs(vx)))
    assert drift[0] == pytest.approx(3 * spread)
    np.testing.assert_allclose(drift[1:], expected, rtol=1e-12)
    flagged = (outputs[:, -1].astype(int) & DEAD_RECKONING) > 0
    np.testing.assert_array_equal(flagged, drift[1:] > np.tan(0.0349) * np.abs(vx))
