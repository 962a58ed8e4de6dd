"""The input monitors a sideslip estimator carries beyond its method, behind one interface: the
input checks of ``model.input_checks`` (each check one module there: the frozen-signal monitor,
the cross-checks of the inputs against each other, the yaw rate against the non-driven wheels)
and, over them all, the recovery hold of INPUT_FROZEN.

The monitor block (``model.monitor_block``) takes from here the schema fields, the inputs the
checks add to the method's, the state entries and their initial values (the checks', then the
sums of the averaged inputs, the countdown to the next run and the last run's status code), and
a run's updates and status code; each check that is off (its setting 0) has no state and no code.
The checks run every ``check_period`` (:func:`period`), after the method, in a kernel of their own
(``model.estimator.CheckSegment``).
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import signals, status
from vsegen.model.filters import held_flag
from vsegen.model.guard import LIMIT_KEYS, hold
from vsegen.model.input_checks import Watch, registered
from vsegen.model.layout import Layout
from vsegen.model.schema import nonnegative
from vsegen.model.signals import Signal

RECOVERY_STATE = Signal("frozen_recovery_left", "-", "samples INPUT_FROZEN stays raised after a frozen input "
                        "moved again (frozen_recovery; samples of the checks' period)")
COUNTDOWN = Signal("checks_countdown", "-", "input checks: active samples to their next run (check_period)")
AVERAGED = {"ay": ("ay",), "r": ("r",), "ax": ("ax",),
            "omega_f_diff": ("omega_fr", "omega_fl"), "omega_r_diff": ("omega_rr", "omega_rl")}
"""What the checks read as its mean over their period, by name: an input, or the right minus the
left wheel speed of an axle (summed on every active sample between two runs; an input only the
checks read, only where it is plausible): a sample a period stands for would carry its whole
noise."""
CODE = Signal("checks_code", "-", "input checks: the status bits of their last run")
CHECK_PERIOD = nonnegative(
    "check_period", "s", "beyond the papers: the input checks (frozen signals, cross-checks, wheel yaw "
    "rate) run after the method on an active sample this often, in whole samples (at least one), "
    "their filters and counters stepped at that period, their status bits kept in between: they "
    "watch for faults that last tenths of a second, the filter runs every sample; 0 = every sample",
    default=0.1)
FIELDS = (CHECK_PERIOD, *(field for check in registered() for field in check.FIELDS))
"""``check_period``, then the checks' fields (``frozen_recovery``, the hold over them all, with the
frozen-signal monitor's)."""
STATUS_BITS = tuple(dict.fromkeys(bit for check in registered() for bit in check.BITS))
"""The bits the checks can raise in every estimator that has them (YAW_RATE_MISMATCH where the
yaw-rate check is on: every such estimator can be given the wheel speeds, :func:`inputs`)."""
OFF = {"frozen_time": 0.0, "lateral_check_limit": 0.0, "steering_offset_limit": 0.0, "steer_check_limit": 0.0,
       "wheel_check_limit": 0.0}
"""The settings that switch every check off (no state, no code)."""


def _on(numeric_settings, inputs: tuple[str, ...]):
    """The checks an estimator reading ``inputs`` has, in their order."""
    return tuple(check for check in registered() if check.enabled(numeric_settings, inputs))


def inputs(method_inputs: tuple[str, ...], numeric_settings) -> Layout:
    """The input layout of an estimator whose method reads ``method_inputs``, plus what the
    checks that are on read beside them (the yaw-rate check: a_x and its axle's wheel speeds),
    in the catalogue's order (``model.signals.INPUTS``)."""
    wanted = {*method_inputs, *(name for check in registered() for name in check.reads(numeric_settings))}
    return Layout(tuple(entry.signal for entry in signals.INPUTS if entry.name in wanted))


def monitored_only(method_inputs: tuple[str, ...], numeric_settings) -> tuple[str, ...]:
    """The inputs only the checks read (``model.guard.input_guard``'s ``monitored``): an
    implausible one does not hold the estimator."""
    return tuple(name for name in inputs(method_inputs, numeric_settings).names if name not in method_inputs)


def recovers(numeric_settings, inputs: tuple[str, ...]) -> bool:
    """Whether INPUT_FROZEN is held after a freeze (structural: ``frozen_recovery`` > 0 and a
    check that raises it)."""
    return numeric_settings["frozen_recovery"] > 0.0 and any(
        status.INPUT_FROZEN in check.raises(numeric_settings, inputs) for check in registered())


def states(numeric_settings, inputs: tuple[str, ...]) -> tuple[Signal, ...]:
    """The checks' state entries (those that are on), the recovery hold's, then their countdown
    and status code; none when every check is off."""
    checks = _on(numeric_settings, inputs)
    if not checks:
        return ()
    return (*(entry for check in checks for entry in check.states(numeric_settings, inputs)),
            *((RECOVERY_STATE,) if recovers(numeric_settings, inputs) else ()),
            *(sum_state(name) for name in averaged(inputs)), COUNTDOWN, CODE)


def averaged(inputs: tuple[str, ...]) -> dict[str, tuple[str, ...]]:
    """The means of :data:`AVERAGED` an estimator reading ``inputs`` has: {name: the inputs it
    sums (one, or right and left wheel)}."""
    return {name: terms for name, terms in AVERAGED.items() if all(term in inputs for term in terms)}


def sum_state(name: str) -> Signal:
    """The state entry summing ``name`` of :data:`AVERAGED` over the active samples since the
    checks' last run."""
    unit = signals.INPUT[AVERAGED[name][0]].signal.unit
    return Signal(f"checks_sum_{name}", unit, f"input checks: sum of {name} since their last run")


def summand(name: str, u, limits=None):
    """The value ``name`` of :data:`AVERAGED` adds to its sum on an active sample: its input, or
    right minus left wheel speed; with ``limits`` (the [inputs] table: its inputs are read by the
    checks alone, ``model.estimator.Sum``), 0 where |value| exceeds the limit of its first input
    (the sum stays finite)."""
    terms = AVERAGED[name]
    value = u[terms[0]] if len(terms) == 1 else u[terms[0]] - u[terms[1]]
    if limits is None:
        return value
    return hold(value, ca.fabs(value) <= limits[LIMIT_KEYS[terms[0]]], 0)


def initial_entries(first: dict, numeric_settings, inputs: tuple[str, ...]) -> dict:
    """The checks' entries at init from the first sample ``first`` (neutralised inputs); they run
    on the first step."""
    checks = _on(numeric_settings, inputs)
    if not checks:
        return {}
    entries = {}
    for check in checks:
        entries |= check.initial_entries(first, numeric_settings, inputs)
    return (entries | ({RECOVERY_STATE.name: ca.SX(0)} if recovers(numeric_settings, inputs) else {})
            | {sum_state(name).name: ca.SX(0) for name in averaged(inputs)}
            | {COUNTDOWN.name: ca.SX(0), CODE.name: ca.SX(0)})


def period(numeric_settings, sample_time: float) -> int:
    """Samples between two runs of the checks: ``check_period`` in whole samples, at least one
    (structural: the number decides the code, also in calibratable mode)."""
    return max(1, round(numeric_settings["check_period"] / sample_time))


def monitor(watch: Watch) -> tuple[dict, ca.SX]:
    """(new state entries, status code) of the checks that are on (:class:`Watch`: what they see);
    a bit two checks raise counts once; INPUT_FROZEN held ``frozen_recovery`` after it fell."""
    updates, raised = {}, {}
    for check in _on(watch.numeric, watch.inputs):
        checked, flags = check.monitor(watch)
        updates |= checked
        for bit, flag in flags.items():
            raised[bit] = flag + raised[bit] - flag * raised[bit] if bit in raised else flag
    if recovers(watch.numeric, watch.inputs):
        updates[RECOVERY_STATE.name], raised[status.INPUT_FROZEN] = held_flag(
            watch.s[RECOVERY_STATE.name], raised.get(status.INPUT_FROZEN, ca.SX(0)), watch.active,
            watch.settings["frozen_recovery"], watch.sample_time)
    return updates, sum((bit * flag for bit, flag in raised.items()), ca.SX(0))
