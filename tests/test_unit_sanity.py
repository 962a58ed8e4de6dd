"""Unit mistakes that pass the range checks are caught from the signals' physics (a_y against
r v_x, delta against l r / v_x): one line naming the column and the likely cause, exit 2, nothing
written; --no-unit-check runs anyway; the simulated logs of both truth cars pass."""

from __future__ import annotations

import pytest
from locations import VEHICLES

from vsegen.harness.logs.table import Log, write_log
from vsegen.harness.logs.units import check_units
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim.scenarios import VERIFICATION_SET, Case

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
def test_the_simulated_logs_of_both_cars_pass(car):
    config = load_vehicle(VEHICLES / f"{car}.toml")
    for case in VERIFICATION_SET:
        check_units(case.simulate(config, 100.0, 1), config.vehicle["wheelbase"])
