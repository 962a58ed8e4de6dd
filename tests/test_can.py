"""Raw CAN logs: a drive recorded as CAN frames (bus-logging MDF4, BLF, ASC) and decoded with a DBC
gives the estimates of the decoded CSV; a bad DBC, a signal the DBC lacks and a signal never
received are one line, exit 2."""

from __future__ import annotations

import can
import cantools
import numpy as np
import pytest
from test_channels import LOGGER, MAP

from vsegen.harness.host.run_log import EstimatorStream
from vsegen.harness.logs.can import open_can_log
from vsegen.harness.logs.channels import read_channel_map
from vsegen.harness.logs.stream import open_csv_log
from vsegen.harness.logs.table import Log, write_log
from vsegen.harness.sim.scenarios import Case

DBC = """VERSION ""

NS_ :

BS_:

BU_: ESC EPS

BO_ 256 Chassis: 8 ESC
 SG_ YawRate : 0|16@1- (0.01,0) [-327.68|327.67] "deg/s" Vector__XXX
 SG_ LatAcc : 16|16@1- (0.0001,0) [-3.2768|3.2767] "g" Vector__XXX
 SG_ LongAcc : 32|16@1- (0.001,0) [-32.768|32.767] "m/s^2" Vector__XXX

BO_ 257 Steering: 8 EPS
 SG_ SteerWhlAng : 0|16@1- (0.1,0) [-3276.8|3276.7] "deg" Vector__XXX

BO_ 258 Speed: 8 ESC
 SG_ VehSpd : 0|16@1+ (0.01,0) [0|655.35] "km/h" Vector__XXX

BO_ 259 Diagnostics: 8 ESC
 SG_ Counter : 0|8@1+ (1,0) [0|255] "" Vector__XXX
"""
OFFSETS = {"Chassis": 0.0001, "Steering": 0.0002, "Speed": 0.0003}
"""s: each message is sent this long after the sample it carries (a bus is never simultaneous)."""
EPOCH = 1.7e9
"""s: loggers stamp frames in absolute time."""


@pytest.fixture(scope="module")
def drive(config, tmp_path_factory):
    """(folder, the decoded CSV) of the DLC recorded as CAN frames in BLF, ASC and bus-logging
    MDF4, with the DBC and the channel map."""
    folder = tmp_path_factory.mktemp("can")
    (folder / "car.dbc").write_text(DBC)
    (folder / "map.toml").write_text(MAP)
    database = cantools.database.load_string(DBC, database_format="dbc")
    log = Case.of("dlc").simulate(config, 100.0, 1)
    writers = [can.BLFWriter(str(folder / "drive.blf")), can.ASCWriter(str(folder / "drive.asc")),
               can.io.MF4Writer(str(folder / "drive.mf4"))]
    decoded = {"t": log["t"]}
    frames = []
    for message in (database.get_message_by_name(n) for n in OFFSETS):
        rows = []
        for k, t in enumerate(log["t"]):
            physical = {s.name: log[_column(s.name)][k] * LOGGER[_column(s.name)][1] for s in message.signals}
            data = message.encode(physical)
            rows.append(message.decode(data))
            frames.append(can.Message(timestamp=EPOCH + t + OFFSETS[message.name], arbitration_id=message.frame_id,
                                      data=data, is_extended_id=False, channel=0))
        decoded.update({s.name: np.array([row[s.name] for row in rows], dtype=float) for s in message.signals})
    for frame in sorted(frames, key=lambda f: f.timestamp):
        for writer in writers:
            writer.on_message_received(frame)
    for writer in writers:
        writer.stop()
    write_log(Log(decoded), folder / "decoded.csv")
    return folder


def _column(signal: str) -> str:
    return next(column for column, (name, _) in LOGGER.items() if name == signal)


@pytest.mark.parametrize("suffix", [".blf", ".asc", ".mf4"])
def test_a_raw_can_log_gives_the_estimates_of_the_decoded_csv(config, drive, suffix):
    channels = read_channel_map(drive / "map.toml")
    csv = open_csv_log(drive / "decoded.csv", {c.channel: (c.name, c.scale) for c in channels.columns.values()})
    frames = open_can_log(drive / f"drive{suffix}", drive / "car.dbc", channels, 0.01)
    assert frames.samples >= csv.samples - 1 and frames.sample_time == pytest.approx(csv.sample_time, rel=1e-12)
    expected = EstimatorStream(config, "switching", csv.sample_time)(csv.read())
    got = EstimatorStream(config, "switching", frames.sample_time)(frames.read())
    n = frames.samples
    for name in ("beta", "vy", "r", "status"):
        np.testing.assert_allclose(got[name], expected[name][:n], rtol=0, atol=1e-12)
    assert np.max(np.abs(got["beta"])) > 0.005   # a real manoeuvre, not zeros


def test_run_reads_a_blf_with_its_dbc(drive, vsegen, tmp_path):
    result = vsegen("run", "--log", str(drive / "drive.blf"), "--dbc", str(drive / "car.dbc"), "--channels",
                    str(drive / "map.toml"), "--estimator", "kf2dof", "--out", str(tmp_path / "est.csv"))
    assert result.exit_code == 0, result.output
    assert "CAN signals" in result.stderr
    result = vsegen("plot", "--log", str(drive / "drive.blf"), "--dbc", str(drive / "car.dbc"), "--channels",
                    str(drive / "map.toml"), "--est", str(tmp_path / "est.csv"), "--out", str(tmp_path / "est.png"))
    assert result.exit_code == 0, result.output
    assert (tmp_path / "est.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("change,fragment", [
    (lambda dbc: "BO_ 256 Chassis 8 ESC\n garbage", "car.dbc: not a readable DBC file"),
    (lambda dbc: dbc.replace("YawRate", "YawRateESC"), "car.dbc: no signal 'YawRate' for column 'r'"),
    (lambda dbc: dbc.replace("BO_ 256 Chassis", "BO_ 300 Chassis"), "'YawRate' (message Chassis, 0x12C) for column "
                                                                      "'r' never received"),
    (lambda dbc: dbc.replace('"deg/s"', '"rad/s"'), "signal 'YawRate' is in rad/s (the DBC's unit)"),
])
@pytest.mark.parametrize("suffix", [".blf", ".mf4"])
def test_dbc_mistakes_are_one_line(drive, vsegen, tmp_path, change, fragment, suffix):
    (tmp_path / "car.dbc").write_text(change(DBC))
    result = vsegen("run", "--log", str(drive / f"drive{suffix}"), "--dbc", str(tmp_path / "car.dbc"), "--channels",
                    str(drive / "map.toml"), "--estimator", "kf2dof", "--out", str(tmp_path / "est.csv"))
    assert result.exit_code == 2, result.output
    assert len(result.stderr.strip().splitlines()) == 1 and fragment in result.stderr, result.stderr
    assert not (tmp_path / "est.csv").exists()


def test_a_blf_without_a_dbc_is_one_line(drive, vsegen, tmp_path):
    result = vsegen("run", "--log", str(drive / "drive.blf"), "--estimator", "kf2dof", "--out",
                    str(tmp_path / "est.csv"))
    assert result.exit_code == 2
    assert "expected --dbc CAR.dbc" in result.stderr and len(result.stderr.strip().splitlines()) == 1
