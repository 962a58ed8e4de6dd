"""Sensor and truth-car disturbances of simulated drives: each does what it says, seeded."""

from __future__ import annotations

import numpy as np
import pytest

from vsegen.harness.sim.scenarios import Case, ScenarioError

RATE = 100.0


def _logs(config, **options):
    """The clean step steer and the same drive with ``options``."""
    clean = Case.of("step_steer").simulate(config, RATE)
    return clean.columns, Case.of("step_steer", **options).simulate(config, RATE).columns


def test_an_accelerometer_offset_appears_when_asked_and_the_noise_stays(config):
    clean, disturbed = _logs(config, ay_offset=0.5, ax_offset=-0.2, offset_time=2.0)
    before, after = clean["t"] < 2.0, clean["t"] >= 2.0
    assert np.array_equal(disturbed["ay"][before], clean["ay"][before])
    np.testing.assert_allclose(disturbed["ay"][after] - clean["ay"][after], 0.5, atol=1e-12)
    np.testing.assert_allclose(disturbed["ax"][after] - clean["ax"][after], -0.2, atol=1e-12)
    assert np.array_equal(disturbed["r"], clean["r"])


def test_gyro_bias_and_drift_are_a_seeded_random_walk(config):
    clean, disturbed = _logs(config, gyro_bias=0.01, gyro_drift=0.002)
    walk = disturbed["r"] - clean["r"] - 0.01
    steps = np.diff(walk)
    assert np.std(steps) == pytest.approx(0.002 * np.sqrt(1 / RATE), rel=0.1)
    again = Case.of("step_steer", gyro_bias=0.01, gyro_drift=0.002).simulate(config, RATE, seed=1)
    other = Case.of("step_steer", gyro_bias=0.01, gyro_drift=0.002).simulate(config, RATE, seed=2)
    assert np.array_equal(again.columns["r"], disturbed["r"])
    assert not np.array_equal(other.columns["r"] - other.columns["r_ref"], disturbed["r"] - clean["r_ref"])


def test_latency_delays_a_channel_and_quantisation_rounds_it(config):
    clean, disturbed = _logs(config, latency="ay:0.03,r:0.02", quantise="delta:0.001")
    np.testing.assert_allclose(disturbed["ay"][3:], clean["ay"][:-3], atol=1e-12)
    np.testing.assert_allclose(disturbed["r"][2:], clean["r"][:-2], atol=1e-12)
    assert np.allclose(disturbed["delta"] / 0.001, np.round(disturbed["delta"] / 0.001))
    assert np.abs(disturbed["delta"] - clean["delta"]).max() <= 0.0005 + 1e-12


def test_a_scale_typed_wrong_multiplies_its_channel_only(config):
    clean, disturbed = _logs(config, scale="r:1.3")
    np.testing.assert_allclose(disturbed["r"], 1.3 * clean["r"], rtol=1e-12)
    np.testing.assert_array_equal(disturbed["ay"], clean["ay"])


def test_frozen_dropped_and_spiking_signals(config):
    clean, disturbed = _logs(config, freeze="r:3:1", dropout="all:4:0.5")
    t = clean["t"]
    frozen = (t >= 3.0) & (t < 4.0)
    assert np.all(disturbed["r"][frozen] == clean["r"][np.argmax(frozen)])
    gone = (t >= 4.0) & (t < 4.5)
    for channel in ("delta", "vx", "ax", "ay", "r", "omega_fl"):
        assert np.all(np.isnan(disturbed[channel][gone])) and not np.isnan(disturbed[channel][~gone]).any()
    _, spiking = _logs(config, spikes="ay:3x2.0")
    jumps = np.abs(spiking["ay"] - clean["ay"])
    assert np.sum(np.isclose(jumps, 2.0)) == 3 and np.sum(jumps > 1e-12) == 3


def test_a_steering_offset_and_a_mounting_roll(config):
    """An IMU rolled by 0.02 rad on the body reads a_y cos(0.02) + a_z sin(0.02): 0.196 m/s^2 more
    with a_z = g (the noise, added in the sensor's axes, is the same in both logs)."""
    clean, disturbed = _logs(config, steer_offset=0.0035, mount_roll=0.02)
    np.testing.assert_allclose(disturbed["delta"] - clean["delta"], 0.0035, atol=1e-15)
    straight = clean["t"] < 1.0
    np.testing.assert_allclose((disturbed["ay"] - clean["ay"])[straight], 9.81 * np.sin(0.02), atol=1e-3)
    # the gyro's axis tilts by 0.02 rad: r cos(0.02) plus 0.02 x the pitch rate, below 1e-3 rad/s
    np.testing.assert_allclose(disturbed["r"], clean["r"], atol=1e-3)


def test_a_heavier_truth_car_changes_the_drive_not_the_estimators_file(config):
    fingerprint = config.fingerprint()
    clean, loaded = _logs(config, mass_added=300.0, cg_shift=0.5)
    steady = clean["t"] > 4.0
    assert np.mean(np.abs(loaded["beta_ref"][steady])) != pytest.approx(
        np.mean(np.abs(clean["beta_ref"][steady])), rel=0.02)
    assert config.fingerprint() == fingerprint


@pytest.mark.parametrize("option,message", [
    ("freeze=q:1:2", "freeze entry 'q:1:2': expected channel:start:duration"),
    ("latency=ay", "latency entry 'ay': expected channel:seconds"),
    ("spikes=r:3", "spikes entry 'r:3': expected channel:countxsize"),
    ("scale=r", "scale entry 'r': expected channel:factor"),
    ("tyre_scale=0", "tyre_scale = 0.0: expected a factor > 0"),
])
def test_a_malformed_disturbance_is_one_line_naming_it(config, option, message):
    from vsegen.harness.sim.scenarios import parse_option
    key, value = parse_option("step_steer", option)
    with pytest.raises(ScenarioError, match=message.replace("(", r"\(")) as error:
        Case.of("step_steer", **{key: value}).simulate(config, RATE)
    assert "\n" not in str(error.value)
