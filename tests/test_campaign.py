"""`vsegen campaign`: rows that agree with `run` and `score` of each log, failed logs listed with
exit 1 while the rest goes on, a cache that makes a second campaign compute only the new logs, a
baseline comparison that finds the logs where new settings are worse, and (slow) a real Dask
scheduler with two workers sharing the work."""

from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np
import pyarrow.parquet as pq
import pytest
from asammdf import MDF, Signal

from vsegen.harness.campaign.row import RowSums
from vsegen.harness.campaign.run import Settings, find_logs, run_campaign
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.logs.stream import in_memory
from vsegen.harness.logs.table import LogError, write_log
from vsegen.harness.score.metrics import score, silent_error_time
from vsegen.harness.sim.scenarios import Case

ESTIMATORS = ("kf2dof", "switching")


@pytest.fixture(scope="module")
def database(config, tmp_path_factory):
    """A folder of logs: two CSV drives, one MDF4 drive, one broken file."""
    folder = tmp_path_factory.mktemp("database")
    for name, case in (("dlc_60.csv", Case.of("dlc", speed_kmh=60.0)),
                       ("sine.csv", Case.of("sine_steer", duration=6.0))):
        write_log(case.simulate(config, 100.0, 3), folder / name)
    drive = Case.of("dlc").simulate(config, 100.0, 4)
    mdf = MDF(version="4.10")
    mdf.append([Signal(drive[name], drive["t"], name=name) for name in ("delta", "vx", "ax", "ay", "r")])
    mdf.save(folder / "drive.mf4")
    (folder / "broken.csv").write_text("t,delta\n0,0\n")
    return folder


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("VSEGEN_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _settings(config, path):
    import hashlib

    return Settings(path.stem, config, hashlib.sha256(path.read_bytes()).hexdigest())


def test_a_campaign_writes_rows_that_agree_with_run_and_score(config, database, cache, vsegen, tmp_path):
    result = vsegen("campaign", str(database), *(f"--estimator={n}" for n in ESTIMATORS), "--scheduler", "serial",
                    "--out", str(tmp_path / "out"))
    assert result.exit_code == 1, result.output
    assert "broken.csv:1: missing columns" in result.stderr, result.stderr
    rows = pq.read_table(tmp_path / "out" / "results.parquet").to_pylist()
    assert sorted({r["log"].rsplit("/", 1)[1] for r in rows}) == ["dlc_60.csv", "drive.mf4", "sine.csv"]
    assert len(rows) == 3 * len(ESTIMATORS)
    log = Case.of("dlc", speed_kmh=60.0).simulate(config, 100.0, 3)
    for name in ESTIMATORS:
        row = next(r for r in rows if r["log"].endswith("dlc_60.csv") and r["estimator"] == name)
        estimates = run_estimator(config, name, log)
        beta = next(s for s in score(log, estimates) if s.signal == "beta")
        assert row["beta_rmse_deg"] == pytest.approx(beta.rmse, rel=1e-9)
        assert row["beta_max_deg"] == pytest.approx(beta.max, rel=1e-12)
        assert row["time_flagged_s"] == pytest.approx(np.count_nonzero(estimates["status"]) * 0.01)
        assert row["silent_longest_s"] == pytest.approx(silent_error_time(log, estimates)[0])
        assert row["duration_s"] == pytest.approx(len(log) * 0.01)
        assert row["distance_km"] == pytest.approx(np.sum(log["vx"]) * 0.01 / 1000)
    mdf_row = next(r for r in rows if r["log"].endswith("drive.mf4"))
    assert math.isnan(mdf_row["beta_rmse_deg"])          # no reference channel in the MDF4
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert "## Logs that failed" in summary and "| broken.csv |" in summary
    html = (tmp_path / "out" / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 3


def test_a_second_campaign_computes_only_the_added_logs(config, database, cache, tmp_path):
    settings = [_settings(config, config_path())]
    first = run_campaign(find_logs([str(database / "*.csv")]), ESTIMATORS, settings, None, None, DaskPool("serial"))
    assert (first.computed, first.cached, len(first.failed)) == (4, 0, 1)
    added = tmp_path / "added.csv"
    write_log(Case.of("dlc", speed_kmh=70.0).simulate(config, 100.0, 5), added)
    second = run_campaign(find_logs([str(database / "*.csv"), str(added)]), ESTIMATORS, settings, None, None,
                          DaskPool("serial"))
    assert (second.computed, second.cached) == (2, 4)
    assert [_plain(r) for r in second.rows if not r["log"].endswith("added.csv")] == [_plain(r) for r in first.rows]


def _plain(row: dict) -> dict:
    """``row`` with NaN as None, so that equal rows compare equal."""
    return {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in row.items()}


def config_path():
    from locations import DEFAULT_VEHICLE

    return DEFAULT_VEHICLE


def test_the_baseline_comparison_lists_the_logs_where_new_settings_are_worse(database, cache, vsegen, tmp_path,
                                                                            write_vehicle):
    heavy = write_vehicle("mass = 1412.0", "mass = 2100.0", name="heavy.toml")   # a wrong car model
    out = tmp_path / "out"
    result = vsegen("campaign", str(database / "*.csv"), "--estimator", "kf2dof", "--vehicle", str(heavy),
                    "--baseline", str(config_path()), "--scheduler", "serial", "--out", str(out))
    assert result.exit_code == 1, result.output
    summary = (out / "summary.md").read_text()
    worse = summary.split("## Where the new settings are worse than the baseline")[1]
    assert "| dlc_60.csv | kf2dof | beta RMSE (deg) |" in worse
    release = vsegen("campaign", str(database / "dlc_60.csv"), "--estimator", "kf2dof", "--scheduler", "serial",
                     "--baseline", str(out / "results.parquet"), "--out", str(tmp_path / "release"))
    assert release.exit_code == 0, release.output
    assert "No log is worse." in (tmp_path / "release" / "summary.md").read_text()
    again = vsegen("campaign", str(database / "*.csv"), "--estimator", "kf2dof", "--vehicle", str(heavy),
                   "--scheduler", "serial", "--baseline", str(out / "results.parquet"),
                   "--out", str(tmp_path / "again"))
    assert again.exit_code == 1 and "0 computed" in again.output      # broken.csv; every run from the cache
    assert "No log is worse." in (tmp_path / "again" / "summary.md").read_text()   # heavy against heavy, not c_class


def test_a_baseline_table_of_several_settings_files_is_matched_by_name_or_refused(database, cache, vsegen, tmp_path):
    from vsegen.harness.campaign.report import baseline_settings, write_table

    rows = [{"log": "a.csv", "estimator": "kf2dof", "settings": label, "duration_s": 1.0, "time_flagged_s": 0.0,
             "beta_rmse_deg": 0.1, "silent_longest_s": 0.0} for label in ("car", "car_v2", "baseline:car_v1")]
    assert baseline_settings(rows, ["car_v2"], tmp_path / "t.parquet") == {"car_v2": "car_v2"}
    assert baseline_settings(rows[:1] + rows[2:], ["car_v3"], tmp_path / "t.parquet") == {"car_v3": "car"}
    write_table(rows, tmp_path / "two.parquet")
    result = vsegen("campaign", str(database / "dlc_60.csv"), "--baseline", str(tmp_path / "two.parquet"),
                    "--scheduler", "serial", "--out", str(tmp_path / "out"))
    assert result.exit_code == 2 and len(result.stderr.strip().splitlines()) == 1, result.output
    assert "two.parquet: rows of the settings car, car_v2: expected one of them to be named c_class" in result.stderr


def test_a_silently_wrong_run_is_listed_and_fails_the_campaign(database, cache, vsegen, tmp_path, write_vehicle):
    wrong = write_vehicle("mass = 1412.0", "mass = 5000.0", name="wrong.toml")      # switching: 0.80 s silent
    out = tmp_path / "out"
    result = vsegen("campaign", str(database / "dlc_60.csv"), "--estimator", "switching", "--vehicle", str(wrong),
                    "--scheduler", "serial", "--out", str(out))
    assert result.exit_code == 1, result.output
    assert "vsegen: silently wrong: switching (wrong) on" in result.stderr and "for 0.80 s" in result.stderr
    section = (out / "summary.md").read_text().split("## Silently wrong (a bug)")[1]
    assert "| dlc_60.csv | wrong | switching | 0.80 |" in section
    assert "Silently wrong (a bug)" in (out / "report.html").read_text()


def test_campaign_mistakes_are_one_line(vsegen, database, cache, tmp_path):
    result = vsegen("campaign", str(tmp_path / "nothing*.csv"), "--scheduler", "serial")
    assert result.exit_code == 2 and "no log: expected a log file" in result.stderr
    (tmp_path / "old.parquet").write_text("not parquet")
    for baseline, fragment in (("old.parquet", "not a readable Parquet table"), ("gone.parquet", "no such file")):
        result = vsegen("campaign", str(database / "dlc_60.csv"), "--baseline", str(tmp_path / baseline),
                        "--scheduler", "serial", "--out", str(tmp_path / "out"))
        assert result.exit_code == 2 and fragment in result.stderr, result.output
        assert len(result.stderr.strip().splitlines()) == 1 and not (tmp_path / "out").exists()
    with pytest.raises(LogError):
        find_logs([str(tmp_path)])


def test_row_sums_over_chunks_equal_the_whole_logs(config):
    log = Case.of("dlc", mu=0.6, speed_kmh=90.0).simulate(config, 100.0, 1)
    estimates = run_estimator(config, "kf2dof", log)
    wrong = (np.arange(len(log)) >= 100) & (np.arange(len(log)) < 260)   # 1.6 s, 2.9 deg off, unflagged
    estimates.columns["beta"] = np.where(wrong, estimates["beta"] + 0.05, estimates["beta"])
    estimates.columns["status"] = np.where(wrong, 0.0, estimates["status"])
    whole, chunked = RowSums(0.01), RowSums(0.01)
    whole.add(log, estimates)
    for part, est in zip(in_memory(log).chunks(57), in_memory(estimates).chunks(57)):
        chunked.add(part, est)
    a, b = whole.row(), chunked.row()
    assert a["silent_longest_s"] == pytest.approx(1.6)      # the 160 wrong samples, across chunk boundaries
    assert a["silent_longest_s"] == pytest.approx(silent_error_time(log, estimates)[0])
    for key, value in a.items():
        assert b[key] == pytest.approx(value, rel=1e-12, nan_ok=True) if isinstance(value, float) else b[key] == value


@pytest.mark.slow
def test_a_real_scheduler_with_two_workers_shares_the_campaign(config, database, tmp_path, monkeypatch):
    logs = find_logs([str(database / "*.csv"), str(database / "*.mf4")])
    settings = [_settings(config, config_path())]
    monkeypatch.setenv("VSEGEN_CACHE", str(tmp_path / "serial"))
    serial = run_campaign(logs, ESTIMATORS, settings, None, None, DaskPool("serial"))
    monkeypatch.setenv("VSEGEN_CACHE", str(tmp_path / "cluster"))
    scheduler_file = tmp_path / "scheduler.json"
    processes = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--no-dashboard",
                                   "--scheduler-file", str(scheduler_file)], stderr=subprocess.DEVNULL)]
    try:
        for _ in range(100):
            if scheduler_file.exists():
                break
            time.sleep(0.1)
        import json

        address = json.loads(scheduler_file.read_text())["address"]
        processes += [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads",
                                        "1", "--no-dashboard"], stderr=subprocess.DEVNULL) for _ in range(2)]
        with DaskPool(address) as pool:
            for _ in range(100):
                if pool.workers == 2:
                    break
                time.sleep(0.2)
            cluster = run_campaign(logs, ESTIMATORS, settings, None, None, pool)
        assert len(cluster.workers) == 2 and cluster.computed == serial.computed == 6
        assert cluster.failed == serial.failed
        serial_rows = {(r["log"], r["estimator"]): r for r in serial.rows}
        for row in cluster.rows:
            assert _plain(row) == _plain(serial_rows[(row["log"], row["estimator"])])
    finally:
        for process in processes:
            process.terminate()
            process.wait(timeout=30)
