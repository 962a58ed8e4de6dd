"""The input checks a sideslip estimator can carry beyond its method, one module each. Beyond
the papers; the rule they serve: never a silently wrong estimate.

Every module of this package is an input check (:class:`InputCheck`) and is found here, so a new
check is one new module (and its twin in ``harness/reference/input_checks``); no estimator and no
wiring changes. ``model.input_monitors`` combines the checks that are on: their schema fields,
inputs, state entries and status bits, and each step's updates and status code.

The checks run after the method, every ``check_period`` on an active sample, in a kernel of their
own (``model.estimator.CheckSegment``): :class:`Watch` gives them that period as their sample time,
the period's means (``model.input_monitors.AVERAGED``) and the sample's own inputs. A check whose
setting is 0 has no state and generates no code. Flags and selections are arithmetic, so the kernel has no branch
(``model.guard``).
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import casadi as ca

from vsegen.model.schema import Field
from vsegen.model.signals import Signal


@dataclass(frozen=True)
class Watch:
    """What every check sees on a step."""

    s: Mapping
    """The state entries as they came in."""
    u: Mapping
    """The inputs, with the means of the checks' period in place of a_y, r and a_x, and each
    axle's mean right minus left wheel speed (``model.input_monitors.AVERAGED``, by name)."""
    plausible: Mapping
    """Each input's plausibility flag (0/1)."""
    active: ca.SX
    """The guard's flag: a holding estimator holds its checks."""
    settings: Mapping
    """The estimator's settings: numbers or calibration symbols."""
    numeric: Mapping
    """Their numbers (which checks and entries exist)."""
    sample_time: float
    """s."""
    inputs: tuple[str, ...]
    """The estimator's input names."""
    vehicle: Mapping
    """The [vehicle] table: numbers or calibration symbols."""
    raw: Mapping
    """The sample's own inputs (a bit-for-bit test wants the sample); those only the checks read
    may be implausible."""


class InputCheck(Protocol):
    """The interface every module of this package provides."""

    ORDER: int
    """Its place among the checks: in the state layout and the status code (generated code stays
    the same when a check is added)."""
    FIELDS: tuple[Field, ...]
    """Its schema fields."""
    BITS: tuple[int, ...]
    """The status bits it can raise."""

    def reads(self, numeric_settings) -> tuple[str, ...]:
        """The inputs it reads beside the method's when it is on (an estimator is given them)."""

    def enabled(self, numeric_settings, inputs: tuple[str, ...]) -> bool:
        """Whether an estimator reading ``inputs`` has it (structural)."""

    def raises(self, numeric_settings, inputs: tuple[str, ...]) -> tuple[int, ...]:
        """The bits it raises as configured (none when it is off)."""

    def states(self, numeric_settings, inputs: tuple[str, ...]) -> tuple[Signal, ...]:
        """Its state entries (none when it is off)."""

    def initial_entries(self, first: dict, numeric_settings, inputs: tuple[str, ...]) -> dict:
        """Its entries at the first sample ``first`` (neutralised inputs)."""

    def monitor(self, watch: Watch) -> tuple[dict, dict]:
        """(new state entries, {status bit: 0/1 flag}) on a step; called only when enabled."""


_INTERFACE = (*InputCheck.__annotations__, *(name for name in vars(InputCheck) if not name.startswith("_")))
"""The names every check module must define: :class:`InputCheck`'s."""


@functools.cache
def registered() -> tuple[InputCheck, ...]:
    """Every input check of this package, in their ORDER."""
    checks = [importlib.import_module(f"{__name__}.{info.name}") for info in pkgutil.iter_modules(__path__)]
    for check in checks:
        missing = [name for name in _INTERFACE if not hasattr(check, name)]
        if missing:
            raise TypeError(f"{check.__name__} is no input check: it lacks {', '.join(missing)}")
    return tuple(sorted(checks, key=lambda check: check.ORDER))
