"""The cross-checks of the inputs against each other in quasi-steady driving
(model.input_checks.crosscheck): a_y against r v_x (LATERAL_INCONSISTENT), the steering-angle zero
against the kinematic turn (STEERING_OFFSET), the path curvature at a held steer angle
(INPUT_FROZEN)."""

from __future__ import annotations

from vsegen.harness.reference import blocks

ORDER = 2
INPUTS = ("delta", "vx", "ay", "r")
"""What the checks read; an estimator without all of them has none."""
CHECKS = {"lateral_check_limit": (blocks.LATERAL_INCONSISTENT, ("lateral_residual", "lateral_residual_samples")),
          "steering_offset_limit": (blocks.STEERING_OFFSET, ("steering_offset", "steering_offset_samples")),
          "steer_check_limit": (blocks.INPUT_FROZEN, ("curvature", "steady_curvature"))}
"""Each check: the setting that switches it on (> 0), the bit it raises, its state entries."""


def _on(settings, limit_key) -> bool:
    return settings[limit_key] > 0


def reads(settings) -> tuple[str, ...]:
    return ()


def enabled(settings, inputs) -> bool:
    return all(n in inputs for n in INPUTS) and any(_on(settings, key) for key in CHECKS)


def raises(settings, inputs) -> int:
    bits = 0
    for key, (bit, _) in CHECKS.items():
        bits |= bit if enabled(settings, inputs) and _on(settings, key) else 0
    return bits


def states(settings, inputs) -> tuple[str, ...]:
    """The quasi-steady detector's, then each check's that is on."""
    if not enabled(settings, inputs):
        return ()
    return ("steady_delta", "steady_samples", "steady_r",
            *(name for key, (_, names) in CHECKS.items() if _on(settings, key) for name in names))


def initial(settings, inputs, first) -> dict:
    """A quasi-steady stretch starting at the first sample's steer angle and yaw rate, nothing learned
    (no sample taken)."""
    firsts = {"steady_delta": first["delta"], "steady_r": first["r"]}
    return {name: firsts.get(name, 0.0) for name in states(settings, inputs)}


def step(x, u, ok, settings, T: float, inputs, vehicle, raw) -> tuple[dict, int]:
    """(new entries, status bits) of the checks that are on."""
    wheelbase = vehicle["wheelbase"]
    new, code = {}, 0
    steady_samples = blocks.whole_samples(settings["steady_time"], T)
    if abs(u["delta"] - x["steady_delta"]) * u["vx"] ** 2 / wheelbase > settings["steady_band"]:
        new["steady_delta"], new["steady_samples"] = u["delta"], 0.0      # a new stretch starts
    else:
        new["steady_delta"] = x["steady_delta"]
        new["steady_samples"] = min(x["steady_samples"] + 1.0, steady_samples)
    steady = new["steady_samples"] >= steady_samples
    settled = steady and abs(u["r"] - x["steady_r"]) * u["vx"] <= settings["settle_band"]   # r too, since the last run
    new["steady_r"] = u["r"]
    if _on(settings, "lateral_check_limit"):
        sampled = settled and abs(u["ay"]) <= settings["lateral_check_range"]
        learned, raised = blocks.learned_check(x, settings, T, "lateral_residual", u["ay"] - u["r"] * u["vx"],
                                               sampled, "lateral_check_time", "lateral_check_limit")
        new |= learned
        code |= blocks.LATERAL_INCONSISTENT if raised else 0
    if _on(settings, "steering_offset_limit"):
        sampled = (settled and abs(u["ay"]) <= settings["steering_offset_range"]
                   and u["vx"] >= settings["steering_offset_speed"])
        learned, raised = blocks.learned_check(x, settings, T, "steering_offset",
                                               u["delta"] - wheelbase * u["r"] / u["vx"], sampled,
                                               "steering_offset_time", "steering_offset_limit")
        new |= learned
        code |= blocks.STEERING_OFFSET if raised else 0
    if _on(settings, "steer_check_limit"):      # the low-passed curvature, taken when steady
        curvature = blocks.low_pass(x["curvature"], u["r"] / u["vx"], T, settings["steer_check_time"])
        turned_steady = steady and x["steady_samples"] < steady_samples
        new["curvature"] = curvature
        new["steady_curvature"] = curvature if turned_steady else x["steady_curvature"]
        if steady and abs(u["ay"]) <= settings["steer_check_range"]:
            change = (curvature - new["steady_curvature"]) * u["vx"] ** 2
            code |= blocks.INPUT_FROZEN if abs(change) > settings["steer_check_limit"] else 0
    return new, code
