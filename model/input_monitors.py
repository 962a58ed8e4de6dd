"""The input monitors a sideslip estimator carries beyond its method, behind one interface: the
frozen-signal monitor (``model.frozen``, status INPUT_FROZEN), the cross-checks of the inputs
against each other (``model.crosscheck``, status LATERAL_INCONSISTENT, STEERING_OFFSET and
INPUT_FROZEN) and the yaw rate against the non-driven wheels (``model.wheel_yaw``, status
YAW_RATE_MISMATCH, where the estimator reads wheel speeds).

An estimator lists :data:`FIELDS` in its schema, takes its inputs from :func:`inputs`, puts
:func:`states` in its state layout and :func:`initial_entries` in its initial state, and adds the
code :func:`monitor` returns to its status; each monitor that is off (its setting 0) has no state and no code.
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import crosscheck, frozen, signals, status, wheel_yaw
from vsegen.model.filters import held_flag
from vsegen.model.layout import Layout
from vsegen.model.schema import nonnegative
from vsegen.model.signals import Signal

RECOVERY = nonnegative("frozen_recovery", "s", "beyond the papers: status INPUT_FROZEN stays raised this "
                       "long after a frozen input (or steering angle) moves again, while the estimate "
                       "recovers from what it was fed; 0 = off", default=0.0)
RECOVERY_STATE = Signal("frozen_recovery_left", "-", "samples INPUT_FROZEN stays raised after a frozen input "
                        "moved again (frozen_recovery)")
FIELDS = (frozen.FIELD, RECOVERY, *crosscheck.FIELDS, *wheel_yaw.FIELDS)
STATUS_BITS = (status.INPUT_FROZEN, status.LATERAL_INCONSISTENT, status.STEERING_OFFSET, status.YAW_RATE_MISMATCH)
"""The bits the monitors can raise in every estimator that has them (YAW_RATE_MISMATCH where the
yaw-rate check is on: every such estimator can be given the wheel speeds, :func:`inputs`)."""
OFF = {"frozen_time": 0.0, "lateral_check_limit": 0.0, "steering_offset_limit": 0.0, "steer_check_limit": 0.0,
       "wheel_check_limit": 0.0}
"""The settings that switch every monitor off (no state, no code)."""


def inputs(method_inputs: tuple[str, ...], numeric_settings) -> Layout:
    """The input layout of an estimator whose method reads ``method_inputs``, plus what the
    monitors that are on read beside them (the yaw-rate check: a_x and its axle's wheel speeds),
    in the catalogue's order (``model.signals.INPUTS``)."""
    wanted = {*method_inputs, *wheel_yaw.reads(numeric_settings)}
    return Layout(tuple(entry.signal for entry in signals.INPUTS if entry.name in wanted))


def monitored_only(method_inputs: tuple[str, ...], numeric_settings) -> tuple[str, ...]:
    """The inputs only the monitors read (``model.guard.input_guard``'s ``monitored``): an
    implausible one does not hold the estimator."""
    return tuple(name for name in inputs(method_inputs, numeric_settings).names if name not in method_inputs)


def enabled(numeric_settings, inputs: tuple[str, ...]) -> bool:
    """Whether an estimator reading ``inputs`` has any input monitor (structural)."""
    return (frozen.enabled(numeric_settings) or crosscheck.enabled(numeric_settings, inputs)
            or wheel_yaw.enabled(numeric_settings, inputs))


def recovers(numeric_settings, inputs: tuple[str, ...]) -> bool:
    """Whether INPUT_FROZEN is held after a freeze (structural: ``frozen_recovery`` > 0 and a
    monitor that raises it)."""
    raises = frozen.enabled(numeric_settings) and frozen.channels(inputs) or (
        crosscheck.enabled(numeric_settings, inputs) and numeric_settings["steer_check_limit"] > 0.0)
    return numeric_settings["frozen_recovery"] > 0.0 and bool(raises)


def states(numeric_settings, inputs: tuple[str, ...]) -> tuple[Signal, ...]:
    """The monitors' state entries (those that are on)."""
    return (*frozen.states(numeric_settings, inputs), *crosscheck.states(numeric_settings, inputs),
            *wheel_yaw.states(numeric_settings, inputs),
            *((RECOVERY_STATE,) if recovers(numeric_settings, inputs) else ()))


def initial_entries(first: dict, numeric_settings, inputs: tuple[str, ...]) -> dict:
    """The monitors' entries at init from the first sample ``first`` (neutralised inputs)."""
    return {**frozen.initial_entries(first, numeric_settings, inputs),
            **crosscheck.initial_entries(first, numeric_settings, inputs),
            **{entry.name: ca.SX(0) for entry in wheel_yaw.states(numeric_settings, inputs)},
            **({RECOVERY_STATE.name: ca.SX(0)} if recovers(numeric_settings, inputs) else {})}


def monitor(s: dict, u: dict, plausible: dict, active, settings, numeric_settings, sample_time: float,
            inputs: tuple[str, ...], vehicle, monitored: tuple[str, ...] = ()) -> tuple[dict, ca.SX]:
    """(new state entries, status code) of the monitors that are on, from the state entries
    ``s`` as they came in, the raw inputs ``u``, their plausibility flags and the guard's
    ``active`` flag (a holding estimator holds its monitors); ``settings`` the estimator's
    (numbers or calibration symbols), ``numeric_settings`` their numbers (which monitors exist),
    ``vehicle`` the [vehicle] table (numbers or symbols), ``monitored`` the inputs the guard does
    not decide on (:func:`monitored_only`: they may be implausible on an active sample)."""
    updates, raised = {}, {}
    if frozen.enabled(numeric_settings):
        updates, raised[status.INPUT_FROZEN] = frozen.monitor(s, u, plausible, active, settings,
                                                              sample_time, inputs)
    if crosscheck.enabled(numeric_settings, inputs):
        checked, flags = crosscheck.monitor(s, u, active, settings, numeric_settings, sample_time,
                                            vehicle["wheelbase"])
        updates |= checked
        for bit, flag in flags.items():     # a bit two monitors raise counts once
            raised[bit] = flag + raised[bit] - flag * raised[bit] if bit in raised else flag
    if wheel_yaw.enabled(numeric_settings, inputs):
        readable = {name: plausible[name] for name in monitored}
        checked, raised[status.YAW_RATE_MISMATCH] = wheel_yaw.monitor(s, u, readable, active, settings,
                                                                      numeric_settings, sample_time, vehicle)
        updates |= checked
    if recovers(numeric_settings, inputs):
        updates[RECOVERY_STATE.name], raised[status.INPUT_FROZEN] = held_flag(
            s[RECOVERY_STATE.name], raised.get(status.INPUT_FROZEN, ca.SX(0)), active, settings["frozen_recovery"],
            sample_time)
    return updates, sum((bit * flag for bit, flag in raised.items()), ca.SX(0))
