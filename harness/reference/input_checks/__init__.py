"""The input checks in plain Python (``model.input_checks``), one module each, written from their
equations, not from the model's code; found here, so a new check is one new module.

Each module provides ``ORDER`` (its place among the checks), ``reads(settings)`` (the inputs it
reads beside the method's), ``enabled(settings, inputs)``, ``raises(settings, inputs)`` (the
status bits it raises as configured, OR-ed), ``states(settings, inputs)``,
``initial(settings, inputs, first)`` and ``step(x, u, ok, settings, T, inputs, vehicle, raw)`` ->
(new entries, status bits), called on an active sample when the checks run (every check_period,
``T`` that period; ``u`` holds the period's means of ``harness.reference.monitors.AVERAGED``, ``raw``
the sample's own inputs).
"""

from __future__ import annotations

import importlib
import pkgutil
from functools import cache

from vsegen.harness.reference import blocks


@cache
def checks() -> tuple:
    """The check modules of this package, in their ORDER."""
    found = (importlib.import_module(f"{__name__}.{info.name}") for info in pkgutil.iter_modules(__path__))
    return tuple(sorted(found, key=lambda module: module.ORDER))


def learned_check(x, entry: str, value: float, sampled: bool, time_constant: float, limit: float, settings,
                  T: float) -> tuple[dict, bool]:
    """(new entries, raised) of a check on a learned mean: ``entry`` learns ``value`` where ``sampled``
    (its runs counted in ``entry``_samples); raised where |mean| > ``limit`` once it has taken
    learned_after of runs, or its time constant's if fewer."""
    mean, taken = x[entry], x[f"{entry}_samples"]
    if sampled:
        mean, taken = blocks.learned_mean(mean, taken, value, T, time_constant)
    judged = taken >= min(blocks.whole_samples(settings["learned_after"], T), blocks.whole_samples(time_constant, T))
    return {entry: mean, f"{entry}_samples": taken}, judged and abs(mean) > limit
