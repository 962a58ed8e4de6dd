"""The monitor block: every check a sideslip estimator carries beyond its method, wired once.
Beyond the papers; the rule it serves: never a silently wrong estimate.

An estimator declares the checks it carries in one place, a :class:`Checks` (its module's
``CHECKS``): the inputs its method reads, whether a consistency monitor watches its filter's prior
innovations, over which measured channels, and whether |a_y| beyond ``linear_range`` flags its
tyre model. Its schema fields, status bits and derived settings follow from that declaration.
From the numeric settings it builds one :class:`MonitorBlock` (``CHECKS.block``, also its
``Definition.monitors``), which supplies

* the input layout (the method's inputs plus what the monitors read beside them) and the inputs
  only the monitors read (an implausible one never holds the estimator, ``model.guard``);
* its state entries and their values at the first sample;
* each step's state updates and status code, in two stages: :meth:`MonitorBlock.watch_inputs`,
  the input monitors of ``model.input_monitors`` (frozen signals, the cross-checks, the yaw rate
  against the wheels), which run after the method every ``check_period`` in a kernel of their own
  on the state's last entries (``model.estimator.CheckSegment``: a check watches for faults that
  last tenths of a second, so it costs a share of the samples), and
  :meth:`MonitorBlock.judge_model` after the filter's update (the consistency monitor of
  ``model.consistency`` and the linear-range flag), every sample.

A check whose setting is 0 has no state and generates no code. A new input check is one new
module of ``model.input_checks`` (found there, combined by ``model.input_monitors``); a new check of
the model's output is a field of :class:`Checks` and its part of :meth:`MonitorBlock.judge_model`.
No estimator file changes for either, beyond naming a new model check in its ``CHECKS``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property

import casadi as ca

from vsegen.model import consistency, input_monitors, status
from vsegen.model.estimator import CheckSegment, Derived, Sum
from vsegen.model.filters import held_flag
from vsegen.model.input_checks import Watch
from vsegen.model.layout import Layout
from vsegen.model.schema import Field
from vsegen.model.signals import Signal


@dataclass(frozen=True)
class Checks:
    """The checks an estimator carries beyond its method, declared once."""

    method_inputs: tuple[str, ...] | Callable[[Mapping], tuple[str, ...]]
    """What the method reads (catalogue names), or the function of the numeric settings that says
    it (an estimator whose model reads more in some configurations)."""
    channels: tuple[str, ...] = ()
    """The measured channels (keys of ``model.consistency.CHANNELS``, in its ``sensor_noise``
    order) whose prior innovations the consistency monitor watches; () = no consistency monitor."""
    linear_range: bool = False
    """Whether |a_y| beyond the setting ``linear_range`` raises BEYOND_LINEAR_RANGE (a sideslip
    that rests on a tyre model)."""

    @property
    def fields(self) -> tuple[Field, ...]:
        """The schema fields of the checks."""
        return (*(consistency.fields(self.channels) if self.channels else ()),
                *((consistency.LINEAR_RANGE, consistency.LINEAR_RANGE_HOLD) if self.linear_range else ()),
                *input_monitors.FIELDS)

    @property
    def status_bits(self) -> tuple[int, ...]:
        """The status bits the checks can raise."""
        return (*((status.MODEL_INCONSISTENT,) if self.channels else ()),
                *((status.BEYOND_LINEAR_RANGE,) if self.linear_range else ()),
                *input_monitors.STATUS_BITS)

    @property
    def derived(self) -> dict[str, Derived]:
        """Settings that follow from identified quantities (``sensor_noise``)."""
        return consistency.derived(self.channels) if self.channels else {}

    def block(self, numeric_settings: Mapping) -> MonitorBlock:
        """The block for the estimator's numeric settings (which checks exist)."""
        method_inputs = self.method_inputs
        if callable(method_inputs):
            method_inputs = method_inputs(numeric_settings)
        return MonitorBlock(self, tuple(method_inputs), numeric_settings)


@dataclass(frozen=True)
class Step:
    """One stage of a step: the new state entries, the status code, and whether the consistency
    monitor's mean first exceeded its limit on this sample (an estimator may restart on it)."""

    updates: dict
    code: ca.SX
    first_inconsistent: ca.SX = ca.SX(0)
    checks: CheckSegment | None = None
    """The input checks' segment (the input monitors' stage, when a check is on): the structure
    builders of ``model.estimator`` take it."""


@dataclass(frozen=True)
class MonitorBlock:
    """The checks of one estimator for its numeric settings (:meth:`Checks.block`)."""

    checks: Checks
    method_inputs: tuple[str, ...]
    numeric: Mapping

    @cached_property
    def inputs(self) -> Layout:
        """The input layout: the method's inputs and what the monitors read beside them."""
        return input_monitors.inputs(self.method_inputs, self.numeric)

    @cached_property
    def monitored(self) -> tuple[str, ...]:
        """The inputs only the monitors read (``model.guard.input_guard``'s ``monitored``)."""
        return input_monitors.monitored_only(self.method_inputs, self.numeric)

    @property
    def consistency(self) -> bool:
        """Whether the consistency monitor exists (structural)."""
        return bool(self.checks.channels) and consistency.enabled(self.numeric)

    @property
    def linear_range_held(self) -> bool:
        """Whether BEYOND_LINEAR_RANGE is held after it fell (structural)."""
        return self.checks.linear_range and consistency.holds_linear_range(self.numeric)

    @cached_property
    def states(self) -> tuple[Signal, ...]:
        """The state entries of the model checks that are on (the consistency monitor's and the
        linear-range hold's)."""
        return (*(consistency.STATES if self.consistency else ()),
                *((consistency.LINEAR_RANGE_STATE,) if self.linear_range_held else ()))

    @cached_property
    def segment(self) -> tuple[Signal, ...]:
        """The input checks' state entries, the last of an estimator's state (``CheckSegment``);
        none when every check is off."""
        return input_monitors.states(self.numeric, self.inputs.names)

    def initial_entries(self, first: dict) -> dict:
        """The entries at the first sample ``first`` (its neutralised inputs)."""
        return {**consistency.initial_entries(self.consistency),
                **({consistency.LINEAR_RANGE_STATE.name: ca.SX(0)} if self.linear_range_held else {}),
                **input_monitors.initial_entries(first, self.numeric, self.inputs.names)}

    def check_time(self, sample_time: float) -> float:
        """s between two runs of the input checks (``check_period`` in whole samples)."""
        return input_monitors.period(self.numeric, sample_time) * sample_time

    def watch_inputs(self, s: dict, u: dict, plausible: dict, active, settings, sample_time: float,
                     vehicle, limits) -> Step:
        """The input monitors' stage from the state entries ``s``, the raw inputs ``u``, their
        plausibility flags and the guard's ``active`` flag; ``settings`` and ``vehicle`` numbers or
        calibration symbols, ``limits`` the [inputs] table.

        The checks run after the method, on an active sample whose countdown is 0 (every
        ``check_period``), stepped at that period, in a kernel of their own
        (``model.estimator.CheckSegment``): on such a sample every input the method reads is
        plausible, so only the monitored-only inputs are judged there. a_y, r and a_x are read as
        their means over the period, and so is each axle's right minus left wheel speed
        (``model.input_monitors.AVERAGED``; an input only the checks read summed where its value
        is plausible, ``model.estimator.Sum``). The method reads their last run: its updates keep
        their entries, its code is ``active`` times their kept code."""
        if not self.segment:
            return Step({}, ca.SX(0))
        period = input_monitors.period(self.numeric, sample_time)
        averaged = input_monitors.averaged(self.inputs.names)
        sums = {name: input_monitors.sum_state(name).name for name in averaged}
        judged_sums = {name: any(t in self.monitored for t in terms) for name, terms in averaged.items()}
        added = {name: input_monitors.summand(name, u, limits if judged_sums[name] else None) for name in sums}
        means = {name: (s[entry] + added[name]) / period for name, entry in sums.items()}
        judged = {name: plausible[name] if name in self.monitored else ca.SX(1) for name in plausible}
        updates, code = input_monitors.monitor(Watch(s, {**u, **means}, judged, ca.SX(1), settings, self.numeric,
                                                     period * sample_time, self.inputs.names, vehicle, u))
        countdown, kept_code = input_monitors.COUNTDOWN.name, input_monitors.CODE.name
        names = tuple(entry.name for entry in self.segment)
        ran = {**{n: updates.get(n, s[n]) for n in names}, **dict.fromkeys(sums.values(), ca.SX(0)),
               countdown: ca.SX(period - 1), kept_code: code}
        counted = {**{n: s[n] for n in names}, **{entry: s[entry] + added[name] for name, entry in sums.items()},
                   countdown: s[countdown] - 1}
        segment = CheckSegment(names, ca.vertcat(*(ran[n] for n in names)), s[countdown] > 0,
                               ca.vertcat(*(counted[n] for n in names)), ca.vertcat(*(s[n] for n in names)),
                               tuple(Sum(terms, sums[name], judged_sums[name]) for name, terms in averaged.items()))
        return Step({n: s[n] for n in names}, active * s[kept_code], checks=segment)

    def judge_model(self, s: dict, active, settings, sample_time: float, innovation=None, ay=None,
                    ay_model=None, concerns=None, beyond: tuple = (), held_here: bool = True,
                    friction_scale=None) -> Step:
        """The model checks' stage: the consistency monitor of the prior ``innovation`` (its
        entries kept while not active, unless ``held_here`` is False: an estimator that selects its
        whole state by ``active`` holds them itself; MODEL_INCONSISTENT where ``concerns``, default
        always: an estimator whose output the filter carries only in part says when it does), and
        BEYOND_LINEAR_RANGE while |``ay``| or |``ay_model``| (the filter's prior a_y, where it has
        one) > ``linear_range`` (times the filter's estimated ``friction_scale``, where it has one),
        held ``linear_range_hold`` after, or while any of the estimator's own ``beyond`` tests holds.
        Only the checks that are on generate code."""
        updates, code, first = {}, ca.SX(0), ca.SX(0)
        if self.consistency:
            check = consistency.monitor(s, innovation, settings, sample_time)
            updates = ({n: ca.if_else(active, value, s[n]) for n, value in check.updates.items()}
                       if held_here else check.updates)
            suspect = ca.logic_and(active, check.suspect)
            suspect = suspect if concerns is None else ca.logic_and(suspect, concerns)
            code = code + ca.if_else(suspect, status.MODEL_INCONSISTENT, 0)
            first = ca.logic_and(active, check.first)
        tests = list(beyond)
        if self.checks.linear_range and self.numeric["linear_range"] > 0:
            over = consistency.beyond_linear_range(ay, settings, ay_model, friction_scale)
            if self.linear_range_held:
                name = consistency.LINEAR_RANGE_STATE.name
                updates[name], over = held_flag(s[name], over, active, settings["linear_range_hold"], sample_time)
            tests.insert(0, over)
        if tests:
            code = code + ca.if_else(ca.logic_and(active, functools.reduce(ca.logic_or, tests)),
                                     status.BEYOND_LINEAR_RANGE, 0)
        return Step(updates, code, first)
