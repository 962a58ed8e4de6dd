"""Logs as loggers write them, read without silent mistakes: a robust rate fit with true jitter
figures, a mapped time column, a channel chosen by group or message where its name repeats, gaps
reported for MDF4 as for CSV, and every missing channel named at once."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from asammdf import MDF, Signal

from vsegen.harness.logs.channels import read_channel_map
from vsegen.harness.logs.mdf import read_mdf
from vsegen.harness.logs.table import Log, LogError, on_uniform_grid, read_log, write_log
from vsegen.harness.sim.scenarios import Case

RATE = 100.0


@pytest.fixture(scope="module")
def dlc(config):
    return Case.of("dlc").simulate(config, RATE, 1)


def jittered_clock(samples: int, jitter: float, gap: tuple[float, float], seed: int = 3) -> np.ndarray:
    """Time stamps of a 100 Hz logger whose stamps scatter uniformly by +-``jitter`` s, with no
    samples inside ``gap`` (s)."""
    t = np.arange(samples) / RATE + np.random.default_rng(seed).uniform(-jitter, jitter, samples)
    return t[(t < gap[0]) | (t > gap[1])]


def test_a_long_jittered_log_is_fitted_at_its_true_rate(tmp_path):
    """Ten minutes at 100 Hz with 0.2 ms jitter and a 0.5 s gap: before, the tick numbers came from
    the rounded median step, the error grew along the log, and the log was fitted as 10.001 ms with
    'jitter +-5 ms'."""
    t = jittered_clock(60_000, 0.0002, (100.0, 100.5))
    resampled = on_uniform_grid(Log({"t": t, "ay": np.zeros(len(t))}, "drive.csv"))
    assert resampled.sample_time == pytest.approx(0.01, abs=1e-12)
    assert "jitter +-0.2 ms around a 10 ms step" in resampled.notes["resampled"]
    assert "1 gap(s) longer than 0.1 s" in resampled.notes["gaps"] and "100.1" in resampled.notes["gaps"]


def test_a_time_column_with_another_name_and_unit_is_mapped(tmp_path, dlc):
    write_log(dlc, tmp_path / "dlc.csv")
    text = (tmp_path / "dlc.csv").read_text().splitlines()
    header = text[0].split(",")
    header[header.index("t")] = "time"
    rows = [",".join(f"{float(c) * 1e3!r}" if i == header.index("time") else c for i, c in enumerate(row.split(",")))
            for row in text[1:]]
    (tmp_path / "logger.csv").write_text("\n".join([",".join(header), *rows]) + "\n")
    (tmp_path / "map.toml").write_text('[columns.t]\nchannel = "time"\nunit = "ms"\n')
    mapping = read_channel_map(tmp_path / "map.toml")
    log = read_log(tmp_path / "logger.csv", channels={c.channel: (c.name, c.scale) for c in mapping.columns.values()})
    np.testing.assert_allclose(log["t"], dlc["t"], rtol=1e-12)
    (tmp_path / "bad.toml").write_text('[columns.t]\nchannel = "time"\nunit = "deg"\n')
    with pytest.raises(LogError, match=r"unit = 'deg': expected a unit of time \(the column is in s\)"):
        read_channel_map(tmp_path / "bad.toml")


def two_messages(log, path: Path, hole: tuple[float, float] | None = None) -> None:
    """The DLC as a CAN logger writes it: the yaw rate twice, in messages ESP_21 (the ESC's, right)
    and ACC_07 (another ECU's copy, in deg/s), and the other inputs in a third group; ``hole``
    leaves a stretch of the ESC's yaw rate unlogged."""
    t = log["t"]
    keep = np.ones(len(t), dtype=bool) if hole is None else (t < hole[0]) | (t > hole[1])
    mdf = MDF(version="4.10")
    mdf.append([Signal(log[c], t, name=c) for c in ("delta", "vx", "ax", "ay")], acq_name="Chassis")
    mdf.append([Signal(log["r"][keep], t[keep], name="YawRate")], acq_name="ESP_21")
    mdf.append([Signal(np.degrees(log["r"]), t, name="YawRate")], acq_name="ACC_07")
    mdf.save(path, overwrite=True)


def test_a_repeated_channel_name_is_chosen_by_group_or_message(tmp_path, dlc):
    two_messages(dlc, tmp_path / "can.mf4")
    (tmp_path / "unchosen.toml").write_text('[columns.r]\nchannel = "YawRate"\n')
    expected = (r"channel 'YawRate' for column 'r' is in 2 groups: expected the channel map to choose one with "
                r"group = N or message = NAME \(group 1 \(message 'ESP_21'\), group 2 \(message 'ACC_07'\)\)")
    with pytest.raises(LogError, match=expected):
        read_mdf(tmp_path / "can.mf4", read_channel_map(tmp_path / "unchosen.toml"), 0.01)
    for choice in ('message = "ESP_21"', "group = 1"):
        (tmp_path / "map.toml").write_text(f'[columns.r]\nchannel = "YawRate"\n{choice}\n')
        log = read_mdf(tmp_path / "can.mf4", read_channel_map(tmp_path / "map.toml"), 0.01)
        np.testing.assert_allclose(log["r"], dlc["r"][:len(log)], rtol=1e-12)
    (tmp_path / "wrong.toml").write_text('[columns.r]\nchannel = "YawRate"\nmessage = "ABS_01"\n')
    with pytest.raises(LogError, match=r"message = 'ABS_01' in .*wrong.toml\) is not in exactly one group"):
        read_mdf(tmp_path / "can.mf4", read_channel_map(tmp_path / "wrong.toml"), 0.01)


def test_mdf4_gaps_are_reported_like_csv_gaps(tmp_path, dlc):
    two_messages(dlc, tmp_path / "can.mf4", hole=(4.0, 4.5))
    (tmp_path / "map.toml").write_text('[columns.r]\nchannel = "YawRate"\nmessage = "ESP_21"\n')
    log = read_mdf(tmp_path / "can.mf4", read_channel_map(tmp_path / "map.toml"), 0.01)
    assert log.notes["gaps"].startswith("1 gap(s) longer than 0.1 s, estimators hold there: 4.1")
    assert np.isnan(log["r"][(log["t"] > 4.11) & (log["t"] < 4.49)]).all()


def test_every_missing_channel_is_named_at_once(tmp_path, dlc):
    mdf = MDF(version="4.10")
    mdf.append([Signal(dlc[c], dlc["t"], name=c) for c in ("delta", "vx")])
    mdf.save(tmp_path / "sparse.mf4", overwrite=True)
    with pytest.raises(LogError, match=r"missing channels 'ax' for column 'ax', 'ay' for column 'ay', 'r' for "
                                       r"column 'r': expected them"):
        read_mdf(tmp_path / "sparse.mf4", read_channel_map(None), 0.01)
    write_log(Log({c: dlc[c] for c in ("t", "delta", "vx")}, "sparse"), tmp_path / "sparse.csv")
    with pytest.raises(LogError, match=r":1: missing columns 'ax', 'ay', 'r': expected the columns"):
        read_log(tmp_path / "sparse.csv")


def test_the_files_own_unit_is_compared_with_the_map(tmp_path, dlc):
    """An MDF4 file that says km/h for the speed, read through a map that takes it as m/s (or names
    no unit): before, the file's unit was never looked at."""
    mdf = MDF(version="4.10")
    mdf.append([Signal(dlc[c], dlc["t"], name=c, unit=u) for c, u in (("delta", "rad"), ("ax", "m/s^2"),
                                                                       ("ay", "m/s²"), ("r", "rad/s"))])
    mdf.append([Signal(dlc["vx"] * 3.6, dlc["t"], name="VehSpd", unit="km/h")])
    mdf.save(tmp_path / "drive.mf4", overwrite=True)
    (tmp_path / "wrong.toml").write_text('[columns.vx]\nchannel = "VehSpd"\n')
    with pytest.raises(LogError, match=r"channel 'VehSpd' is in km/h \(the file's unit\), the channel map reads it as "
                                       r"m/s: expected unit = \"km/h\" in \[columns.vx\]"):
        read_mdf(tmp_path / "drive.mf4", read_channel_map(tmp_path / "wrong.toml"), 0.01)
    (tmp_path / "right.toml").write_text('[columns.vx]\nchannel = "VehSpd"\nunit = "km/h"\n')
    log = read_mdf(tmp_path / "drive.mf4", read_channel_map(tmp_path / "right.toml"), 0.01)
    np.testing.assert_allclose(log["vx"], dlc["vx"][:len(log)], rtol=1e-12)
