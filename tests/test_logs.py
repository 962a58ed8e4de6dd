"""Log CSV I/O: exact round trip, atomic writes, one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

from vsegen.harness.logs.table import LogError, read_log, write_log
from vsegen.harness.sim.scenarios import Case


def test_round_trip_is_exact(tmp_path, config):
    log = Case.of("invalid_inputs").simulate(config, 100.0)
    path = tmp_path / "log.csv"
    write_log(log, path)
    back = read_log(path)
    assert list(back.columns) == list(log.columns)
    for name in log.columns:
        np.testing.assert_array_equal(back[name], log[name])
    assert back.sample_time == pytest.approx(0.01)
    assert [p.name for p in tmp_path.iterdir()] == ["log.csv"]


GOOD = "t,delta,vx,ax,ay,r,extra\n0.00,0,20,0,0,0,a1\n0.01,0,20,0,0,0,a2\n0.02,0,20,0,0,0,a3\n"


@pytest.mark.parametrize("text,fragment", [
    ("", ":1: empty file"),
    ("t,delta,vx,ax,ay\n0,0,0,0,0\n0.01,0,0,0,0\n", ":1: missing column 'r'"),
    (GOOD.replace("0.01,0,20,0,0,0", "0.01,0,20,0,x,0"), ":3: column 'ay': 'x' is not a number"),
    (GOOD.replace("0.02,0,20", "0.005,0,20"), ":4: column 't' = 0.005 after 0.01"),
    (GOOD.replace("0.01,0,20,0,0,0,a2", "0.01,0,20"), ":3: 3 cells: expected 7"),
    (GOOD.replace("0.01,0,20", "0.01,17,20"), ":3: column 'delta' = 17.0: expected |delta| <= 1 rad (a larger"),
    (GOOD.replace(",0,20,", ",0,200,"), "km/h"),
    (GOOD.replace("0.01,0,20", "nan,0,20"), "column 't' = nan"),
])
def test_bad_logs(tmp_path, text, fragment):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(LogError) as error:
        read_log(path)
    assert fragment in str(error.value) and "\n" not in str(error.value)
    assert str(error.value).startswith(str(path))


def test_unknown_columns_kept_and_nan_inputs_allowed(tmp_path):
    path = tmp_path / "ok.csv"
    path.write_text(GOOD.replace("0.01,0,20,0,0,0", "0.01,0,20,0,nan,0"))
    log = read_log(path)
    assert list(log["extra"]) == ["a1", "a2", "a3"] and np.isnan(log["ay"][1])
    write_log(log, tmp_path / "again.csv")
    assert (tmp_path / "again.csv").read_text().splitlines()[2].endswith(",nan,0,a2")


def test_binary_junk(tmp_path):
    path = tmp_path / "junk.csv"
    path.write_bytes(bytes(range(256)))
    with pytest.raises(LogError, match="not a text file"):
        read_log(path)


def _jittered_log(tmp_path, drop=(), gap_after=None):
    """A 100 Hz CSV log with +-0.2 ms time-stamp jitter, ``drop`` sample indices left out and a
    0.3 s gap after sample ``gap_after``; delta counts the samples (0, 1, 2, ...)."""
    rng = np.random.default_rng(5)
    t = np.arange(0, 2, 0.01) + rng.uniform(-2e-4, 2e-4, 200)
    k = np.arange(200)
    if gap_after is not None:
        t[gap_after + 1:] += 0.3
    keep = np.setdiff1d(k, drop)
    rows = "".join(f"{float(t[i])!r},{float(i) * 1e-4!r},20,0,0,0\n" for i in keep)
    path = tmp_path / "jittered.csv"
    path.write_text("t,delta,vx,ax,ay,r\n" + rows)
    return path


def test_a_jittered_log_lands_on_a_uniform_grid_causally(tmp_path):
    log = read_log(_jittered_log(tmp_path, drop=(50,)))
    assert log.sample_time == pytest.approx(0.01, abs=1e-12)
    assert np.allclose(np.diff(log["t"]), 0.01, rtol=0, atol=1e-12)
    sample = np.round(log["delta"] / 1e-4).astype(int)
    assert sample[0] == 0 and list(sample[48:53]) == [48, 49, 49, 51, 52]  # the dropped one: held
    original = np.arange(0, 2, 0.01) + np.random.default_rng(5).uniform(-2e-4, 2e-4, 200)
    assert np.all(original[sample] <= log["t"] + 1e-15)  # never a sample from after its tick
    assert "jitter +-0.2" in log.notes["resampled"] and "gaps" not in log.notes


def test_across_a_long_gap_the_inputs_are_nan_and_the_gap_is_reported(tmp_path):
    log = read_log(_jittered_log(tmp_path, gap_after=99))
    missing = np.isnan(log["delta"])
    assert 15 <= missing.sum() <= 25 and np.all(np.isnan(log["r"][missing]))
    assert "1 gap(s) longer than 0.1 s" in log.notes["gaps"]


@pytest.mark.parametrize("suffix, compress", [(".gz", "gzip"), (".bz2", "bz2"), (".xz", "lzma")])
def test_compressed_logs_are_read_by_their_suffix(tmp_path, suffix, compress):
    import importlib

    module = importlib.import_module(compress)
    path = tmp_path / f"log.csv{suffix}"
    path.write_bytes(module.compress(GOOD.encode()))
    assert read_log(path)["t"].tolist() == [0.0, 0.01, 0.02]
    broken = tmp_path / f"broken.csv{suffix}"
    broken.write_bytes(GOOD.encode())
    with pytest.raises(LogError, match=rf"broken.csv{suffix}: cannot decompress CSV log"):
        read_log(broken)


def test_written_files_get_the_mode_the_umask_allows(tmp_path):
    import os

    from vsegen.harness.logs.table import Log

    previous = os.umask(0o022)
    try:
        write_log(Log({"t": np.array([0.0, 0.01]), "beta": np.array([0.0, 0.0])}), tmp_path / "est.csv")
    finally:
        os.umask(previous)
    assert (tmp_path / "est.csv").stat().st_mode & 0o777 == 0o644
