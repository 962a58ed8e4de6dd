"""The frozen-signal monitor (model.input_checks.frozen): per inertial channel, the samples its
plausible value has repeated bit for bit, at most N = round(frozen_time / T); INPUT_FROZEN while
any count reaches N."""

from __future__ import annotations

from collections.abc import Mapping

from vsegen.harness.reference import blocks

ORDER = 1
CHANNELS = ("ax", "ay", "r")
"""The channels it watches (model.input_checks.frozen.CHANNELS), where an estimator reads them."""


def reads(settings) -> tuple[str, ...]:
    return ()


def enabled(settings, inputs) -> bool:
    return settings["frozen_time"] > 0.0 and any(c in inputs for c in CHANNELS)


def raises(settings, inputs) -> int:
    return blocks.INPUT_FROZEN if enabled(settings, inputs) else 0


def states(settings, inputs) -> tuple[str, ...]:
    """Per watched channel: its last plausible value and its repetitions."""
    if not enabled(settings, inputs):
        return ()
    return tuple(name for c in CHANNELS if c in inputs for name in (f"frozen_{c}_value", f"frozen_{c}_repeats"))


def initial(settings, inputs, first: Mapping[str, float]) -> dict:
    """The first sample's (neutralised) values, no repetition."""
    if not enabled(settings, inputs):
        return {}
    return {k: v for c in CHANNELS if c in inputs
            for k, v in ((f"frozen_{c}_value", first[c]), (f"frozen_{c}_repeats", 0.0))}


def any_frozen(new: Mapping[str, float], settings, T, names) -> bool:
    """Whether one of the channels ``names`` is frozen, from the monitor's new entries ``new``
    (model.input_checks.frozen.any_frozen); False when the monitor is off."""
    limit = blocks.whole_samples(settings["frozen_time"], T)
    return settings["frozen_time"] > 0 and any(new.get(f"frozen_{c}_repeats", 0.0) >= limit for c in names)


def step(x, u: Mapping[str, float], ok: Mapping[str, bool], settings, T, inputs, vehicle,
         raw: Mapping[str, float]) -> tuple[dict, int]:
    """(new entries, INPUT_FROZEN or 0) from the sample's own inputs ``raw`` (bit for bit, not
    the period's means ``u``); an implausible sample is no repetition."""
    u = raw
    limit = blocks.whole_samples(settings["frozen_time"], T)
    new, frozen = {}, False
    for c in (c for c in CHANNELS if c in inputs):
        value, count = x[f"frozen_{c}_value"], x[f"frozen_{c}_repeats"]
        count = min(count + 1.0, limit) if ok[c] and u[c] == value else 0.0
        new[f"frozen_{c}_value"] = u[c] if ok[c] else value
        new[f"frozen_{c}_repeats"] = count
        frozen = frozen or count >= limit
    return new, blocks.INPUT_FROZEN if frozen else 0
