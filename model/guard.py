"""The input guard shared by all estimators: plausibility, low-speed hysteresis, status.

Rule (docs/methods.md, "Low speed and invalid inputs"):

* an input is *plausible* when |value| <= its limit from ``[inputs]``. The comparison is false for
  NaN and +-Inf, so one test rejects non-finite and out-of-range values alike (do not compile the C
  with -ffast-math, which breaks NaN comparisons);
* *low speed*: vx < vx_min, or vx < vx_resume while the estimator is still holding (hysteresis);
* the estimator is *active* when every input is plausible and the speed is not low; otherwise it
  holds (each estimator says what it holds and resets) and reports the status bits.

Every decision is a *flag*, exactly 0 or 1 (a comparison's value), and flags combine by arithmetic
(and: a b, or: a + b - a b, not: 1 - a): C's && and || on reals compile to compare-and-branch
chains (the Cortex-M4F guard of kf2dof: 460 B with them, 248 B without, measured). Selecting an
input keeps ``if_else`` (:func:`hold`): a rejected value may be NaN, which arithmetic would spread.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import casadi as ca

from vsegen.model import signals, status

LIMIT_KEYS = {entry.name: entry.limit_key for entry in signals.INPUTS}
"""Which ``[inputs]`` limit bounds which log column (model.signals)."""


@dataclass(frozen=True)
class Guard:
    plausible: dict[str, ca.SX]
    active: ca.SX
    status: ca.SX
    low_speed: ca.SX
    monitored: tuple[str, ...] = ()
    """Inputs only an input monitor reads: judged, but they do not decide whether the estimator
    holds."""


def input_guard(inputs: Mapping[str, ca.SX], limits: Mapping[str, float], vx_min: float,
                vx_resume: float, held_before: ca.SX, monitored: tuple[str, ...] = ()) -> Guard:
    """Plausibility of every input, activity and status bits for one sample.

    Args:
        inputs: the sample's inputs by log column name (must include ``vx``).
        limits: the ``[inputs]`` table.
        vx_min, vx_resume: low-speed limit and resume speed (m/s).
        held_before: non-zero if the estimator held at the previous sample (its ``holding``,
            ``hold_reason`` or ``low_speed_hold`` state entry), else 0.
        monitored: inputs only an input monitor reads (the yaw-rate check's wheel speeds): an
            implausible one neither holds the estimator nor raises INVALID_INPUT; the monitor
            skips the sample (``model.input_checks.wheel_yaw``).
    """
    plausible = plausibility(inputs, limits)
    all_plausible = _all(flag for name, flag in plausible.items() if name not in monitored)
    vx = inputs["vx"]
    low_speed = plausible["vx"] * _either(vx < vx_min, (held_before > 0) * (vx < vx_resume))
    active = all_plausible * (1 - low_speed)
    return Guard(plausible, active, _status(all_plausible, low_speed), low_speed, monitored)


def _status(all_plausible: ca.SX, low_speed: ca.SX) -> ca.SX:
    """The guard's status bits: INVALID_INPUT unless every input is plausible, LOW_SPEED."""
    return status.INVALID_INPUT * (1 - all_plausible) + status.LOW_SPEED * low_speed


def _either(a: ca.SX, b: ca.SX) -> ca.SX:
    """a or b, of flags."""
    return a + b - a * b


@dataclass(frozen=True)
class Decisions:
    """A guard's decisions as symbols (``symbols``: each input's plausibility, low speed, and
    last, active) and what they stand for (``values``), so one step expression written with them
    yields the composed step and the kernels of ``model.estimator.Guarded``."""

    symbols: ca.SX
    values: ca.SX

    def actual(self, expression: ca.SX) -> ca.SX:
        """``expression`` with every decision taken as the inputs and state decide it."""
        return ca.substitute(expression, self.symbols, self.values)

    def when_active(self, expression: ca.SX) -> ca.SX:
        """``expression`` on an active sample: every input plausible, the speed not low."""
        count = self.symbols.numel()
        constants = ca.vertcat(*[ca.SX(1)] * (count - 2), ca.SX(0), ca.SX(1))
        return ca.substitute(expression, self.symbols, constants)

    def when_held(self, expression: ca.SX) -> ca.SX:
        """``expression`` on a held sample, in terms of the other decisions' symbols."""
        return ca.substitute(expression, self.symbols[-1], ca.SX(0))


def symbolic(guard: Guard) -> tuple[Guard, Decisions]:
    """``guard`` with its decisions replaced by symbols (its status written with them), and the
    :class:`Decisions` that give them their values."""
    decisive = [name for name in guard.plausible if name not in guard.monitored]
    symbols = {name: ca.SX.sym(f"plausible_{name}") for name in decisive}
    low_speed, active = ca.SX.sym("low_speed"), ca.SX.sym("active")
    code = _status(_all(symbols.values()), low_speed)
    plausible = {name: symbols.get(name, flag) for name, flag in guard.plausible.items()}
    return (Guard(plausible, active, code, low_speed, guard.monitored),
            Decisions(ca.vertcat(*symbols.values(), low_speed, active),
                      ca.vertcat(*(guard.plausible[name] for name in decisive), guard.low_speed, guard.active)))


def plausibility(inputs: Mapping[str, ca.SX], limits: Mapping[str, float]) -> dict[str, ca.SX]:
    """|value| <= its [inputs] limit, per input (false for NaN and +-Inf)."""
    return {name: ca.fabs(value) <= limits[LIMIT_KEYS[name]] for name, value in inputs.items()}


def model_speed(vx: ca.SX, vx_min: float, vx_max: float) -> ca.SX:
    """The forward speed a model sees (m/s): ``vx`` clamped to [vx_min, vx_max]. Its upper bound is
    the v_x plausibility limit, so a held (plausible) speed never reaches past it."""
    return ca.fmin(ca.fmax(vx, vx_min), vx_max)


def hold(value: ca.SX, accept: ca.SX, previous: ca.SX) -> ca.SX:
    """``value`` where ``accept`` holds, else ``previous`` (never evaluates to the rejected value)."""
    return ca.if_else(accept, value, previous)


def _all(flags) -> ca.SX:
    """1 when every flag is 1: their product."""
    result = None
    for flag in flags:
        result = flag if result is None else result * flag
    return result


def first_sample(inputs: Mapping[str, ca.SX], limits: Mapping[str, float], vx_min: float,
                 vx_resume: float, monitored: tuple[str, ...] = ()) -> tuple[dict[str, ca.SX], ca.SX]:
    """Sample 0 for an estimator's ``init``: every implausible input replaced by a neutral value
    (vx by vx_min), and the initial ``holding`` flag: 0 only if every input (but the ``monitored``
    ones, :func:`input_guard`) is plausible and vx >= vx_resume (an estimator starts only above the
    resume speed)."""
    guard = input_guard(inputs, limits, vx_resume, vx_resume, ca.SX(1), monitored)
    values = {name: hold(value, guard.plausible[name], neutral(name, vx_min))
              for name, value in inputs.items()}
    return values, ca.if_else(guard.active, 0, 1)


def neutral(name: str, vx_min: float) -> float:
    """What an implausible input ``name`` of the first sample is replaced by (vx: ``vx_min``)."""
    value = signals.INPUT[name].neutral
    return vx_min if value is None else value


def previous_inputs(inputs: Mapping[str, ca.SX], plausible: Mapping[str, ca.SX],
                    previous: Mapping[str, ca.SX]) -> dict[str, ca.SX]:
    """New ``delta_prev`` and ``vx_prev``: this sample's value where plausible, else the old one."""
    return {f"{name}_prev": hold(inputs[name], plausible[name], previous[f"{name}_prev"])
            for name in ("delta", "vx")}
