"""vsegen tune never hands back a worse or silently wrong estimator: it searches only the settings
whose regime the training logs cover, rejects silent candidates, ranks by mean and worst log with
a prior towards the base, cross-validates across logs and refuses (exit 3, nothing written) when
the result is worse than the base."""

from __future__ import annotations

import math

import pytest
from locations import VEHICLES

from bench.table3 import PAPER_SWITCHING
from vsegen.harness.logs.table import Log, write_log
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.tune import objective as rule
from vsegen.harness.tune import search
from vsegen.harness.tune.coverage import MIN_TIME, coverage, frozen_settings
from vsegen.harness.tune.search import Trial, cross_validated
from vsegen.model.estimators import DEFINITIONS

HIGH_FRICTION = Case.of("dlc", speed_kmh=80.0, mu=1.0)
LOW_FRICTION = Case.of("dlc", speed_kmh=80.0, mu=0.5)


@pytest.fixture(scope="module")
def saloon():
    return load_vehicle(VEHICLES / "rwd_saloon.toml")


@pytest.fixture(scope="module")
def dlc_logs(saloon):
    return {"high": HIGH_FRICTION.simulate(saloon, 100.0, 1), "low": LOW_FRICTION.simulate(saloon, 100.0, 1)}


def without_friction(log: Log) -> Log:
    """The log as a real logger writes it: no mu column."""
    return Log({k: v for k, v in log.columns.items() if k != "mu"}, log.source, log.notes)


def test_coverage_sees_low_friction_only_where_the_road_has_it(saloon, dlc_logs):
    high, low = coverage([dlc_logs["high"]], saloon), coverage([dlc_logs["low"]], saloon)
    assert high.low_friction_limit < MIN_TIME <= low.low_friction_limit
    assert high.beyond_linear >= MIN_TIME and high.ay_max > 4.0
    assert 21.0 < high.speed_min <= high.speed_max < 23.5 and 0.0 < high.quasi_steady < 1.0


def test_without_a_friction_column_low_friction_is_inferred_from_the_yaw_rate():
    """Steady cornering at the limit of a mu 0.5 road: the yaw rate leaves the linear model's for
    the steer angle at an |a_y| a dry road would still hold linearly; a dry road's manoeuvres do not."""
    c_class = load_vehicle(VEHICLES / "c_class.toml")
    limit = coverage([without_friction(Case.of("step_steer", mu=0.5).simulate(c_class, 100.0, 1))], c_class)
    assert not limit.friction_known and "inferred" in limit.describe()
    assert limit.low_friction_limit >= MIN_TIME
    for case in (HIGH_FRICTION, Case.of("step_steer"), Case.of("sine_steer"), Case.of("fishhook")):
        assert coverage([without_friction(case.simulate(c_class, 100.0, 1))], c_class).low_friction_limit < 0.5


def test_a_dry_race_lap_is_no_low_friction_road(revs_lap, revs_car):
    """The Revs lap (1.1 g, no mu column): its corner entries leave the linear model's yaw rate, but a
    road that carries 0.6 g and more is not called low friction."""
    lap = coverage([revs_lap.window(0.0, 275.0)], revs_car)
    assert lap.ay_max > 10.0 and lap.beyond_linear >= MIN_TIME
    assert lap.low_friction_limit == 0.0


def test_a_race_lap_tunes_switchings_dwell_but_not_its_low_friction_threshold(revs_lap, revs_car):
    """The hand-over: how long the kinematic scheme may stay acts beyond the linear range, which a
    race lap holds; the threshold acts near the limit of a low-friction road, which it does not."""
    regimes = {key: t.regime for key, t in DEFINITIONS["switching"].tunable.items()}
    frozen = frozen_settings(regimes, coverage([revs_lap.window(0.0, 275.0)], revs_car))
    assert "threshold" in frozen and "kinematic_max_dwell" not in frozen
    assert "kinematic_max_dwell" in {d.key for d in search.dimensions(revs_car, "switching", tuple(frozen))}


def test_settings_of_an_uncovered_regime_keep_their_base_values(saloon, dlc_logs):
    regimes = {key: t.regime for key, t in DEFINITIONS["switching"].tunable.items()}
    frozen = frozen_settings(regimes, coverage([dlc_logs["high"]], saloon))
    assert {"threshold", "hysteresis", "lateral_acceleration_band"} <= set(frozen)
    assert "process_noise" not in frozen and "measurement_noise" not in frozen
    assert "near the friction limit" in frozen["threshold"]
    assert "threshold" not in frozen_settings(regimes, coverage([dlc_logs["high"]], saloon), freed=("threshold",))
    assert not frozen_settings(regimes, coverage([dlc_logs["high"], dlc_logs["low"]], saloon))
    dims = {d.key for d in search.dimensions(saloon, "switching", tuple(frozen))}
    assert dims and not dims & set(frozen)


def test_the_rule_rejects_silence_weighs_the_worst_log_and_pulls_towards_the_base():
    assert rule.ranked([0.01, 0.01], [0.0, 0.6], 0.0, 0.01) == math.inf
    assert rule.combined([0.01, 0.03]) == pytest.approx(0.5 * 0.02 + 0.5 * 0.03)
    assert rule.combined([0.01, float("nan")]) == math.inf
    scales = {"q": (1e-4, 1e2, True), "t": (0.5, 4.0, False)}
    assert rule.distance({"q": 1.0, "t": 1.5}, {"q": 1.0, "t": 1.5}, scales) == 0.0
    assert rule.distance({"q": 10.0, "t": 1.5}, {"q": 1.0, "t": 1.5}, scales) == pytest.approx(0.5)
    one_log, four_logs = rule.prior(1.0, 0.01, 1), rule.prior(1.0, 0.01, 4)
    assert one_log == pytest.approx(4 * four_logs) and four_logs > 0


def test_cross_validation_scores_each_log_with_the_choice_of_the_others():
    base = Trial({}, [1.0, 1.0, 1.0, 1.0], [0.0] * 4, 0.0, rule.ranked([1.0] * 4, [0.0] * 4, 0.0, 1.0))
    overfit = Trial({"x": 2.0}, [0.5, 0.5, 0.5, 3.0], [0.0] * 4, 0.0,
                    rule.ranked([0.5, 0.5, 0.5, 3.0], [0.0] * 4, 0.0, 1.0))
    general = Trial({"x": 1.1}, [0.9, 0.9, 0.9, 0.9], [0.0] * 4, 0.0,
                    rule.ranked([0.9] * 4, [0.0] * 4, 0.0, 1.0))
    assert cross_validated([base, general], base) == (1.0, pytest.approx(0.9))
    base_cv, chosen_cv = cross_validated([base, overfit], base)
    # with the fourth log in, its worst log keeps the base chosen (1.0 each); left out, the fourth
    # log is scored with the over-fitted choice of the other three (3.0): worse than the base
    assert (base_cv, chosen_cv) == (1.0, pytest.approx((1.0 * 3 + 3.0) / 4))


def test_harm_names_every_way_the_result_is_worse():
    base = Trial({}, [1.0, 1.0], [0.0, 0.0], 0.0, 1.0)
    worse = Trial({"x": 2.0}, [0.5, 1.2], [0.0, 0.0], 0.1, 0.9)
    result = search.TuneResult(coverage=None, frozen={}, dimensions=[], trials=[worse], base=base, best=worse,
                               train_names=["a.csv", "b.csv"], cross_validated=(1.0, 1.2), holdout=(1.0, 1.1),
                               holdout_silent=(0.0, 0.7), harm=[], text="")
    found = search.harm(result)
    assert len(found) == 4
    assert found[0].startswith("training log b.csv") and "cross-validated" in found[1]
    assert "hold-out" in found[2] and "silently wrong for 0.70 s" in found[3]
    fine = search.TuneResult(coverage=None, frozen={}, dimensions=[], trials=[], base=base, best=base,
                             train_names=["a.csv", "b.csv"], cross_validated=(1.0, 1.0), holdout=None,
                             holdout_silent=None, harm=[], text="")
    assert search.harm(fine) == []


def test_a_worse_result_is_refused_with_exit_3_and_no_file(tmp_path, saloon, dlc_logs, vsegen, monkeypatch):
    write_log(dlc_logs["high"], tmp_path / "train.csv")
    monkeypatch.setattr(search, "harm", lambda result: ["hold-out: 0.2000 against 0.1000 for the base"])
    arguments = ["tune", "--estimator", "kf2dof", "--vehicle", VEHICLES / "rwd_saloon.toml", "--log",
                 tmp_path / "train.csv", "--trials", "3", "--scheduler", "serial", "--out", tmp_path / "tuned.toml"]
    refused = vsegen(*arguments)
    assert refused.exit_code == 3 and not (tmp_path / "tuned.toml").exists()
    assert len(refused.stderr.strip().splitlines()) == 1 and "worse than the base" in refused.stderr
    assert "--accept-worse" in refused.stderr
    accepted = vsegen(*arguments, "--accept-worse")
    assert accepted.exit_code == 0 and (tmp_path / "tuned.toml").exists()
    assert "written although worse" in accepted.stderr


def test_the_tuned_file_says_how_it_was_tuned(tmp_path, saloon, dlc_logs, vsegen):
    write_log(dlc_logs["high"], tmp_path / "train.csv")
    result = vsegen("tune", "--estimator", "switching", "--vehicle", VEHICLES / "rwd_saloon.toml", "--log",
                    tmp_path / "train.csv", "--trials", "3", "--scheduler", "serial", "--accept-worse",
                    "--out", tmp_path / "tuned.toml")
    assert result.exit_code == 0, result.output
    assert "kept at its base value: threshold" in result.stdout and "--free threshold" in result.stdout
    header = (tmp_path / "tuned.toml").read_text().splitlines()[:6]
    assert header[0].startswith("# vsegen tune switching: training coverage: 1 log(s)")
    assert any(line.startswith("# kept at its base value: threshold") for line in header)
    assert any("cross-validated rmse (leave one log out)" in line for line in header)


def test_a_training_set_that_makes_things_worse_is_refused(tmp_path, vsegen):
    """The saloon's switching as the paper has it (bench.table3.PAPER_SWITCHING: linear KF with the
    paper's noise, no learned offset, unbounded kinematic dwell)
    tuned on four dry test-track manoeuvres (the regime of its threshold and bands not covered):
    worse on a training log and on the continuous-DLC hold-out, so refused."""
    saloon = load_vehicle(VEHICLES / "rwd_saloon.toml")
    paper = tmp_path / "rwd_saloon.toml"
    paper.write_text(with_settings((VEHICLES / "rwd_saloon.toml").read_text(), "estimator.switching",
                                   **PAPER_SWITCHING))
    arguments = ["tune", "--estimator", "switching", "--vehicle", paper, "--scheduler",
                 "serial", "--out", tmp_path / "tuned.toml"]
    for i, case in enumerate((HIGH_FRICTION, Case.of("step_steer"), Case.of("sine_steer"), Case.of("fishhook"))):
        write_log(case.simulate(saloon, 100.0, 1), tmp_path / f"track{i}.csv")
        arguments += ["--log", tmp_path / f"track{i}.csv"]
    write_log(Case.of("continuous_dlc", speed_kmh=80.0).simulate(saloon, 100.0, 1), tmp_path / "holdout.csv")
    refused = vsegen(*arguments, "--holdout", tmp_path / "holdout.csv")
    assert refused.exit_code == 3, refused.output
    assert not (tmp_path / "tuned.toml").exists()
    assert "kept at its base value: threshold" in refused.stdout
    assert "hold-out:" in refused.stderr and "nothing written" in refused.stderr
