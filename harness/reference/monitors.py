"""The input monitors in plain Python (model.input_monitors): the input checks of
``harness.reference.input_checks`` (one module each) and, over them all, the recovery hold of
INPUT_FROZEN. They run after the method on an active sample every check_period (in whole samples,
at least one), stepped at that period, and keep their status bits in between (:func:`run`)."""

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
    """The state entries of the checks that are on, in their order, the recovery hold's, then the
    countdown to their next run and the status bits of their last; none when all are off."""
    if not _on(settings, inputs):
        return ()
    return (*(name for check in _on(settings, inputs) for name in check.states(settings, inputs)),
            *(("frozen_recovery_left",) if _recovers(settings, inputs) else ()),
            *(f"checks_sum_{name}" for name in averaged(inputs)), "checks_countdown", "checks_code")


AVERAGED = {"ay": ("ay",), "r": ("r",), "ax": ("ax",),
            "omega_f_diff": ("omega_fr", "omega_fl"), "omega_r_diff": ("omega_rr", "omega_rl")}
"""What the checks read as its mean over their period: an input, or an axle's right minus left
wheel speed (model.input_monitors.AVERAGED)."""


def averaged(inputs) -> dict[str, tuple[str, ...]]:
    """The means an estimator reading ``inputs`` has: {name: the inputs summed (first minus second)}."""
    return {name: terms for name, terms in AVERAGED.items() if all(term in inputs for term in terms)}


def initial(settings, inputs, first: Mapping[str, float]) -> dict:
    """The entries at init from the first sample's (neutralised) inputs ``first``; the checks run
    on the first step."""
    if not _on(settings, inputs):
        return {}
    entries = {}
    for check in _on(settings, inputs):
        entries |= check.initial(settings, inputs, first)
    return entries | ({"frozen_recovery_left": 0.0} if _recovers(settings, inputs) else {}) | {
        **{f"checks_sum_{name}": 0.0 for name in averaged(inputs)}, "checks_countdown": 0.0, "checks_code": 0.0}


def period(settings, T: float) -> int:
    """Samples between two runs of the checks."""
    return max(1, round(settings["check_period"] / T))


def run(x: Mapping[str, float], u: Mapping[str, float], ok: Mapping[str, bool], active: bool, settings,
        T: float, inputs, vehicle: Mapping[str, float], entries: tuple[str, ...], limits: Mapping[str, float],
        monitored: tuple[str, ...]) -> dict:
    """The checks' new entries after a sample (every sample): a held sample keeps them; on an
    ``active`` one, while their countdown runs, the countdown one less and each of
    :data:`AVERAGED` added to its sum (:func:`_summand`); when it is 0, a run at their period on
    the period's means (the other inputs this sample's) and the countdown and sums restarted.
    ``entries``: their names (:func:`states`); ``limits`` the [inputs] table, ``monitored`` the
    inputs only the checks read."""
    kept = {name: x[name] for name in entries}
    if not active:
        return kept
    terms = averaged(inputs)
    sums = {name: f"checks_sum_{name}" for name in terms}
    added = {name: _summand(u, terms[name], limits if set(terms[name]) & set(monitored) else None) for name in sums}
    if x["checks_countdown"] > 0:
        return kept | {entry: x[entry] + added[name] for name, entry in sums.items()} | {
            "checks_countdown": x["checks_countdown"] - 1}
    n = period(settings, T)
    means = {name: (x[entry] + added[name]) / n for name, entry in sums.items()}
    new, code = step(x, u | means, ok, settings, n * T, inputs, vehicle, raw=u)
    return kept | new | dict.fromkeys(sums.values(), 0.0) | {"checks_countdown": float(n - 1),
                                                              "checks_code": float(code)}


def _summand(u: Mapping[str, float], terms: tuple[str, ...], limits: Mapping[str, float] | None) -> float:
    """The input ``terms[0]`` (minus ``terms[1]``); with ``limits`` (inputs the checks alone read,
    which can be implausible on an active sample), 0 unless that value is plausible by the limit of
    ``terms[0]``, so a sum of it stays finite."""
    value = u[terms[0]] - (u[terms[1]] if len(terms) > 1 else 0.0)
    if limits is not None and not blocks.plausible(limits, terms[0], value):
        return 0.0
    return value


def step(x: Mapping[str, float], u: Mapping[str, float], ok: Mapping[str, bool], settings, T: float,
         inputs, vehicle: Mapping[str, float], raw: Mapping[str, float]) -> tuple[dict, int]:
    """(new entries, status bits) of one run of the checks that are on at period ``T``, on an
    active sample: ``u`` the inputs and the period's means of :data:`AVERAGED`, ``raw`` the
    sample's own inputs."""
    new, code = {}, 0
    for check in _on(settings, inputs):
        checked, bits = check.step(x, u, ok, settings, T, inputs, vehicle, raw)
        new, code = new | checked, code | bits
    if _recovers(settings, inputs):             # INPUT_FROZEN held while the estimate recovers
        new["frozen_recovery_left"], frozen = blocks.held_flag(
            x["frozen_recovery_left"], bool(code & blocks.INPUT_FROZEN), settings["frozen_recovery"], T)
        code |= blocks.INPUT_FROZEN if frozen else 0
    return new, code
