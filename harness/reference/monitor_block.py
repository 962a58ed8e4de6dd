"""The monitor block in plain Python (model.monitor_block): every check an estimator carries beyond
its method, declared once per estimator (:class:`Checks`) and built from its settings and its
method's inputs: the input layout, the inputs only the monitors read, the state entries and their
initial values, and the two stages of a step (the input monitors, ``harness.reference.monitors``;
then the consistency monitor of the filter's innovations and the linear-range flag,
``harness.reference.blocks``). Written from the equations, not from the model's code."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

from vsegen.harness.reference import blocks, monitors
from vsegen.harness.reference.input_checks import checks


@dataclass(frozen=True)
class Checks:
    """Which model checks an estimator carries beside the input monitors."""

    consistency: bool = False
    """A consistency monitor of its filter's prior innovations (setting residual_window > 0)."""
    linear_range: bool = False
    """BEYOND_LINEAR_RANGE while |a_y|, measured or the filter's prior, > linear_range (> 0), held
    linear_range_hold after."""

    def block(self, method_inputs, settings: Mapping) -> MonitorBlock:
        """The block for ``settings`` (an estimator's table), built once per table and set of
        check modules: a reference estimator asks for it on every step, and its layout is the same
        each time."""
        key = (self, tuple(method_inputs), id(settings), checks())
        kept = _BUILT.get(key)
        if kept is None or kept.settings is not settings:
            if len(_BUILT) >= _KEEP:
                _BUILT.clear()
            kept = _BUILT[key] = MonitorBlock(self, key[1], settings)
        return kept


_KEEP = 64
"""How many built blocks are kept (all are let go when there are more): a run uses one per estimator."""
_BUILT: dict[tuple, MonitorBlock] = {}
"""Blocks by (checks, method inputs, id of the settings table, check modules); an entry keeps its
table alive, so the id is not reused while it is kept."""


@dataclass(frozen=True)
class MonitorBlock:
    """The checks of one estimator for its ``settings``."""

    checks: Checks
    method_inputs: tuple[str, ...]
    settings: Mapping

    @cached_property
    def inputs(self) -> tuple[str, ...]:
        """The method's inputs and what the monitors read beside them, in the log's column order."""
        return monitors.inputs(self.method_inputs, self.settings)

    @cached_property
    def monitored(self) -> tuple[str, ...]:
        """The inputs only the monitors read (an implausible one does not hold the estimator)."""
        return monitors.monitored_only(self.method_inputs, self.settings)

    @property
    def range_held(self) -> bool:
        """Whether BEYOND_LINEAR_RANGE is held after it fell."""
        return self.checks.linear_range and self.settings["linear_range"] > 0 and self.settings["linear_range_hold"] > 0

    @property
    def consistent(self) -> bool:
        """Whether the consistency monitor is on."""
        return self.checks.consistency and self.settings["residual_window"] > 0

    @property
    def states(self) -> tuple[str, ...]:
        """The entries of the model checks that are on: the consistency monitor's, the linear-range
        hold's."""
        return (*(blocks.MONITOR_STATES if self.consistent else ()),
                *(("linear_range_hold_left",) if self.range_held else ()))

    @cached_property
    def segment(self) -> tuple[str, ...]:
        """The input monitors' entries: the last of an estimator's state."""
        return monitors.states(self.settings, self.inputs)

    def initial(self, first: Mapping[str, float]) -> dict:
        """The entries at the first sample ``first`` (its neutralised inputs)."""
        return {**dict.fromkeys(blocks.MONITOR_STATES if self.consistent else (), 0.0),
                **({"linear_range_hold_left": 0.0} if self.range_held else {}),
                **monitors.initial(self.settings, self.inputs, first)}

    def check_time(self, T: float) -> float:
        """s between two runs of the input checks."""
        return monitors.period(self.settings, T) * T

    def watch_inputs(self, x, u, ok, active: bool, T: float, vehicle, limits) -> tuple[dict, int]:
        """(the input monitors' entries after the sample, the status bits the method reports) on
        every sample: the checks run after the method, which reports their last run's code while
        ``active``, else 0. ``limits``: the [inputs] table."""
        if not self.segment:
            return {}, 0
        new = monitors.run(x, u, ok, active, self.settings, T, self.inputs, vehicle, self.segment, limits,
                           self.monitored)
        return new, int(x["checks_code"]) if active else 0

    def judge_model(self, x, innovation, T: float, ay: float, ay_model: float | None = None,
                    concerns: bool = True, beyond: bool = False,
                    friction_scale: float = 1.0) -> tuple[dict, int, bool]:
        """(new entries, status bits, first firing) of the model checks on an active sample: the
        consistency monitor (MODEL_INCONSISTENT where ``concerns``) and BEYOND_LINEAR_RANGE while
        |``ay``| or |``ay_model``| (the filter's prior a_y) > linear_range times the filter's
        estimated ``friction_scale``, held linear_range_hold after, or while the estimator's own
        ``beyond`` holds."""
        new, code, first = {}, 0, False
        if self.consistent:
            new, suspect, first = blocks.residual_monitor(x, innovation, self.settings, T)
            code |= blocks.MODEL_INCONSISTENT if suspect and concerns else 0
        if self.checks.linear_range:
            over = blocks.beyond_linear_range(ay, self.settings, ay_model, friction_scale)
            if self.range_held:
                new["linear_range_hold_left"], over = blocks.held_flag(x["linear_range_hold_left"], over,
                                                                       self.settings["linear_range_hold"], T)
            code |= blocks.BEYOND_LINEAR_RANGE if over else 0
        code |= blocks.BEYOND_LINEAR_RANGE if beyond else 0
        return new, code, first
