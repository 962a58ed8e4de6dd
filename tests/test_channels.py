"""Logger logs: MDF4 channels at their own rates and CSV with the logger's names and units, mapped
onto the log columns by a channel map; the grid is causal; mistakes are one line, exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from asammdf import MDF, Signal
from locations import VEHICLES

from vsegen.harness.logs.channels import read_channel_map
from vsegen.harness.logs.mdf import read_mdf
from vsegen.harness.logs.table import read_log, write_log
from vsegen.harness.outputs.estimates import read_estimates
from vsegen.harness.sim.scenarios import Case

MAP = """[columns.delta]
channel = "SteerWhlAng"
unit = "deg"
factor = 0.0625

[columns.vx]
channel = "VehSpd"
unit = "km/h"

[columns.ay]
channel = "LatAcc"
unit = "g"

[columns.ax]
channel = "LongAcc"

[columns.r]
channel = "YawRate"
unit = "deg/s"
"""
LOGGER = {"delta": ("SteerWhlAng", np.degrees(1.0) / 0.0625), "vx": ("VehSpd", 3.6), "ay": ("LatAcc", 1 / 9.80665),
          "ax": ("LongAcc", 1.0), "r": ("YawRate", np.degrees(1.0))}
"""Log column -> (logger channel, factor from SI to the logger's unit)."""


@pytest.fixture(scope="module")
def dlc(config):
    return Case.of("dlc").simulate(config, 100.0, 1)


def write_mf4(log, path: Path, slow=("vx",)) -> None:
    """The DLC as a logger would record it: the mapped channels in their units, ``slow`` ones at
    50 Hz in a group of their own."""
    mdf = MDF(version="4.10")
    t = log["t"]
    fast = [Signal(log[c] * k, t, name=n) for c, (n, k) in LOGGER.items() if c not in slow]
    mdf.append(fast)
    for column in slow:
        name, k = LOGGER[column]
        mdf.append([Signal(log[column][::2] * k, t[::2], name=name)])
    mdf.save(path, overwrite=True)


def test_an_mdf4_log_runs_through_a_channel_map_on_a_causal_grid(tmp_path, config, dlc, vsegen):
    write_mf4(dlc, tmp_path / "drive.mf4")
    (tmp_path / "map.toml").write_text(MAP)
    log = read_mdf(tmp_path / "drive.mf4", read_channel_map(tmp_path / "map.toml"), 0.01)
    assert np.allclose(log["delta"], dlc["delta"][:len(log)], rtol=1e-12, atol=1e-15)
    assert np.allclose(log["r"], dlc["r"][:len(log)], rtol=1e-12, atol=1e-15)
    held = dlc["vx"][(np.arange(len(log)) // 2) * 2]  # 50 Hz: each odd tick holds the even sample before it
    assert np.allclose(log["vx"], held, rtol=1e-12)
    result = vsegen("run", "--log", str(tmp_path / "drive.mf4"), "--channels",
                    str(tmp_path / "map.toml"), "--estimator", "kf2dof", "--out",
                    str(tmp_path / "est.mf4"))
    assert result.exit_code == 0, result.output
    assert "taken causally onto a uniform 10 ms grid" in result.stderr
    written = MDF(tmp_path / "est.mf4")
    assert {"beta", "vy", "r", "status"} <= set(written.channels_db)


def test_a_csv_with_the_loggers_names_and_units_equals_the_si_log(tmp_path, dlc, vsegen):
    write_log(dlc, tmp_path / "si.csv")
    logger = {"t": dlc["t"], **{name: dlc[c] * k for c, (name, k) in LOGGER.items()}}
    from vsegen.harness.logs.table import Log

    write_log(Log(logger, "logger.csv"), tmp_path / "logger.csv")
    (tmp_path / "map.toml").write_text(MAP)
    outputs = []
    for log, extra in (("si.csv", []), ("logger.csv", ["--channels", str(tmp_path / "map.toml")])):
        out = tmp_path / f"est_{log}"
        result = vsegen("run", "--log", str(tmp_path / log), "--estimator", "kf2dof",
                        "--out", str(out), *extra)
        assert result.exit_code == 0, result.output
        outputs.append(read_estimates(out))
    assert np.allclose(outputs[0]["beta"], outputs[1]["beta"], rtol=1e-9, atol=1e-12)
    mapped = read_log(tmp_path / "logger.csv", channels={n: (c, 1 / k) for c, (n, k) in LOGGER.items()})
    assert np.allclose(mapped["vx"], dlc["vx"], rtol=1e-12)


@pytest.mark.parametrize("edit, fragment", [
    (('unit = "km/h"', 'unit = "kmh"'), "[columns.vx] unit = 'kmh': expected one of rad, deg"),
    (('unit = "deg/s"', 'unit = "km/h"'), "[columns.r] unit = 'km/h': expected a unit of angular rate"),
    (("[columns.ax]", "[columns.accel]"), "[columns.accel]: unknown column: expected one of t, delta"),
    (("factor = 0.0625", "factor = 0"), "[columns.delta] factor = 0: expected a finite non-zero number"),
    (('channel = "YawRate"', 'channel = "Gyro"'), "missing channel 'Gyro' for column 'r'"),
])
def test_channel_map_mistakes_are_one_line_and_nothing_is_written(tmp_path, dlc, edit, fragment, vsegen):
    write_mf4(dlc, tmp_path / "drive.mf4")
    (tmp_path / "map.toml").write_text(MAP.replace(*edit))
    out = tmp_path / "est.csv"
    result = vsegen("run", "--log", str(tmp_path / "drive.mf4"), "--channels",
                    str(tmp_path / "map.toml"), "--estimator", "kf2dof", "--out", str(out),
                    "--vehicle", str(VEHICLES / "c_class.toml"))
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0], lines
    assert not out.exists()


def test_a_file_that_is_not_mdf4_is_one_line(tmp_path, vsegen):
    (tmp_path / "junk.mf4").write_bytes(b"\x00junk" * 100)
    result = vsegen("run", "--log", str(tmp_path / "junk.mf4"), "--estimator", "kf2dof",
                    "--out", str(tmp_path / "est.csv"))
    assert result.exit_code == 2
    assert result.stderr.startswith(f"vsegen: error: {tmp_path / 'junk.mf4'}: not a readable MDF4 file")
