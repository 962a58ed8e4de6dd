"""Unit mistakes that pass the range checks are caught from the redundancy of the log (v_x and r
against the wheel speeds, a_y against r v_x, delta against the bicycle model's yaw rate) in every
manoeuvre: one line naming the column and the likely cause, exit 2, nothing written;
--no-unit-check runs anyway; what could not be checked is said in one line; the simulated logs of
both truth cars pass."""

from __future__ import annotations

import re

import pytest
from locations import VEHICLES

from vsegen.harness.logs.table import Log, LogError, write_log
from vsegen.harness.logs.units import check_units
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
    for name in SCENARIOS:
        log = Case.of(name).simulate(config, 100.0, 1)
        assert check_units(log, config.vehicle) == [], name
        for column, factor, cause in MISTAKES:
            wrong = dict(log.columns)
            wrong[column] = wrong[column] * factor
            with pytest.raises(LogError, match=re.escape(cause)):
                check_units(Log(wrong, f"{name}.csv"), config.vehicle)


def test_a_log_that_cannot_be_judged_says_so(tmp_path, config, vsegen):
    """A log without wheel speeds whose car barely turns: the run says which units were not checked."""
    log = Case.of("sine_steer", amplitude=0.002).simulate(config, 100.0, 1)
    bare = {k: v for k, v in log.columns.items() if not k.startswith("omega")}
    write_log(Log(bare, "straight.csv"), tmp_path / "straight.csv")
    result = vsegen("run", "--log", tmp_path / "straight.csv", "--estimator", "kf2dof", "--out", tmp_path / "e.csv")
    assert result.exit_code == 0, result.output
    said = [line for line in result.stderr.splitlines() if "units not checked" in line]
    assert len(said) == 1 and "delta (too little steering" in said[0] and "ay (too little motion)" in said[0]
