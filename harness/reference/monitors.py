"""The input monitors in plain Python (model.input_monitors): the frozen-signal monitor
(``blocks.frozen_*``), the cross-checks of the inputs against each other (model.crosscheck) and
the yaw rate against the non-driven wheels (model.wheel_yaw), written from their equations, not
from the model's code."""

from __future__ import annotations

import math
from collections.abc import Mapping

from vsegen.harness.reference import blocks

COLUMNS = ("delta", "vx", "ax", "ay", "r", "omega_fl", "omega_fr", "omega_rl", "omega_rr", "mz")
"""The log format's input columns in their order (docs/conventions.md)."""
CROSSCHECK_INPUTS = ("delta", "vx", "ay", "r")
CHECKS = {"lateral_check_limit": ("lateral_residual",), "steering_offset_limit": ("steering_offset",),
          "steer_check_limit": ("curvature", "steady_curvature")}
"""Each cross-check: the setting that switches it on (> 0), its state entries."""


def _on(settings, limit_key) -> bool:
    return settings[limit_key] > 0


def _crosschecked(settings, inputs) -> bool:
    return all(n in inputs for n in CROSSCHECK_INPUTS) and any(_on(settings, key) for key in CHECKS)


def _wheel_axle(settings) -> tuple[str, str]:
    axle = "r" if settings["wheel_check_axle"] == "rear" else "f"
    return f"omega_{axle}l", f"omega_{axle}r"


def _wheel_checked(settings, inputs) -> bool:
    return _on(settings, "wheel_check_limit") and all(n in inputs for n in ("delta", "ax", "r", *_wheel_axle(settings)))


def inputs(method_inputs, settings) -> tuple[str, ...]:
    """The inputs of an estimator whose method reads ``method_inputs``: with the yaw-rate check on,
    also a_x and the checked axle's wheel speeds, in the log's column order."""
    checked = ("delta", "ax", "r", *_wheel_axle(settings)) if _on(settings, "wheel_check_limit") else ()
    return tuple(name for name in COLUMNS if name in {*method_inputs, *checked})


def monitored_only(method_inputs, settings) -> tuple[str, ...]:
    """The inputs only the monitors read: an implausible one does not hold the estimator."""
    return tuple(name for name in inputs(method_inputs, settings) if name not in method_inputs)


def states(settings, inputs) -> tuple[str, ...]:
    """The state entries of the monitors that are on: the frozen-signal monitor's, then the
    cross-checks' (quasi-steady detector, then each check's that is on), the yaw-rate check's."""
    checks = ()
    if _crosschecked(settings, inputs):
        checks = ("steady_delta", "steady_samples",
                  *(name for key, names in CHECKS.items() if _on(settings, key) for name in names))
    wheels = ()
    if _wheel_checked(settings, inputs):
        wheels = ("wheel_yaw_residual", *(("wheel_yaw_rate",) if _on(settings, "wheel_check_scale") else ()),
                  *(("wheel_yaw_hold_left",) if _on(settings, "wheel_check_hold") else ()))
    recovery = ("frozen_recovery_left",) if _recovers(settings, inputs) else ()
    return (*blocks.frozen_states(settings, inputs), *checks, *wheels, *recovery)


def initial(settings, inputs, first: Mapping[str, float]) -> dict:
    """The monitors' entries at init: the frozen monitor's, a quasi-steady stretch starting at the
    first sample's steer angle, nothing learned."""
    entries = blocks.frozen_initial(settings, inputs, first)
    for name in states(settings, inputs)[len(entries):]:
        entries[name] = first["delta"] if name == "steady_delta" else 0.0
    return entries


def step(x: Mapping[str, float], u: Mapping[str, float], ok: Mapping[str, bool], settings, T: float,
         inputs, vehicle: Mapping[str, float]) -> tuple[dict, int]:
    """(new entries, status bits) of the monitors that are on; call only on an active sample (a
    holding estimator holds its monitors)."""
    new, code = {}, 0
    if settings["frozen_time"] > 0:
        new, frozen = blocks.frozen_monitor(x, u, ok, settings, T, inputs)
        code = blocks.INPUT_FROZEN if frozen else 0
    if _crosschecked(settings, inputs):
        checked, flags = _crosschecks(x, u, settings, T, vehicle["wheelbase"])
        new, code = new | checked, code | flags
    if _wheel_checked(settings, inputs):        # r against the free-rolling axle's speed difference
        checked, mismatch = _wheel_check(x, u, ok, settings, T, vehicle)
        new, code = new | checked, code | (blocks.YAW_RATE_MISMATCH if mismatch else 0)
    if _recovers(settings, inputs):             # INPUT_FROZEN held while the estimate recovers
        new["frozen_recovery_left"], frozen = blocks.held_flag(
            x["frozen_recovery_left"], bool(code & blocks.INPUT_FROZEN), settings["frozen_recovery"], T)
        code |= blocks.INPUT_FROZEN if frozen else 0
    return new, code


def _wheel_check(x, u, ok, settings, T: float, vehicle) -> tuple[dict, bool]:
    """(new entries, YAW_RATE_MISMATCH) of the yaw rate against the non-driven axle's wheel yaw rate
    r_w (model.wheel_yaw): the mean of r - r_w beyond the limit, or beyond a share of the mean
    |r_w| where that is large enough, held a while after; a sample with an implausible a_x or
    wheel speed is skipped."""
    left, right = _wheel_axle(settings)
    new = {"wheel_yaw_residual": x["wheel_yaw_residual"]}
    if _on(settings, "wheel_check_scale"):
        new["wheel_yaw_rate"] = x["wheel_yaw_rate"]
    readable = ok["ax"] and ok[left] and ok[right]
    if readable and abs(u["ax"]) <= settings["wheel_check_ax"]:     # no brake or drive slip
        steer = math.cos(u["delta"]) if settings["wheel_check_axle"] == "front" else 1.0
        wheel_yaw_rate = vehicle["wheel_radius"] * (u[right] - u[left]) / (vehicle["track_width"] * steer)
        new["wheel_yaw_residual"] = blocks.low_pass(new["wheel_yaw_residual"], u["r"] - wheel_yaw_rate, T,
                                                    settings["wheel_check_time"])
        if _on(settings, "wheel_check_scale"):
            new["wheel_yaw_rate"] = blocks.low_pass(new["wheel_yaw_rate"], abs(wheel_yaw_rate), T,
                                                    settings["wheel_check_time"])
    residual = abs(new["wheel_yaw_residual"])
    mismatch = residual > settings["wheel_check_limit"]
    if _on(settings, "wheel_check_scale") and new["wheel_yaw_rate"] >= settings["wheel_check_scale_rate"]:
        mismatch = mismatch or residual > settings["wheel_check_scale"] * new["wheel_yaw_rate"]
    if _on(settings, "wheel_check_hold"):
        new["wheel_yaw_hold_left"], mismatch = blocks.held_flag(x["wheel_yaw_hold_left"], mismatch,
                                                                settings["wheel_check_hold"], T)
    return new, mismatch


def _recovers(settings, inputs) -> bool:
    raises = (settings["frozen_time"] > 0 and any(c in inputs for c in blocks.FROZEN_CHANNELS)) or (
        _crosschecked(settings, inputs) and _on(settings, "steer_check_limit"))
    return settings["frozen_recovery"] > 0 and raises


def _crosschecks(x, u, settings, T: float, wheelbase: float) -> tuple[dict, int]:
    """(new entries, status bits) of the cross-checks that are on (model.crosscheck)."""
    new, code = {}, 0
    steady_samples = blocks.whole_samples(settings["steady_time"], T)
    if abs(u["delta"] - x["steady_delta"]) * u["vx"] ** 2 / wheelbase > settings["steady_band"]:
        new["steady_delta"], new["steady_samples"] = u["delta"], 0.0      # a new stretch starts
    else:
        new["steady_delta"] = x["steady_delta"]
        new["steady_samples"] = min(x["steady_samples"] + 1.0, steady_samples)
    steady = new["steady_samples"] >= steady_samples
    if _on(settings, "lateral_check_limit"):
        residual = x["lateral_residual"]
        if steady and abs(u["ay"]) <= settings["lateral_check_range"]:
            residual = blocks.low_pass(residual, u["ay"] - u["r"] * u["vx"], T, settings["lateral_check_time"])
        new["lateral_residual"] = residual
        code |= blocks.LATERAL_INCONSISTENT if abs(residual) > settings["lateral_check_limit"] else 0
    if _on(settings, "steering_offset_limit"):
        offset = x["steering_offset"]
        if (steady and abs(u["ay"]) <= settings["steering_offset_range"]
                and u["vx"] >= settings["steering_offset_speed"]):
            offset = blocks.low_pass(offset, u["delta"] - wheelbase * u["r"] / u["vx"], T,
                               settings["steering_offset_time"])
        new["steering_offset"] = offset
        code |= blocks.STEERING_OFFSET if abs(offset) > settings["steering_offset_limit"] else 0
    if _on(settings, "steer_check_limit"):      # the low-passed curvature, taken when steady
        curvature = blocks.low_pass(x["curvature"], u["r"] / u["vx"], T, settings["steer_check_time"])
        turned_steady = steady and x["steady_samples"] < steady_samples
        new["curvature"] = curvature
        new["steady_curvature"] = curvature if turned_steady else x["steady_curvature"]
        if steady and abs(u["ay"]) <= settings["steer_check_range"]:
            change = (curvature - new["steady_curvature"]) * u["vx"] ** 2
            code |= blocks.INPUT_FROZEN if abs(change) > settings["steer_check_limit"] else 0
    return new, code
