"""The frozen-signal monitor (model.frozen): a stuck a_x, a_y or r raises INPUT_FROZEN within
frozen_time, a live or quantised signal never does, and frozen_time = 0 removes it."""

from __future__ import annotations

from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pytest

from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.sim.scenarios import Case
from vsegen.model.estimators import build
from vsegen.model.status import INPUT_FROZEN

MONITORED = ("kf2dof", "switching", "fusion", "ekf_rls", "ukf", "aukf")


def _frozen_times(config, name, case: Case) -> np.ndarray:
    log = case.simulate(config, 1.0 / config.sample_time)
    estimates = run_estimator(config, name, log)
    return log["t"][(estimates["status"].astype(int) & INPUT_FROZEN) > 0]


@pytest.mark.parametrize("name", MONITORED)
@pytest.mark.parametrize("channel", ["r", "ay"])
def test_a_frozen_inertial_signal_raises_input_frozen_within_frozen_time(config, name, channel):
    frozen_time = config.settings(name)["frozen_time"]
    flagged = _frozen_times(config, name, Case.of("dlc", speed_kmh=80.0, freeze=f"{channel}:3:1.5"))
    assert flagged.size and 3.0 < flagged[0] <= 3.0 + frozen_time + 1e-9
    assert flagged[-1] < 4.5 + 1e-9            # and lowered when the signal lives again


@pytest.mark.parametrize("name", MONITORED)
def test_a_live_or_quantised_signal_is_never_frozen(config, name):
    for case in (Case.of("dlc", speed_kmh=80.0), Case.of("dlc", speed_kmh=80.0, quantise="ay:0.03,r:0.002")):
        assert _frozen_times(config, name, case).size == 0


def test_a_frozen_longitudinal_acceleration_is_seen_where_it_is_read(config):
    case = Case.of("step_steer", freeze="ax:2:1")
    assert _frozen_times(config, "ekf_rls", case).size and _frozen_times(config, "ukf", case).size
    assert _frozen_times(config, "kf2dof", case).size == 0     # kf2dof does not read a_x


def test_frozen_time_zero_removes_the_monitor(config):
    settings = {**config.settings("kf2dof"), "frozen_time": 0.0}
    off = replace(config, estimators=MappingProxyType({**config.estimators, "kf2dof": MappingProxyType(settings)}))
    assert not [n for n in build("kf2dof", off).states.names if n.startswith("frozen_")]
    assert _frozen_times(off, "kf2dof", Case.of("dlc", speed_kmh=80.0, freeze="r:3:1.5")).size == 0
