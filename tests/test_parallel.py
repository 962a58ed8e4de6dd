"""Speed machinery of the harness: the on-disk log cache, worker processes, progress lines."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from rich.console import Console

from vsegen.harness.jobs import pool as parallel
from vsegen.harness.jobs.memo import clear_all
from vsegen.harness.jobs.pool import ProcessPool, WorkerCountError, worker_count
from vsegen.harness.jobs.progress import RunProgress
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim import log_cache
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.verify.equivalence import verify

CASE = Case.of("step_steer", duration=2.0)


@pytest.fixture
def empty_cache(tmp_path, monkeypatch, cleared_memos):
    monkeypatch.setenv("VSEGEN_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache" / "logs"


def test_a_simulated_log_is_stored_once_and_read_back_exactly(config, empty_cache, monkeypatch):
    first = CASE.simulate(config, 100.0, seed=3)
    (entry,) = empty_cache.glob("*.npz")
    clear_all()
    monkeypatch.setattr(Case, "_simulate", lambda *args: pytest.fail("simulated again"))
    again = CASE.simulate(config, 100.0, seed=3)
    assert list(again.columns) == list(first.columns) and again.notes == first.notes
    for name in first.columns:
        np.testing.assert_array_equal(again[name], first[name])
    assert entry.exists()


def test_the_key_follows_the_truth_car_not_the_estimator_settings(config, write_vehicle):
    key = log_cache.log_key(config, "dlc", {"mu": 1.0}, 100.0, 1)
    retuned = load_vehicle(write_vehicle("yaw_rate_band = 0.2", "yaw_rate_band = 0.3"))
    heavier = load_vehicle(write_vehicle("tyre_nominal_load = 4000.0", "tyre_nominal_load = 4100.0"))
    noisier = load_vehicle(write_vehicle("gyro_noise = 0.017453", "gyro_noise = 0.02"))
    assert log_cache.log_key(retuned, "dlc", {"mu": 1.0}, 100.0, 1) == key
    for other in (heavier, noisier):
        assert log_cache.log_key(other, "dlc", {"mu": 1.0}, 100.0, 1) != key
    for args in (("dlc", {"mu": 0.9}, 100.0, 1), ("dlc", {"mu": 1.0}, 200.0, 1),
                 ("dlc", {"mu": 1.0}, 100.0, 2), ("fishhook", {"mu": 1.0}, 100.0, 1)):
        assert log_cache.log_key(config, *args) != key


def test_a_damaged_entry_is_simulated_again(config, empty_cache, monkeypatch):
    first = CASE.simulate(config, 100.0, seed=4)
    (entry,) = empty_cache.glob("*.npz")
    entry.write_bytes(b"not a zip file")
    clear_all()
    again = CASE.simulate(config, 100.0, seed=4)
    np.testing.assert_array_equal(again["ay"], first["ay"])
    assert entry.read_bytes()[:2] == b"PK"


def test_a_vehicle_configuration_pickles_to_an_equal_one(config):
    copy = pickle.loads(pickle.dumps(config))
    assert copy == config and copy.fingerprint() == config.fingerprint()
    with pytest.raises(TypeError):
        copy.vehicle["mass"] = 1.0          # still read-only


def test_workers_return_what_the_serial_run_returns_in_job_order(config):
    cases = (CASE, Case.of("sine_steer", duration=2.0))
    jobs = ("kf2dof", "switching")
    serial = verify(config, jobs, cases, workers=ProcessPool(1))
    finished = []
    with ProcessPool(2) as pool:
        spread = verify(config, jobs, cases, workers=pool, on_done=finished.append)
    assert [(r.estimator, r.case) for r in spread] == [(r.estimator, r.case) for r in serial]
    assert sorted(id(r) for r in finished) == sorted(id(r) for r in spread)
    assert spread == serial                  # every difference figure equal, bit for bit


def test_worker_count_comes_from_the_environment(monkeypatch):
    monkeypatch.setenv("VSEGEN_WORKERS", "3")
    assert worker_count() == 3
    monkeypatch.setenv("VSEGEN_WORKERS", "many")
    with pytest.raises(WorkerCountError, match="VSEGEN_WORKERS = 'many': expected a positive"):
        worker_count()


def test_few_jobs_run_in_this_process(monkeypatch):
    monkeypatch.setattr(ProcessPool, "_started", lambda self: pytest.fail("started a pool"))
    with ProcessPool(2) as pool:
        assert pool.map(pow, [(2, 3)] * (parallel.MIN_PARALLEL_JOBS - 1)) == [8, 8, 8]


def test_progress_prints_a_line_per_finished_group():
    console = Console(record=True, width=100, force_terminal=False)
    with RunProgress("verifying", {"a": 2, "b": 1}, console=console) as progress:
        progress.done("a")
        progress.done("b", ok=False)
        assert "verifying a" not in console.export_text(clear=False)
        progress.done("a")
    lines = console.export_text().splitlines()
    assert [line.split(" (")[0] for line in lines] == ["verifying b: 1 FAILED", "verifying a: ok"]
