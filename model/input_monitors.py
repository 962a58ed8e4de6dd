"""The input monitors a sideslip estimator carries beyond its method, behind one interface: the
frozen-signal monitor (``model.frozen``, status INPUT_FROZEN), the cross-checks of the inputs
against each other (``model.crosscheck``, status LATERAL_INCONSISTENT, STEERING_OFFSET and
INPUT_FROZEN) and the yaw rate against the non-driven wheels (``model.wheel_yaw``, status
YAW_RATE_MISMATCH, where the estimator reads wheel speeds).

An estimator lists :data:`FIELDS` in its schema, puts :func:`states` in its state layout and
:func:`initial_entries` in its initial state, and adds the code :func:`monitor` returns to its
status; each monitor that is off (its setting 0) has no state and no code.
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import crosscheck, frozen, status, wheel_yaw
from vsegen.model.signals import Signal

FIELDS = (frozen.FIELD, *crosscheck.FIELDS, *wheel_yaw.FIELDS)
STATUS_BITS = (status.INPUT_FROZEN, status.LATERAL_INCONSISTENT, status.STEERING_OFFSET)
"""The bits the monitors can raise in every estimator that has them; YAW_RATE_MISMATCH too where
the estimator reads wheel speeds (:data:`WHEEL_STATUS_BITS`)."""
WHEEL_STATUS_BITS = (*STATUS_BITS, status.YAW_RATE_MISMATCH)
OFF = {"frozen_time": 0.0, "lateral_check_limit": 0.0, "steering_offset_limit": 0.0, "steer_check_limit": 0.0,
       "wheel_check_limit": 0.0}
"""The settings that switch every monitor off (no state, no code)."""


def enabled(numeric_settings, inputs: tuple[str, ...]) -> bool:
    """Whether an estimator reading ``inputs`` has any input monitor (structural)."""
    return (frozen.enabled(numeric_settings) or crosscheck.enabled(numeric_settings, inputs)
            or wheel_yaw.enabled(numeric_settings, inputs))


def states(numeric_settings, inputs: tuple[str, ...]) -> tuple[Signal, ...]:
    """The monitors' state entries (those that are on)."""
    return (*frozen.states(numeric_settings, inputs), *crosscheck.states(numeric_settings, inputs),
            *wheel_yaw.states(numeric_settings, inputs))


def initial_entries(first: dict, numeric_settings, inputs: tuple[str, ...]) -> dict:
    """The monitors' entries at init from the first sample ``first`` (neutralised inputs)."""
    return {**frozen.initial_entries(first, numeric_settings, inputs),
            **crosscheck.initial_entries(first, numeric_settings, inputs),
            **{entry.name: ca.SX(0) for entry in wheel_yaw.states(numeric_settings, inputs)}}


def monitor(s: dict, u: dict, plausible: dict, active, settings, numeric_settings,
            sample_time: float, inputs: tuple[str, ...], vehicle) -> tuple[dict, ca.SX]:
    """(new state entries, status code) of the monitors that are on, from the state entries
    ``s`` as they came in, the raw inputs ``u``, their plausibility flags and the guard's
    ``active`` flag (a holding estimator holds its monitors); ``settings`` the estimator's
    (numbers or calibration symbols), ``numeric_settings`` their numbers (which monitors exist),
    ``vehicle`` the [vehicle] table (numbers or symbols)."""
    updates, raised = {}, {}
    if frozen.enabled(numeric_settings):
        updates, raised[status.INPUT_FROZEN] = frozen.monitor(s, u, plausible, active, settings,
                                                              sample_time, inputs)
    if crosscheck.enabled(numeric_settings, inputs):
        checked, flags = crosscheck.monitor(s, u, active, settings, numeric_settings, sample_time,
                                            vehicle["wheelbase"])
        updates |= checked
        for bit, flag in flags.items():     # a bit two monitors raise counts once
            raised[bit] = flag + raised[bit] - flag * raised[bit] if bit in raised else flag
    if wheel_yaw.enabled(numeric_settings, inputs):
        checked, raised[status.YAW_RATE_MISMATCH] = wheel_yaw.monitor(s, u, active, settings, numeric_settings,
                                                                      sample_time, vehicle)
        updates |= checked
    return updates, sum((bit * flag for bit, flag in raised.items()), ca.SX(0))
