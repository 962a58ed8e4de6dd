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


@cache
def checks() -> tuple:
    """The check modules of this package, in their ORDER."""
    found = (importlib.import_module(f"{__name__}.{info.name}") for info in pkgutil.iter_modules(__path__))
    return tuple(sorted(found, key=lambda module: module.ORDER))
