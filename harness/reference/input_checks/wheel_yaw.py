"""The yaw rate against the non-driven axle's wheel yaw rate r_w (model.input_checks.wheel_yaw):
the mean of r - r_w beyond the limit, or beyond a share of the mean |r_w| where that is large
enough, or a share of it learned there (judged once it has sampled learned_after) beyond that
share where the mean |r_w| is at least a lower rate, held a while after, raises
YAW_RATE_MISMATCH; all of the checks' period's means (r, the axle's right minus left wheel speed,
a_x); a period braking or accelerating hard is skipped."""

from __future__ import annotations

import math

from vsegen.harness.reference import blocks

ORDER = 3


def _axle(settings) -> str:
    return "r" if settings["wheel_check_axle"] == "rear" else "f"


def _wheels(settings) -> tuple[str, str]:
    return f"omega_{_axle(settings)}l", f"omega_{_axle(settings)}r"


def reads(settings) -> tuple[str, ...]:
    """With the check on: the steer angle, a_x, r and the checked axle's wheel speeds."""
    return ("delta", "ax", "r", *_wheels(settings)) if settings["wheel_check_limit"] > 0 else ()


def enabled(settings, inputs) -> bool:
    checked = reads(settings)
    return bool(checked) and all(n in inputs for n in checked)


def raises(settings, inputs) -> int:
    return blocks.YAW_RATE_MISMATCH if enabled(settings, inputs) else 0


def states(settings, inputs) -> tuple[str, ...]:
    if not enabled(settings, inputs):
        return ()
    return ("wheel_yaw_residual", *(("wheel_yaw_rate",) if settings["wheel_check_scale"] > 0 else ()),
            *(("wheel_yaw_share", "wheel_yaw_share_samples") if _learns_share(settings) else ()),
            *(("wheel_yaw_hold_left",) if settings["wheel_check_hold"] > 0 else ()))


def _learns_share(settings) -> bool:
    """Whether the check learns the share (model.input_checks.wheel_yaw._learns_share)."""
    return settings["wheel_check_scale"] > 0 and settings["wheel_check_scale_time"] > 0


def initial(settings, inputs, first) -> dict:
    return dict.fromkeys(states(settings, inputs), 0.0)


def step(x, u, ok, settings, T: float, inputs, vehicle, raw) -> tuple[dict, int]:
    """(new entries, YAW_RATE_MISMATCH or 0) from the period's means ``u``."""
    scale = settings["wheel_check_scale"] > 0
    new = {name: x[name] for name in states(settings, inputs) if name != "wheel_yaw_hold_left"}
    rolling = abs(u["ax"]) <= settings["wheel_check_ax"]     # no brake or drive slip
    if rolling:
        steer = math.cos(u["delta"]) if settings["wheel_check_axle"] == "front" else 1.0
        difference = u[f"omega_{_axle(settings)}_diff"]     # the period's mean right minus left
        wheel_yaw_rate = vehicle["wheel_radius"] * difference / (vehicle["track_width"] * steer)
        new["wheel_yaw_residual"] = blocks.low_pass(new["wheel_yaw_residual"], u["r"] - wheel_yaw_rate, T,
                                                    settings["wheel_check_time"])
        if scale:
            new["wheel_yaw_rate"] = blocks.low_pass(new["wheel_yaw_rate"], abs(wheel_yaw_rate), T,
                                                    settings["wheel_check_time"])
    residual = abs(new["wheel_yaw_residual"])
    mismatch = residual > settings["wheel_check_limit"]
    yawing = scale and new["wheel_yaw_rate"] >= settings["wheel_check_scale_rate"]
    if yawing:
        mismatch = mismatch or residual > settings["wheel_check_scale"] * new["wheel_yaw_rate"]
    if _learns_share(settings):     # the share, learned where it is judged, kept for the milder corners
        share = residual / max(new["wheel_yaw_rate"], settings["wheel_check_scale_rate"])
        learned, beyond = blocks.learned_check(new, settings, T, "wheel_yaw_share", share, rolling and yawing,
                                               "wheel_check_scale_time", "wheel_check_scale")
        new |= learned
        mismatch = mismatch or (beyond and new["wheel_yaw_rate"] >= settings["wheel_check_learned_rate"])
    if settings["wheel_check_hold"] > 0:
        new["wheel_yaw_hold_left"], mismatch = blocks.held_flag(x["wheel_yaw_hold_left"], mismatch,
                                                                settings["wheel_check_hold"], T)
    return new, blocks.YAW_RATE_MISMATCH if mismatch else 0
