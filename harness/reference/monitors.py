"""The input monitors in plain Python (model.input_monitors): the input checks of
``harness.reference.input_checks`` (one module each) and, over them all, the recovery hold of
INPUT_FROZEN."""

from __future__ import annotations

from collections.abc import Mapping

from vsegen.harness.reference import blocks
from vsegen.harness.reference.input_checks import checks

COLUMNS = ("delta", "vx", "ax", "ay", "r", "omega_fl", "omega_fr", "omega_rl", "omega_rr", "mz")
"""The log format's input columns in their order (docs/conventions.md)."""


def _on(settings, inputs) -> tuple:
    return tuple(check for check in checks() if check.enabled(settings, inputs))


def inputs(method_inputs, settings) -> tuple[str, ...]:
    """The inputs of an estimator whose method reads ``method_inputs``, and what the checks that
    are on read beside them (the yaw-rate check: a_x and its axle's wheel speeds), in the log's
    column order."""
    wanted = {*method_inputs, *(name for check in checks() for name in check.reads(settings))}
    return tuple(name for name in COLUMNS if name in wanted)


def monitored_only(method_inputs, settings) -> tuple[str, ...]:
    """The inputs only the monitors read: an implausible one does not hold the estimator."""
    return tuple(name for name in inputs(method_inputs, settings) if name not in method_inputs)


def _recovers(settings, inputs) -> bool:
    return settings["frozen_recovery"] > 0 and any(check.raises(settings, inputs) & blocks.INPUT_FROZEN
                                                   for check in checks())


def states(settings, inputs) -> tuple[str, ...]:
    """The state entries of the checks that are on, in their order, then the recovery hold's."""
    return (*(name for check in _on(settings, inputs) for name in check.states(settings, inputs)),
            *(("frozen_recovery_left",) if _recovers(settings, inputs) else ()))


def initial(settings, inputs, first: Mapping[str, float]) -> dict:
    """The entries at init from the first sample's (neutralised) inputs ``first``."""
    entries = {}
    for check in _on(settings, inputs):
        entries |= check.initial(settings, inputs, first)
    return entries | ({"frozen_recovery_left": 0.0} if _recovers(settings, inputs) else {})


def step(x: Mapping[str, float], u: Mapping[str, float], ok: Mapping[str, bool], settings, T: float,
         inputs, vehicle: Mapping[str, float]) -> tuple[dict, int]:
    """(new entries, status bits) of the checks that are on; call only on an active sample (a
    holding estimator holds its monitors)."""
    new, code = {}, 0
    for check in _on(settings, inputs):
        checked, bits = check.step(x, u, ok, settings, T, inputs, vehicle)
        new, code = new | checked, code | bits
    if _recovers(settings, inputs):             # INPUT_FROZEN held while the estimate recovers
        new["frozen_recovery_left"], frozen = blocks.held_flag(
            x["frozen_recovery_left"], bool(code & blocks.INPUT_FROZEN), settings["frozen_recovery"], T)
        code |= blocks.INPUT_FROZEN if frozen else 0
    return new, code
