"""Frozen-signal monitor shared by the estimators: a stuck sensor, or a CAN signal whose sender
stopped updating it, repeats its last value. Beyond the papers; the rule it serves: never a
silently wrong estimate.

The monitored channels are the estimator's inertial inputs among a_x, a_y and r: in operation
their sensor noise lies far above their resolution (seed 000 Table 2: 0.3 m/s^2 and 1 deg/s against
ESC resolutions of about 0.01 m/s^2 and 0.1 deg/s), so a real signal never repeats bit for bit for
long. Per channel c, on each run of the checks (every check_period T_c, on the sample itself, not
the period's mean), with u_c held at its last plausible value (model.guard):

    n_c,k = min(n_c,k-1 + 1, N)   if u_c,k == u_c,k-1 (bit for bit),   else 0,
    N = frozen_time / T_c (rounded to whole runs),

and the status bit INPUT_FROZEN is raised on an active sample while any n_c reaches N (within
``frozen_time`` of the freeze). An implausible sample (NaN, out of range) does not count as a
repetition; INVALID_INPUT reports it. A holding estimator holds the monitor with the rest of its
state; it watches again from the first active sample. Steering angle, speed and wheel speeds are not monitored:
they can be constant, quantisation and all, while the car drives straight or at constant speed.
A logger that records a CAN signal at a multiple of its message rate repeats values by design:
``frozen_time`` must exceed a few message periods (the default 0.25 s covers 50 ms periods).
``frozen_time`` = 0 switches the monitor off (no state, no status).
"""

from __future__ import annotations

import functools

import casadi as ca

from vsegen.model import status
from vsegen.model.filters import whole_samples
from vsegen.model.input_checks import Watch
from vsegen.model.schema import nonnegative
from vsegen.model.signals import INPUT, Signal

ORDER = 1

CHANNELS = ("ax", "ay", "r")
"""The inputs the monitor watches, where an estimator reads them."""

FIELDS = (nonnegative("frozen_time", "s", "beyond the papers: an inertial input (a_x, a_y, r) that "
                    "repeats its value bit for bit this long raises status INPUT_FROZEN (a stuck "
                    "sensor or CAN signal); longer than a few CAN message periods; 0 = no monitor",
                    default=0.25),
          nonnegative("frozen_recovery", "s", "beyond the papers: status INPUT_FROZEN stays raised this "
                      "long after a frozen input (or steering angle) moves again, while the estimate "
                      "recovers from what it was fed; 0 = off", default=0.0))
"""``frozen_time``, and ``frozen_recovery``: the hold of INPUT_FROZEN that ``model.input_monitors``
puts over every check raising it (the steer check too)."""
BITS = (status.INPUT_FROZEN,)


def channels(inputs: tuple[str, ...]) -> tuple[str, ...]:
    """The monitored channels among an estimator's ``inputs`` (log column names)."""
    return tuple(c for c in CHANNELS if c in inputs)


def reads(numeric_settings) -> tuple[str, ...]:
    """None beside the method's: the monitor watches what the method reads."""
    return ()


def enabled(numeric_settings, inputs: tuple[str, ...]) -> bool:
    """Whether the generated code has the monitor (structural: ``frozen_time`` > 0 when it is
    generated, also in calibratable mode, and an estimator reading ``inputs`` has a channel)."""
    return numeric_settings["frozen_time"] > 0.0 and bool(channels(inputs))


def raises(numeric_settings, inputs: tuple[str, ...]) -> tuple[int, ...]:
    """INPUT_FROZEN where the monitor is on."""
    return BITS if enabled(numeric_settings, inputs) else ()


def states(numeric_settings, inputs: tuple[str, ...]) -> tuple[Signal, ...]:
    """The monitor's state entries for an estimator reading ``inputs`` (none when it is off)."""
    if not enabled(numeric_settings, inputs):
        return ()
    entries = []
    for c in channels(inputs):
        unit = INPUT[c].signal.unit
        entries += [Signal(f"frozen_{c}_value", unit, f"frozen-signal monitor: last plausible {c}"),
                    Signal(f"frozen_{c}_repeats", "-", f"frozen-signal monitor: samples {c} has "
                           "repeated its value (at most frozen_time / T)")]
    return tuple(entries)


def initial_entries(first: dict, numeric_settings, inputs: tuple[str, ...]) -> dict:
    """The entries at init: the first sample's (neutralised) values, no repetition."""
    if not enabled(numeric_settings, inputs):
        return {}
    return {k: v for c in channels(inputs)
            for k, v in ((f"frozen_{c}_value", first[c]), (f"frozen_{c}_repeats", ca.SX(0)))}


def samples_limit(settings, sample_time: float):
    """N = frozen_time / T, rounded to whole samples."""
    return whole_samples(settings["frozen_time"], sample_time)


def any_frozen(updates: dict, settings, sample_time: float, names: tuple[str, ...]) -> ca.SX:
    """1 while one of the channels ``names`` is frozen, from the monitor's entries ``updates``
    (the state's: its last run; ``sample_time`` the checks' period); 0 when the monitor is off or
    watches none of them."""
    counts = [updates[f"frozen_{c}_repeats"] for c in names if f"frozen_{c}_repeats" in updates]
    if not counts:
        return ca.SX(0)
    limit = samples_limit(settings, sample_time)
    return functools.reduce(ca.logic_or, [count >= limit for count in counts])


def monitor(watch: Watch) -> tuple[dict, dict]:
    """(new state entries, {INPUT_FROZEN: 1 while a channel is frozen}) on a step; call only when
    :func:`enabled`. An implausible sample is no repetition, and a holding estimator holds the
    monitor too."""
    s, u, plausible, active = watch.s, watch.raw, watch.plausible, watch.active
    limit = samples_limit(watch.settings, watch.sample_time)
    updates, frozen = {}, ca.SX(0)
    for c in channels(watch.inputs):
        value, count = s[f"frozen_{c}_value"], s[f"frozen_{c}_repeats"]
        repeated = plausible[c] * (u[c] == value)
        count_next = repeated * ca.fmin(count + 1, limit)
        updates[f"frozen_{c}_value"] = ca.if_else(active, ca.if_else(plausible[c], u[c], value), value)
        updates[f"frozen_{c}_repeats"] = ca.if_else(active, count_next, count)
        stuck = count_next >= limit
        frozen = frozen + stuck - frozen * stuck
    return updates, {status.INPUT_FROZEN: active * frozen}
