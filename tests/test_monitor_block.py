"""The monitor block (model/monitor_block.py): each estimator declares its checks once and takes its
inputs, states and status bits from the block; a check that is off leaves no state; the model
stage raises what it should. Equivalence of every check with the reference is in verify."""

from __future__ import annotations

import casadi as ca
import pytest

from vsegen.model import consistency, input_monitors, status
from vsegen.model.estimators import DEFINITIONS, build, kf2dof, monitor_only_inputs

MONITORED = [name for name, d in DEFINITIONS.items() if d.monitors]
ALL_OFF = {**input_monitors.OFF, "residual_window": 0.0, "linear_range": 0.0}


def test_every_model_based_estimator_carries_a_block():
    assert set(MONITORED) == {"kf2dof", "switching", "fusion", "ekf_rls", "ukf", "aukf"}


@pytest.mark.parametrize("name", MONITORED)
def test_the_estimator_takes_inputs_states_and_bits_from_its_block(config, name):
    block = DEFINITIONS[name].monitors(config.settings(name))
    estimator = build(name, config)
    assert estimator.inputs.names == block.inputs.names
    assert set(s.name for s in block.states) <= set(estimator.states.names)
    assert block.states, "the shipped file switches checks on"
    assert set(block.checks.status_bits) <= set(DEFINITIONS[name].status_bits)
    assert monitor_only_inputs(config, name) == block.monitored


@pytest.mark.parametrize("name", MONITORED)
def test_checks_switched_off_leave_no_state(config, name):
    quiet = config.with_settings(name, **{k: v for k, v in ALL_OFF.items() if k in config.settings(name)})
    block = DEFINITIONS[name].monitors(quiet.settings(name))
    assert block.states == ()
    names = set(build(name, quiet).states.names)
    monitored = {s.name for s in DEFINITIONS[name].monitors(config.settings(name)).states}
    assert not names & monitored


def _judged(config, residual, concerns):
    """(code, first firing) of kf2dof's model stage for a previous mean ``residual`` and an
    innovation of 10 sigma on both channels, active."""
    settings = config.settings("kf2dof")
    block = kf2dof.CHECKS.block(settings)
    s = {"residual": ca.SX(residual), "residual_hold_left": ca.SX(0)}
    sigma = settings["sensor_noise"]
    step = block.judge_model(s, ca.SX(1), settings, config.sample_time, ca.vertcat(10 * sigma[0], 10 * sigma[1]),
                             ca.SX(0.0), concerns=ca.SX(concerns))
    return int(ca.evalf(step.code)), int(ca.evalf(step.first_inconsistent))


def test_the_model_stage_raises_model_inconsistent_where_it_concerns_the_output(config):
    limit = config.settings("kf2dof")["residual_limit"]
    code, first = _judged(config, 2 * limit, concerns=1)
    assert code & status.MODEL_INCONSISTENT and not first        # above the limit already
    code, first = _judged(config, 0.0, concerns=1)
    assert first == int(bool(code & status.MODEL_INCONSISTENT))
    code, _ = _judged(config, 2 * limit, concerns=0)
    assert not code & status.MODEL_INCONSISTENT
    assert consistency.enabled(config.settings("kf2dof"))
