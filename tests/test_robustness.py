"""Real roads and real sensors (docs/robustness.md): the shipped switching estimator (saturating KF,
learned kinematic offset, bounded kinematic dwell) on a 3 degree bank and with a 0.5 m/s^2 a_y offset
the vehicle file was not identified with, on both truth cars; and no estimator silently wrong
anywhere in the robustness matrix. Some shipped settings were chosen on the matrix's runs
(docs/robustness.md names them): its counts are not a hold-out score."""

from __future__ import annotations

import math

import numpy as np
import pytest
from locations import VEHICLES

from bench.robustness import matrix, run_case
from bench.seed002 import PAPER_DLC
from bench.silent import MODEL_BASED
from bench.table3 import PAPER_KF
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.score.metrics import SILENT_DURATION, silent_error_time, worse_than_zero
from vsegen.harness.sim.scenarios import Case

BANK = {"bank": 100.0 * math.tan(math.radians(3.0))}
WORSE_THAN_ZERO_RUNS = 0
"""Model-based runs of the matrix not better than answering beta = 0 (#44): 77 of 744 when the rule
was first measured, 62 since ekf_rls flags a learned stiffness below half the file's, 61 since the
yaw-rate check reads the means of the checks' period, 32 since fusion ships the saturating KF with
k_c = 5/s and flags from 4 m/s^2 and ekf_rls from 6 m/s^2, 16 since kf2dof's and fusion's process
noise grows with a_y, kf2dof and ukf hold BEYOND_LINEAR_RANGE 0.2 and 0.3 s and aukf caps the
adapted noise of v at 2e-3, 13 since switching ships the saturating KF and ekf_rls flags below 0.65, 7 since
ukf and aukf trust a_y as its sensor deserves and switching's KF noise is half the paper's, 2 since
the checks' means start as running means, ekf_rls learns from slips above the sensors' noise and
switching's checks take a steer angle held 0.2 s as quasi-steady, 0 since aukf learns no noise
from a flagged sample and the yaw-rate check learns its share; the count may only fall."""
OFFSET = {"ay_offset": 0.5}
PAPERS_Q_C = np.diag(PAPER_KF["process_noise"]).tolist()
"""The papers' constant KF noise (bench.table3.PAPER_KF) as a parsed vehicle file holds it."""


def _scores(config, case: Case) -> tuple[float, float, bool]:
    """beta RMSE (deg) and the longest silent stretch (s) of switching, and whether the car spun."""
    log = case.simulate(config, 1.0 / config.sample_time)
    estimates = run_estimator(config, "switching", log)
    error = np.rad2deg(estimates["beta"] - log["beta_ref"])
    return float(np.sqrt(np.mean(error**2))), silent_error_time(log, estimates)[0], log.notes["spun"] != "no"


CONTINUOUS_DLC_DISTURBANCES = {"bank right": {"bank": BANK["bank"]}, "bank left": {"bank": -BANK["bank"]},
                               "offset +": OFFSET, "offset -": {"ay_offset": -OFFSET["ay_offset"]}}
BALANCED_SHORTFALL = pytest.mark.xfail(strict=True, reason=(
    "a bank and an a_y offset cannot be told apart from a_y and r; offset_sensor_share = 0.4 balances "
    "them and leaves c_class at 1.55 x (offset -), docs/robustness.md"))


@pytest.mark.slow
@pytest.mark.parametrize("car", ["c_class", "rwd_saloon"])
def test_switching_step_steer_copes_with_a_bank_and_an_accelerometer_offset(car):
    """Step steer with a 3 deg bank or a 0.5 m/s^2 offset: beta RMSE <= 1 deg, never silent."""
    config = load_vehicle(VEHICLES / f"{car}.toml")
    for disturbance in (BANK, OFFSET):
        rmse, silent, _ = _scores(config, Case.of("step_steer", **disturbance))
        assert rmse <= 1.0 and silent <= SILENT_DURATION, (disturbance, rmse, silent)


@pytest.mark.slow
@pytest.mark.parametrize("car, disturbance", [
    ("c_class", "bank right"), ("c_class", "bank left"),
    ("c_class", "offset +"), pytest.param("c_class", "offset -", marks=BALANCED_SHORTFALL),
    ("rwd_saloon", "bank right"), ("rwd_saloon", "bank left"), ("rwd_saloon", "offset +"),
    ("rwd_saloon", "offset -")])
def test_switching_continuous_dlc_stays_within_1_5_times_its_undisturbed_rmse(car, disturbance):
    """Continuous DLC with a 3 deg bank or a 0.5 m/s^2 offset present from the start (the vehicle
    file identified without it): beta RMSE <= 1.5 x undisturbed, never silent, no spin."""
    config = load_vehicle(VEHICLES / f"{car}.toml")
    clean, _, _ = _scores(config, Case.of("continuous_dlc"))
    rmse, silent, spun = _scores(config, Case.of("continuous_dlc", **CONTINUOUS_DLC_DISTURBANCES[disturbance]))
    assert not spun and silent <= SILENT_DURATION
    assert rmse <= 1.5 * clean, (rmse, clean)


@pytest.mark.slow
def test_no_estimator_is_silently_wrong_anywhere_in_the_robustness_matrix():
    """Every disturbance x core manoeuvre and road scenario x sideslip estimator x both cars (the
    matrix of bench.robustness, 992 runs): no stretch over SILENT_DURATION with |beta error| > 2 deg
    and status 0 before a spin; and no more model-based runs worse than answering beta = 0 than
    today (docs/robustness.md)."""
    runs = matrix()
    with DaskPool(None) as cluster:
        results = cluster.map(run_case, runs)
    silent = [(car, disturbance, case.label, name, round(row["silent"], 2))
              for (car, disturbance, case), rows in zip(runs, results)
              for name, row in rows.items() if row["silent"] > SILENT_DURATION]
    assert not silent
    worse = [(car, disturbance, case.label, name) for (car, disturbance, case), rows in zip(runs, results)
             for name, row in rows.items() if name in MODEL_BASED and row["worse"] is not None]
    assert len(worse) <= WORSE_THAN_ZERO_RUNS, worse


def _beats_zero_only_as_shipped(config, name: str, case: Case, **other_settings) -> None:
    """On ``case``, ``name`` as the file ships it beats answering beta = 0 (flags and all), and with
    ``other_settings`` instead it does not."""
    log = case.simulate(config, 1.0 / config.sample_time)
    other = config.with_settings(name, **other_settings)
    assert worse_than_zero(log, run_estimator(config, name, log)) is None
    assert worse_than_zero(log, run_estimator(other, name, log)) is not None


@pytest.mark.parametrize("car", ["c_class", "rwd_saloon"])
def test_kf_noise_growing_with_a_y_beats_zero_where_a_constant_noise_does_not(car):
    """The steering angle frozen in the 80 km/h DLC's reversal: for 0.3 s nothing can tell it from
    a held wheel, and kf2dof's error grows to 1-2 deg before its monitors see it. With the shipped
    Q_c growing with a_y (process_noise_load) its straight-line noise is low enough that the run,
    flags and all, beats answering beta = 0; with the papers' constant Q_c it does not."""
    config = load_vehicle(VEHICLES / f"{car}.toml")
    assert config.settings("kf2dof")["process_noise_load"] > 0
    _beats_zero_only_as_shipped(config, "kf2dof", Case.of("dlc", speed_kmh=80.0, freeze="delta:3.0:2"),
                                process_noise=PAPERS_Q_C, process_noise_load=0.0)


@pytest.mark.slow
def test_ekf_rls_learning_from_slips_above_the_noise_beats_zero_on_a_crossfall():
    """The C-class's lane changes on a 2.5 % crossfall: with the RLS learning from slip angles of
    0.002 rad (our default) the stiffness it learns leaves beta 0.25 deg off, unflagged, no better
    than answering beta = 0; from the shipped 0.005 rad it is better."""
    config = load_vehicle(VEHICLES / "c_class.toml")
    assert config.settings("ekf_rls")["slip_min"] > 0.002
    _beats_zero_only_as_shipped(config, "ekf_rls", Case.of("crossfall_lane_change"), slip_min=0.002)


@pytest.mark.slow
def test_switching_seeing_a_frozen_steering_angle_sooner_beats_zero():
    """The steering angle frozen for 2 s in the C-class's 80 km/h DLC reversal: switching's KF
    trusts delta; with the checks' default steady_time (0.3 s) the steer check sees it 0.1 s too
    late and the run is no better than answering beta = 0; with the shipped 0.2 s it is better."""
    config = load_vehicle(VEHICLES / "c_class.toml")
    _beats_zero_only_as_shipped(config, "switching", Case.of("dlc", speed_kmh=80.0, freeze="delta:3.0:2"),
                                steady_time=0.3)


@pytest.mark.slow
def test_aukf_trusting_a_y_as_its_sensor_beats_zero_where_the_papers_noise_does_not():
    """The steering angle frozen for 1.5 s in the 80 km/h DLC's reversal: with the paper's R = 1e-3 I
    the aukf trusts a_y 90-fold more than its noise (0.3 m/s^2), which moves its straight-line v,
    and the run, flags and all, is no better than answering beta = 0; with the shipped R (a_y at
    about the sensor's variance) it is (C-class; on the saloon the paper's R beats zero there too since
    the aukf learns no noise from a flagged sample)."""
    config = load_vehicle(VEHICLES / "c_class.toml")
    assert config.settings("aukf")["measurement_noise"][1] >= 0.09
    _beats_zero_only_as_shipped(config, "aukf", Case.of("dlc", speed_kmh=80.0, freeze="delta:3.0:1.5"),
                                measurement_noise=PAPER_DLC["measurement_noise"])


@pytest.mark.slow
@pytest.mark.parametrize("case", [Case.of("step_steer", scale="r:1.3"),
                                  Case.of("dlc", speed_kmh=80.0, scale="r:1.3")],
                         ids=["step steer", "DLC 80 km/h"])
def test_switching_with_half_the_papers_kf_noise_beats_zero_where_the_papers_does_not(case):
    """The saloon with a yaw-rate factor typed wrong (x 1.3): before the wheel check sees it in the
    first bend, the straight is unflagged, and with the paper's Q_c = diag(0.25, 0.01) the a_y noise
    moves switching's beta by up to 0.15 deg there, no better than answering beta = 0; with the
    shipped Q_c it is."""
    _beats_zero_only_as_shipped(load_vehicle(VEHICLES / "rwd_saloon.toml"), "switching", case,
                                process_noise=PAPERS_Q_C)


def test_a_learned_yaw_rate_share_beats_zero_where_the_share_test_alone_does_not():
    """The C-class's continuous DLC with r x 1.3 (a DBC typo): the low-friction part's corners yaw
    too little for the share test of the yaw-rate check, and switching's estimate from the wrong r
    was 0.27 deg RMSE where it was not flagged (bound 0.18 deg); the learned share
    (wheel_check_scale_time) keeps the bit raised there, and the run, flags and all, beats zero."""
    config = load_vehicle(VEHICLES / "c_class.toml")
    assert config.settings("switching")["wheel_check_scale_time"] > 0
    _beats_zero_only_as_shipped(config, "switching", Case.of("continuous_dlc", scale="r:1.3"),
                                wheel_check_scale_time=0.0)
