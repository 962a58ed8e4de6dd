"""vsegen tune: a search over an estimator's declared tunable settings, every candidate run as the
calibratable generated C; the same result serially, on a local Dask cluster and on a real
scheduler started as local processes."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from locations import VEHICLES

from vsegen.harness.host.build import compile_estimator, load_tuning_estimator
from vsegen.harness.logs.table import Log, write_log
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.tune.objective import combined
from vsegen.harness.tune.search import MEASURED_SPAN, Trial, TuneResult, dimensions, harm, measured_settings, tune
from vsegen.model.calibration import calibration_values
from vsegen.model.estimators import DEFINITIONS
from vsegen.model.params import parse_vehicle

TRAINING = (Case.of("sine_steer"), Case.of("dlc", speed_kmh=60.0))
HOLDOUT = (Case.of("step_steer", delta=0.03),)


@pytest.fixture(scope="module")
def saloon():
    path = VEHICLES / "rwd_saloon.toml"
    return path.read_text(), load_vehicle(path)


@pytest.fixture(scope="module")
def logs(saloon, tmp_path_factory):
    """Training and hold-out logs of the saloon (with ground truth), also written as CSV."""
    folder = tmp_path_factory.mktemp("tune_logs")
    written = {}
    for role, cases in (("train", TRAINING), ("holdout", HOLDOUT)):
        written[role] = []
        for i, case in enumerate(cases):
            log = case.simulate(saloon[1], 100.0, 1)
            write_log(log, folder / f"{role}{i}.csv")
            written[role].append((log, folder / f"{role}{i}.csv"))
    return written


def _run(saloon, logs, scheduler: str, trials: int = 12):
    text, config = saloon
    return tune(text, config, "switching", [log for log, _ in logs["train"]], [log for log, _ in logs["holdout"]],
                trials, batch=4, scheduler=scheduler)


def test_tuning_improves_training_and_a_local_cluster_gives_the_serial_result(saloon, logs, monkeypatch):
    serial = _run(saloon, logs, "serial")
    monkeypatch.setenv("VSEGEN_WORKERS", "2")
    local = _run(saloon, logs, "local")
    assert [t.score for t in local.trials] == [t.score for t in serial.trials]
    assert local.text == serial.text
    assert len(serial.trials) == 12 and len({tuple(t.point.values()) for t in serial.trials}) == 12
    assert combined(serial.best.scores) < combined(serial.base.scores)
    assert serial.holdout is not None and np.isfinite(serial.holdout[1])
    tuned = parse_vehicle(serial.text, "tuned.toml", "rwd_saloon")
    for dim in dimensions(tuned, "switching"):
        value = tuned.settings("switching")[dim.key]
        value = value if dim.index is None else np.diag(np.atleast_2d(value))[dim.index] \
            if isinstance(value[0], tuple) else value[dim.index]
        assert dim.range.low <= value <= dim.range.high, dim.label
    changed = serial.text.count("# tuned by vsegen tune (rmse over 2 log(s), 12 trials, seed 1); was")
    assert changed == len({dim.key for dim in serial.dimensions})
    assert set(serial.frozen) == {d.key for d in dimensions(tuned, "switching")} - {d.key for d in serial.dimensions}


def _tuning_and_regenerated(base, changed, name: str, log: Log) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``name``'s outputs on ``log``: the tuning build of ``base`` as compiled, then with the calibration
    of ``changed`` set at run time, and the calibratable build regenerated from ``changed``."""
    estimator, regenerated = compile_estimator(changed, name, "double", "calibratable")
    tuning = load_tuning_estimator(base, name)
    inputs = log.matrix(estimator.inputs.names)
    before = tuning.run(inputs)[0].copy()
    tuning.set_calibration(calibration_values(changed, name, estimator.parameters.names))
    return before, tuning.run(inputs)[0], regenerated.run(inputs)[0]


def test_the_tuning_build_computes_what_the_regenerated_calibratable_build_computes(saloon, logs):
    """Setting the calibration at run time is the same as regenerating with those values: the
    calibration struct is what the code reads."""
    text, config = saloon
    tuned = parse_vehicle(_run(saloon, logs, "serial", trials=3).text, "tuned.toml", "rwd_saloon")
    _, tuning, regenerated = _tuning_and_regenerated(config, tuned, "switching", logs["train"][0][0])
    assert np.array_equal(tuning, regenerated)


def test_the_growth_of_the_noise_and_the_friction_state_are_searched_where_the_file_has_them(saloon, logs):
    """fusion's file has the noise growing with a_y and a friction scale in its KF: tune searches the
    load and the friction's noise and return time, and each reaches the tuning build as regenerating
    with that value does; switching's file has the friction scale and a constant noise, kf2dof's the
    growing noise and linear tyres: tune searches only what the code has (structural)."""
    text, config = saloon
    growth, friction = {"process_noise_load"}, {"friction_noise", "friction_time"}

    def searched(name):
        return {dim.key for dim in dimensions(config, name)} & (growth | friction)

    assert (searched("fusion"), searched("switching"), searched("kf2dof")) == (growth | friction, friction, growth)
    changed = config.with_settings("fusion", process_noise_load=0.7, friction_noise=0.3, friction_time=0.4)
    base, tuning, regenerated = _tuning_and_regenerated(config, changed, "fusion", logs["train"][1][0])
    assert np.array_equal(tuning, regenerated)
    assert not np.array_equal(tuning, base)


def test_keeping_the_base_because_nothing_beat_it_is_no_harm():
    base = Trial({}, [0.010, 0.012], [0.0, 0.0], 0.0, 0.011)
    other = Trial({"threshold": 2.0}, [0.011, 0.013], [0.0, 0.0], 0.1, 0.013)
    worse_cv = (0.011, 0.013)                  # the folds chose `other`: the search rates worse than the base

    def result(best):
        return TuneResult(None, {}, [], [other], base, best, ["a", "b"], worse_cv, None, None, [], "")

    assert result(base).unchanged and harm(result(base)) == []
    assert not result(other).unchanged
    assert [line.split(":")[0] for line in harm(result(other))] == ["training log a", "training log b",
                                                                     "cross-validated (leave one log out)"]


def test_tune_needs_ground_truth_and_says_so_in_one_line(tmp_path: Path, logs, vsegen):
    log = logs["train"][0][0]
    bare = Log({k: v for k, v in log.columns.items() if k != "beta_ref"}, "bare.csv")
    write_log(bare, tmp_path / "bare.csv")
    result = vsegen("tune", "--estimator", "switching", "--log", str(tmp_path / "bare.csv"),
                    "--vehicle", str(VEHICLES / "rwd_saloon.toml"), "--out",
                    str(tmp_path / "t.toml"), "--scheduler", "serial")
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [
        f"vsegen: error: {tmp_path / 'bare.csv'}:1: missing column 'beta_ref': tune scores switching's beta "
        "against it (a log with ground truth, e.g. an optical or GNSS/INS reference)"]


def test_a_real_scheduler_and_worker_give_the_serial_result(tmp_path: Path, logs, vsegen):
    """A distributed scheduler and a worker started as separate processes, reached by address."""
    scheduler_file = tmp_path / "scheduler.json"
    processes = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--port", "0",
                                   "--no-dashboard", "--scheduler-file", str(scheduler_file)],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(300):
            if scheduler_file.exists() and scheduler_file.read_text().strip():
                break
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        processes.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                           "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        arguments = ["tune", "--estimator", "kf2dof", "--vehicle", str(VEHICLES / "rwd_saloon.toml"),
                     "--trials", "4", "--batch", "2", "--accept-worse"]
        for _, path in logs["train"]:
            arguments += ["--log", str(path)]
        runs = {}
        for scheduler in ("serial", address):
            out = tmp_path / f"tuned_{len(runs)}.toml"
            result = vsegen(*arguments, "--scheduler", scheduler, "--out", str(out))
            assert result.exit_code == 0, result.output
            runs[scheduler] = out.read_text()
        assert runs["serial"] == runs[address]
    finally:
        for process in reversed(processes):
            process.terminate()
            process.wait(timeout=30)


def test_a_measured_sensor_noise_is_searched_only_near_its_value(saloon):
    """The a_y and gyro noise identify measured for this car (R of the KF): within MEASURED_SPAN of
    the file's value, not over the whole declared range (a dry-track tune had moved the a_y noise
    60x); in a file not derived for its car, the whole range."""
    text, config = saloon
    assert measured_settings(config, "switching") == ("measurement_noise",)
    noise = config.settings("switching")["measurement_noise"]
    ranges = {d.index: (d.range.low, d.range.high) for d in dimensions(config, "switching")
              if d.key == "measurement_noise"}
    variances = [row[i] if isinstance(row, tuple) else row for i, row in enumerate(noise)]
    assert ranges == {i: (v / MEASURED_SPAN, v * MEASURED_SPAN) for i, v in enumerate(variances)}
    copied = parse_vehicle(text.replace(f'derived_for = "{config.derived_for}"', 'derived_for = "00000000"'),
                           "copied.toml", "rwd_saloon")
    full = DEFINITIONS["switching"].tunable["measurement_noise"]
    assert {(d.range.low, d.range.high) for d in dimensions(copied, "switching")
            if d.key == "measurement_noise"} == {(full.low, full.high)}
