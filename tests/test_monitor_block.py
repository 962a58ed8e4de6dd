"""The monitor block (model/monitor_block.py): each estimator declares its checks once and takes its
inputs, states and status bits from the block; a check that is off leaves no state; the model
stage raises what it should; a new input check is one module per tree (model/input_checks/,
harness/reference/input_checks/), with no wiring. Equivalence of every check with the reference
is in verify."""

from __future__ import annotations

import sys

import casadi as ca
import numpy as np
import pytest

from vsegen.harness.reference import input_checks as reference_input_checks
from vsegen.harness.reference import kf2dof as reference_kf2dof
from vsegen.harness.reference.input_checks import checks as reference_checks
from vsegen.harness.sim.scenarios import Case
from vsegen.model import consistency, input_monitors, status
from vsegen.model import input_checks as model_checks
from vsegen.model.estimators import DEFINITIONS, build, build_fresh, kf2dof, monitor_only_inputs
from vsegen.model.input_checks import registered

MONITORED = [name for name, d in DEFINITIONS.items() if d.monitors]
ALL_OFF = {**input_monitors.OFF, "residual_window": 0.0, "linear_range": 0.0}


def test_every_model_based_estimator_carries_a_block():
    assert set(MONITORED) == {"kf2dof", "switching", "fusion", "ekf_rls", "ukf", "aukf"}


@pytest.mark.parametrize("name", MONITORED)
def test_the_estimator_takes_inputs_states_and_bits_from_its_block(config, name):
    block = DEFINITIONS[name].monitors(config.settings(name))
    estimator = build(name, config)
    assert estimator.inputs.names == block.inputs.names
    assert set(s.name for s in (*block.states, *block.segment)) <= set(estimator.states.names)
    assert block.segment, "the shipped file switches checks on"
    assert estimator.states.names[-len(block.segment):] == tuple(s.name for s in block.segment)
    assert set(block.checks.status_bits) <= set(DEFINITIONS[name].status_bits)
    assert monitor_only_inputs(config, name) == block.monitored


@pytest.mark.parametrize("name", MONITORED)
def test_checks_switched_off_leave_no_state(config, name):
    quiet = config.with_settings(name, **{k: v for k, v in ALL_OFF.items() if k in config.settings(name)})
    block = DEFINITIONS[name].monitors(quiet.settings(name))
    assert block.states == () and block.segment == ()
    names = set(build(name, quiet).states.names)
    shipped = DEFINITIONS[name].monitors(config.settings(name))
    monitored = {s.name for s in (*shipped.states, *shipped.segment)}
    assert not names & monitored


def _judged(config, residual, concerns):
    """(code, first firing) of kf2dof's model stage for a previous mean ``residual`` and an
    innovation of 10 sigma on both channels, active."""
    settings = config.settings("kf2dof")
    block = kf2dof.CHECKS.block(settings)
    s = {"residual": ca.SX(residual), "residual_hold_left": ca.SX(0), "linear_range_hold_left": ca.SX(0)}
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


def _beyond(config, ay, ay_model, left):
    """(BEYOND_LINEAR_RANGE raised, samples left) of kf2dof's model stage, active."""
    settings = config.settings("kf2dof")
    block = kf2dof.CHECKS.block(settings)
    s = {"residual": ca.SX(0), "residual_hold_left": ca.SX(0), "linear_range_hold_left": ca.SX(left)}
    step = block.judge_model(s, ca.SX(1), settings, config.sample_time, ca.vertcat(0, 0), ca.SX(ay), ca.SX(ay_model))
    left = int(ca.evalf(step.updates["linear_range_hold_left"]))
    return bool(int(ca.evalf(step.code)) & status.BEYOND_LINEAR_RANGE), left


def test_the_linear_range_flag_reads_the_model_a_y_and_holds(config):
    settings = config.settings("kf2dof")
    limit, held = settings["linear_range"], round(settings["linear_range_hold"] / config.sample_time)
    assert held >= 1
    assert _beyond(config, 0.5 * limit, 0.5 * limit, 0) == (False, 0)
    assert _beyond(config, 1.1 * limit, 0.5 * limit, 0) == (True, held)
    assert _beyond(config, 0.5 * limit, -1.1 * limit, 0) == (True, held)    # the model asks for more
    assert _beyond(config, 0.5 * limit, 0.5 * limit, 2) == (True, 1)        # fell back: held
    assert _beyond(config, 0.5 * limit, 0.5 * limit, 1) == (True, 0)


def test_model_and_reference_find_the_same_input_checks_in_the_same_order():
    def names(modules):
        return [module.__name__.rsplit(".", 1)[1] for module in modules]

    assert names(registered()) == names(reference_checks()) == ["frozen", "crosscheck", "wheel_yaw"]


TOY_MODEL = '''
"""A check written in a test: v_x above 30 m/s on more than 3 runs raises INPUT_FROZEN."""
import casadi as ca
from vsegen.model import status
from vsegen.model.signals import Signal
ORDER = 99
FIELDS = ()
BITS = (status.INPUT_FROZEN,)
STATE = Signal("toy_fast_samples", "-", "samples above 30 m/s")
def reads(numeric):
    return ("ax",)
def enabled(numeric, inputs):
    return "ax" in inputs
def raises(numeric, inputs):
    return BITS
def states(numeric, inputs):
    return (STATE,)
def initial_entries(first, numeric, inputs):
    return {STATE.name: ca.SX(0)}
def monitor(watch):
    count = (watch.u["vx"] > 30) * (watch.s[STATE.name] + 1)
    updates = {STATE.name: ca.if_else(watch.active, count, watch.s[STATE.name])}
    return updates, {status.INPUT_FROZEN: watch.active * (count > 3)}
'''
TOY_REFERENCE = '''
ORDER = 99
def reads(settings):
    return ("ax",)
def enabled(settings, inputs):
    return "ax" in inputs
def raises(settings, inputs):
    return 2048
def states(settings, inputs):
    return ("toy_fast_samples",)
def initial(settings, inputs, first):
    return {"toy_fast_samples": 0.0}
def step(x, u, ok, settings, T, inputs, vehicle, raw):
    count = x["toy_fast_samples"] + 1 if u["vx"] > 30 else 0.0
    return {"toy_fast_samples": count}, 2048 if count > 3 else 0
'''


@pytest.fixture
def toy_check(tmp_path, monkeypatch):
    """One module more in each tree's input_checks package, as a new check would be."""
    for package, text in ((model_checks, TOY_MODEL), (reference_input_checks, TOY_REFERENCE)):
        folder = tmp_path / package.__name__.replace(".", "_")
        folder.mkdir()
        (folder / "toy_speed.py").write_text(text)
        monkeypatch.setattr(package, "__path__", [*package.__path__, str(folder)])
    registered.cache_clear()
    reference_checks.cache_clear()
    yield
    registered.cache_clear()
    reference_checks.cache_clear()
    for name in [n for n in sys.modules if n.endswith(".toy_speed")]:
        del sys.modules[name]


def test_a_check_added_as_one_module_per_tree_reaches_the_estimators_equal_to_the_reference(config, toy_check):
    """No wiring: kf2dof takes the toy check's input (a_x), state and bit, and steps equal to its
    reference, which takes them from its own new module."""
    estimator = build_fresh("kf2dof", config)
    assert "ax" in estimator.inputs.names and "toy_fast_samples" in estimator.states.names
    assert reference_kf2dof.input_names(config) == estimator.inputs.names
    assert reference_kf2dof.names(config)[1] == estimator.states.names
    log = Case.of("dlc", speed_kmh=120.0).simulate(config, 1.0 / config.sample_time, 1)
    inputs = log.matrix(estimator.inputs.names)[:200]
    state = np.array(estimator.init(inputs[0])).ravel()
    reference_state = reference_kf2dof.init(config, inputs[0])
    statuses = []
    for row in inputs:
        state, output = (np.array(v).ravel() for v in estimator.step(state, row))
        reference_state, reference_output = reference_kf2dof.step(config, reference_state, row)
        np.testing.assert_allclose(state, reference_state, rtol=1e-9, atol=1e-12)
        assert output[-1] == reference_output[-1]
        statuses.append(int(output[-1]))
    # the checks run on samples 0, P, 2P, ...; on the 4th run above 30 m/s the bit is raised, and
    # the method reports it from the next sample on
    period = input_monitors.period(config.settings("kf2dof"), config.sample_time)
    assert statuses[3 * period] & status.INPUT_FROZEN == 0 and statuses[3 * period + 1] & status.INPUT_FROZEN
