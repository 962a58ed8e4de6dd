"""Unit mistakes that pass the range checks are caught from the redundancy of the log (v_x and r
against the wheel speeds, a_y against r v_x, delta against the bicycle model's yaw rate) in every
manoeuvre: one line naming the column and the likely cause, exit 2, nothing written;
--no-unit-check runs anyway; what could not be checked is said in one line; the simulated logs of
both truth cars pass."""

from __future__ import annotations

import re

import numpy as np
import pytest
from locations import VEHICLES

from vsegen.harness.logs.table import Log, LogError, write_log
from vsegen.harness.physics.units import check_units
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim.scenarios import SCENARIOS, Case

MISTAKES = [
    ("r", 57.29578, "column 'r' looks like deg/s"),
    ("vx", 3.6, "column 'vx' looks like km/h"),
    ("ay", 1 / 9.80665, "column 'ay' looks like g"),
    ("delta", 15.0, "column 'delta' looks like the steering-wheel angle"),
]


@pytest.mark.parametrize("column, factor, cause", MISTAKES, ids=[m[2] for m in MISTAKES])
def test_a_unit_mistake_is_named_in_one_line_and_nothing_is_written(tmp_path, config, column, factor, cause, vsegen):
    log = Case.of("step_steer", delta=0.02).simulate(config, 100.0, 1)
    wrong = dict(log.columns)
    wrong[column] = wrong[column] * factor
    write_log(Log(wrong, "wrong.csv"), tmp_path / "wrong.csv")
    out = tmp_path / "est.csv"
    arguments = ["run", "--log", str(tmp_path / "wrong.csv"), "--estimator", "kf2dof", "--out", str(out)]
    result = vsegen(*arguments)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and cause in lines[0] and str(tmp_path / "wrong.csv") in lines[0], lines
    assert not out.exists()
    assert vsegen(*arguments, "--no-unit-check").exit_code == 0


@pytest.mark.parametrize("car", ["c_class", "rwd_saloon"])
def test_every_mistake_is_refused_on_every_scenario_of_both_cars_and_no_right_log_is(car):
    """Before, only quasi-steady cornering was judged: the steering-wheel angle without its ratio
    passed on the DLC, step steer, continuous DLC, sine and fishhook, km/h as m/s on the DLC,
    continuous DLC and sine."""
    config = load_vehicle(VEHICLES / f"{car}.toml")
    for name in (name for name, scenario in SCENARIOS.items() if scenario.scored):   # a vehicle's log
        log = Case.of(name).simulate(config, 100.0, 1)
        for axle in (None, config.driven_axle):          # the wheels chosen per sample, or the free axle
            notes: list[str] = []
            assert check_units(log, config.vehicle, axle, notes) == [] and notes == [], name
            for column, factor, cause in MISTAKES:
                wrong = dict(log.columns)
                wrong[column] = wrong[column] * factor
                with pytest.raises(LogError, match=re.escape(cause)):
                    check_units(Log(wrong, f"{name}.csv"), config.vehicle, axle)


def test_a_signal_that_stays_zero_where_motion_is_predicted_is_refused_without_a_traceback(config):
    log = Case.of("input_extremes").simulate(config, 100.0, 1)     # r is 0 while the wheels steer
    with pytest.raises(LogError, match=r"r / r_model\(delta\) = 0 over .* a unit or a sign is wrong"):
        check_units(log, config.vehicle, None)


def test_a_log_that_cannot_be_judged_says_so(tmp_path, config, vsegen):
    """A log without wheel speeds whose car barely turns: the run says which units were not checked."""
    log = Case.of("sine_steer", amplitude=0.002).simulate(config, 100.0, 1)
    bare = {k: v for k, v in log.columns.items() if not k.startswith("omega")}
    write_log(Log(bare, "straight.csv"), tmp_path / "straight.csv")
    result = vsegen("run", "--log", tmp_path / "straight.csv", "--estimator", "kf2dof", "--out", tmp_path / "e.csv")
    assert result.exit_code == 0, result.output
    said = [line for line in result.stderr.splitlines() if "units not checked" in line]
    assert len(said) == 1 and "delta (too little steering" in said[0] and "ay (too little motion)" in said[0]


@pytest.mark.parametrize("car", ["c_class", "rwd_saloon"])
def test_a_frozen_gyro_is_said_and_the_log_is_judged_on_the_rest(car, tmp_path, vsegen):
    """Before, a gyro frozen for 6 s made r / (R_eff (omega_rr - omega_rl) / t_w) = -0.159 and the
    log was refused as a unit or sign mistake."""
    config = load_vehicle(VEHICLES / f"{car}.toml")
    log = Case.of("continuous_dlc", freeze="r:3:6").simulate(config, 100.0, 1)
    notes: list[str] = []
    assert check_units(log, config.vehicle, config.driven_axle, notes) == []
    assert notes == ["column 'r' repeats one value for 6.00 s from t = 3.00 s: a frozen sensor or CAN signal? "
                     "(its unit was judged on the rest)"]
    write_log(Log(dict(log.columns), "frozen.csv"), tmp_path / "frozen.csv")
    result = vsegen("run", "--log", tmp_path / "frozen.csv", "--vehicle", VEHICLES / f"{car}.toml", "--estimator",
                    "kf2dof", "--out", tmp_path / "est.csv")
    assert result.exit_code == 0 and "column 'r' repeats one value for 6.00 s" in result.stderr


@pytest.mark.parametrize("factor", [1.3, 1 / 1.3])
def test_a_yaw_rate_scaled_by_a_typo_is_said(config, factor):
    """A yaw-rate factor typed 30 % wrong in a DBC passes the unit band (0.6 to 1.6) but is said."""
    log = Case.of("dlc").simulate(config, 100.0, 1)
    scaled = dict(log.columns)
    scaled["r"] = scaled["r"] * factor
    notes: list[str] = []
    assert check_units(Log(scaled, "typo.csv"), config.vehicle, config.driven_axle, notes) == []
    (note,) = notes
    assert f"the yaw rate reads {abs(factor - 1):.0%} {'above' if factor > 1 else 'below'} the wheel speeds'" in note


def test_a_spinning_inner_wheel_of_the_driven_axle_is_no_unit_mistake():
    """A rear-wheel-drive car in a long 80 km/h corner, its unloaded inner rear wheel spinning up and
    v_x taken from the driven wheels: before, the check judged r by that axle (the one rolling
    nearest v_x) and refused a healthy log ("-1.49 ... a unit or a sign is wrong")."""
    config = load_vehicle(VEHICLES / "rwd_saloon.toml")
    log = Case.of("step_steer", delta=0.03, duration=8.0).simulate(config, 100.0, 1)
    spinning = dict(log.columns)
    inner = "omega_rl" if float(log["r"][-1]) < 0 else "omega_rr"
    spinning[inner] = np.where(log["t"] > 1.5, spinning[inner] * 1.15, spinning[inner])
    radius = config.vehicle["wheel_radius"]                       # the ECU's v_x from the driven wheels
    spinning["vx"] = radius * (np.abs(spinning["omega_rl"]) + np.abs(spinning["omega_rr"])) / 2
    for axle in ("rear", None):
        assert check_units(Log(spinning, "corner.csv"), config.vehicle, axle) == []
    wrong = dict(spinning, r=spinning["r"] * 57.29578)
    with pytest.raises(LogError, match="looks like deg/s"):
        check_units(Log(wrong, "corner.csv"), config.vehicle, "rear")
