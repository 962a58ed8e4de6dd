"""Log CSV I/O: exact round trip, atomic writes, one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

from harness.logs import LogError, read_log, write_log
from harness.scenarios import Case


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
    (GOOD.replace("0.02,0,20", "0.025,0,20"), ":3: column 't': step 0.01 s: expected a constant"),
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
