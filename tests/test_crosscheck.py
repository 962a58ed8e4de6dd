"""The cross-checks of the inputs (model.input_checks.crosscheck, model.input_checks.wheel_yaw): a
bank or an accelerometer offset raises LATERAL_INCONSISTENT, a steering-angle zero error STEERING_OFFSET within 60 s of
ordinary driving, a steering angle frozen in a manoeuvre INPUT_FROZEN within 1 s, a gyro that
disagrees with the non-driven wheels YAW_RATE_MISMATCH; undisturbed drives raise none of them, on
both truth cars; a limit of 0 removes its check."""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pytest
from locations import VEHICLES

from vsegen.harness.host.run_log import estimator_inputs, run_estimator
from vsegen.harness.logs.table import Log, LogError, write_log
from vsegen.harness.outputs.estimates import read_estimates
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.score.metrics import SILENT_DURATION, silent_error_time
from vsegen.harness.sim.scenarios import Case
from vsegen.model.estimators import build
from vsegen.model.status import INPUT_FROZEN, INVALID_INPUT, LATERAL_INCONSISTENT, STEERING_OFFSET, YAW_RATE_MISMATCH

CARS = ("c_class", "rwd_saloon")
CHECKED = ("kf2dof", "switching", "fusion", "ekf_rls", "ukf", "aukf")
UNDISTURBED = ("dlc", "continuous_dlc", "step_steer", "sine_steer", "fishhook", "hil_sine", "crest_dip",
               "downhill_brake_curve", "crossfall_lane_change")


def _car(name: str):
    return load_vehicle(VEHICLES / f"{name}.toml")


def _raised(config, estimator: str, case: Case, bit: int) -> np.ndarray:
    """The times (s) at which ``estimator`` raises ``bit`` on ``case``."""
    log = case.simulate(config, 1.0 / config.sample_time)
    status = run_estimator(config, estimator, log)["status"].astype(int)
    return log["t"][(status & bit) > 0]


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("scenario", UNDISTURBED)
def test_undisturbed_drives_raise_no_cross_check(car, scenario):
    """Every undisturbed manoeuvre, the friction limit and a 2.5 % crossfall included: no bit."""
    config = _car(car)
    for bit in (LATERAL_INCONSISTENT, STEERING_OFFSET, INPUT_FROZEN):
        assert _raised(config, "switching", Case.of(scenario), bit).size == 0, bit


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("case", [Case.of("banked_curve"), Case.of("dlc", ay_offset=0.5),
                                  Case.of("crossfall_lane_change", crossfall=6.0)])
def test_a_bank_or_an_accelerometer_offset_is_lateral_inconsistency(car, case):
    """The 6 % superelevated curve, a 0.5 m/s^2 offset, a 6 % crossfall (each about 0.5 m/s^2 of
    a_y - r v_x)."""
    assert _raised(_car(car), "switching", case, LATERAL_INCONSISTENT).size


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("fault, bit", [({"bank": 100.0 * math.tan(math.radians(3.0))}, LATERAL_INCONSISTENT),
                                        ({"steer_offset": math.radians(0.2)}, STEERING_OFFSET)])
def test_a_bank_or_a_steering_zero_error_there_from_the_start_is_told_on_the_first_second_of_straight(
        car, fault, bit):
    """The step steer drives 1 s straight before its step: a 3 deg bank (0.51 m/s^2 against the
    0.4 limit) or a 0.2 deg steering zero error (0.1 deg limit) under the car from start-up is
    flagged there. The checks' means start as running means (model.filters.learned_mean); as
    first-order low-passes from 0 they had reached 75 % and 13 % of the fault by then."""
    flagged = _raised(_car(car), "switching", Case.of("step_steer", **fault), bit)
    assert flagged.size and flagged[0] < 1.0


@pytest.mark.slow   # 60 s drives: about a minute of the default suite
@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_steering_zero_error_of_0_2_degrees_is_flagged_within_60_s_of_ordinary_driving(car, sign):
    """A 0.2 deg road-wheel zero error (about 3 deg at the steering wheel) on a 60 s drive with a
    lane change, flat and on a 2.5 % crossfall; a 0.3 deg/s gyro bias alone is not taken for one."""
    config = _car(car)
    offset = sign * math.radians(0.2)
    for crossfall in (0.0, 2.5):
        case = Case.of("crossfall_lane_change", duration=60.0, crossfall=crossfall, steer_offset=offset)
        flagged = _raised(config, "switching", case, STEERING_OFFSET)
        assert flagged.size and flagged[0] < 60.0
    biased = Case.of("crossfall_lane_change", duration=60.0, gyro_bias=math.radians(0.3))
    assert _raised(config, "switching", biased, STEERING_OFFSET).size == 0


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("start", [3.0, 4.0, 5.0, 6.0])
def test_a_steering_angle_frozen_in_a_manoeuvre_is_flagged_within_1_s(car, start):
    """The steering signal stuck at any point of the double lane change."""
    flagged = _raised(_car(car), "switching", Case.of("dlc", freeze=f"delta:{start}:1.5"), INPUT_FROZEN)
    assert flagged.size and start < flagged[0] <= start + 1.0


@pytest.mark.parametrize("name", CHECKED)
def test_every_checked_estimator_raises_the_bits(config, name):
    """Each estimator carries the same checks (model.input_monitors): the offset and the steering
    zero error are seen by all."""
    case = Case.of("crossfall_lane_change", duration=30.0, crossfall=0.0, ay_offset=0.5,
                   steer_offset=math.radians(0.3))
    assert _raised(config, name, case, LATERAL_INCONSISTENT).size
    assert _raised(config, name, case, STEERING_OFFSET).size


def test_a_limit_of_zero_removes_its_check(variant):
    off = variant("estimator.kf2dof", lateral_check_limit=0.0, steering_offset_limit=0.0, steer_check_limit=0.0)
    entries = {"steady_delta", "lateral_residual", "steering_offset", "curvature"}
    assert not entries & set(build("kf2dof", off).states.names)
    only_lateral = variant("estimator.kf2dof", steering_offset_limit=0.0, steer_check_limit=0.0)
    names = set(build("kf2dof", only_lateral).states.names)
    assert "lateral_residual" in names and not {"steering_offset", "curvature"} & names


def test_ekf_rls_learns_no_stiffness_from_a_frozen_yaw_rate(config):
    """The RLS stops while an input monitor raises a bit, so a yaw rate stuck for 1.5 s in a
    steady corner leaves the stiffness, and after the freeze the sideslip angle, near right."""
    case = Case.of("step_steer", freeze="r:3:1.5")
    log = case.simulate(config, 1.0 / config.sample_time)
    estimate = run_estimator(config, "ekf_rls", log)
    after = log["t"] > 4.5
    assert np.max(np.abs(np.degrees(estimate["beta"][after] - log["beta_ref"][after]))) < 1.0


@pytest.mark.parametrize("car", CARS)
def test_the_yaw_rate_is_checked_against_the_non_driven_wheels(car):
    """ukf and aukf read wheel speeds, switching is given them for the check: every undisturbed
    drive (braking in a bend and the synthetic low-speed log included) passes; a yaw rate frozen in
    the DLC or a 3.4 deg/s gyro offset raises YAW_RATE_MISMATCH, a 0.3 deg/s offset with drift
    does not."""
    config = _car(car)
    for scenario in (*UNDISTURBED, "banked_curve", "low_speed"):
        for name in ("ukf", "switching", "ekf_rls"):
            assert _raised(config, name, Case.of(scenario), YAW_RATE_MISMATCH).size == 0, (name, scenario)
    frozen = _raised(config, "aukf", Case.of("dlc", freeze="r:3:1.5"), YAW_RATE_MISMATCH)
    assert frozen.size and 3.0 < frozen[0] <= 4.0
    assert _raised(config, "ukf", Case.of("dlc", gyro_bias=0.06), YAW_RATE_MISMATCH).size
    drift = Case.of("dlc", gyro_bias=math.radians(0.3), gyro_drift=0.001)
    assert _raised(config, "ukf", drift, YAW_RATE_MISMATCH).size == 0


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("factor", [1.3, 1 / 1.3])
@pytest.mark.parametrize("name", ["switching", "ekf_rls"])
def test_a_yaw_rate_scale_typed_wrong_is_never_silent_for_longer_than_allowed(car, factor, name):
    """A DBC whose yaw-rate factor is 0.013 instead of 0.01 (or the reverse): the unit check only
    notes it (tests/test_unit_sanity.py). Before the wheel check, switching's kinematic integrator was
    3-4.7 deg off with status 0 for 0.60-0.91 s on the DLC (seeds 1-3, both cars), ekf_rls for up to
    0.47 s there and 4.5 s on the step steer; both now flag YAW_RATE_MISMATCH (the share test)."""
    config = _car(car)
    for case in (Case.of("dlc"), Case.of("step_steer")):
        for seed in (1, 2, 3):
            log = case.simulate(config, 1.0 / config.sample_time, seed)
            typo = Log({**log.columns, "r": log["r"] * factor}, "typo.csv")
            estimates = run_estimator(config, name, typo)
            assert silent_error_time(typo, estimates)[0] <= SILENT_DURATION, (case, seed)
            assert np.any(estimates["status"].astype(int) & YAW_RATE_MISMATCH), (case, seed)


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("name", ["switching", "ekf_rls"])
def test_a_yaw_rate_scale_typed_wrong_is_kept_for_the_mild_corners_of_low_friction(car, name):
    """The continuous DLC with r x 1.3: after the first corner (friction 0.85) the learned share
    (wheel_check_scale_time) keeps YAW_RATE_MISMATCH raised through most of the low-friction part
    (friction 0.5 and 0.35 from 9 s), whose corners yaw too little for the share test alone (raised
    on 7 % of it on the C-class's switching; tests/test_robustness.py: beating beta = 0 there)."""
    config = _car(car)
    log = Case.of("continuous_dlc", scale="r:1.3").simulate(config, 1.0 / config.sample_time)
    low_friction = log["t"] > 9.0
    shares = {}
    for learned in (config.settings(name)["wheel_check_scale_time"], 0.0):
        status = run_estimator(config.with_settings(name, wheel_check_scale_time=learned), name, log)["status"]
        shares[learned] = np.mean((status[low_friction].astype(int) & YAW_RATE_MISMATCH) > 0)
    shipped, without = shares.values()
    assert shipped > 0.5 and shipped > without + 0.2, shares


def test_the_yaw_rate_check_is_where_it_is_on_and_brings_its_inputs(config):
    """An estimator has the check, and reads a_x and the checked axle's wheel speeds, exactly when
    its wheel_check_limit is above 0 (the UKFs read every wheel for their model anyway)."""
    assert "wheel_yaw_residual" in build("ukf", config).states.names
    assert "wheel_yaw_residual" not in build("kf2dof", config).states.names
    assert build("kf2dof", config).inputs.names == ("delta", "vx", "ay", "r")
    assert build("ekf_rls", config).inputs.names == ("delta", "vx", "ax", "ay", "r", "omega_rl", "omega_rr")
    switching = build("switching", config)
    assert "wheel_yaw_residual" in switching.states.names
    assert switching.inputs.names == ("delta", "vx", "ax", "ay", "r", "omega_rl", "omega_rr")
    settings = MappingProxyType({**config.settings("switching"), "wheel_check_limit": 0.0})
    off = replace(config, estimators=MappingProxyType({**config.estimators, "switching": settings}))
    assert build("switching", off).inputs.names == ("delta", "vx", "ay", "r")


def test_a_log_without_the_checked_wheel_speeds_runs_without_the_check(config, tmp_path, vsegen):
    """A log of the five required columns only: switching (whose file switches its yaw-rate check
    on) runs as with wheel_check_limit = 0 and says so, rather than refusing the log."""
    log = Case.of("dlc").simulate(config, 1.0 / config.sample_time, 1)
    bare = Log({name: log[name] for name in ("t", "delta", "vx", "ax", "ay", "r", "beta_ref")}, "bare.csv")
    write_log(bare, tmp_path / "bare.csv")
    result = vsegen("run", "--log", tmp_path / "bare.csv", "--estimator", "switching", "--out", tmp_path / "est.csv")
    assert result.exit_code == 0, result.output
    assert "switching runs without its yaw-rate check: the log has no omega_rl, omega_rr" in result.stderr
    expected = run_estimator(config.with_settings("switching", wheel_check_limit=0.0), "switching", bare)
    np.testing.assert_array_equal(read_estimates(tmp_path / "est.csv")["beta"], expected["beta"])


@pytest.mark.parametrize("name", ["switching", "ekf_rls"])
def test_a_bad_wheel_speed_only_the_check_reads_never_holds_the_estimator(name):
    """The saloon's invalid_inputs run (its front wheel speeds NaN at 6 s, 1e4 rad/s at 7 s): the
    estimate is that of the same estimator without the check, sample for sample (the check only
    adds status bits), and no wheel-speed fault raises INVALID_INPUT or holds it."""
    config = _car("rwd_saloon")
    log = Case.of("invalid_inputs").simulate(config, 1.0 / config.sample_time, 1)
    checked = run_estimator(config, name, log)
    unchecked = run_estimator(config.with_settings(name, wheel_check_limit=0.0), name, log)
    np.testing.assert_array_equal(checked["beta"], unchecked["beta"])
    wheel_faults = (np.abs(log["t"] - 6.0) < 1e-9) | (np.abs(log["t"] - 7.0) < 1e-9)
    assert np.all(checked["status"][wheel_faults].astype(int) & INVALID_INPUT == 0)


def test_where_a_log_without_the_checked_wheel_speeds_cannot_run_the_message_names_the_setting(config):
    """tune and identify read the log whole through ``estimator_inputs``: one line naming the
    check and the setting, not the UKFs' reason for needing every wheel speed."""
    log = Case.of("dlc").simulate(config, 1.0 / config.sample_time, 1)
    bare = Log({name: log[name] for name in ("t", "delta", "vx", "ax", "ay", "r")}, "bare.csv")
    with pytest.raises(LogError) as error:
        estimator_inputs(build("switching", config), bare)
    assert str(error.value) == ("bare.csv:1: missing column 'omega_rl': estimator switching's yaw-rate check reads "
                                "ax, omega_rl, omega_rr; for logs without them set [estimator.switching] "
                                "wheel_check_limit = 0")
