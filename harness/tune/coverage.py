"""What a set of training logs covers, and so which settings ``vsegen tune`` may search.

A setting acts in a regime (``model.estimator.REGIMES``): everywhere, beyond the tyres' linear
range, or near the friction limit of a low-friction road. Logs that never enter a regime say
nothing about the settings that act in it: a search would move them freely (whatever it likes
best on the other data) and the tuned file would be silently wrong where they matter. So a regime
counts as covered only with :data:`MIN_TIME` of it in the logs; the settings of an uncovered one
keep their base values unless the user frees them.

Measured per log (SI units): the speed range; the largest |a_y| and the time beyond
:data:`LINEAR_LIMIT`; the time near the friction limit on a low-friction road; the share of
quasi-steady samples. Near the limit on low friction means, where the log has the road's friction
``mu`` (a simulated or instrumented log): mu <= :data:`LOW_FRICTION_MU` and |a_y| >= :data:`NEAR_LIMIT`
mu g; without it, the evidence of saturated tyres at a low lateral acceleration: the measured yaw
rate departs from the linear bicycle model's steady-state yaw rate for the steer angle by more
than :data:`SATURATION` (either way) in quasi-steady driving (a transient's yaw lag is no saturation) while
|a_y| < LOW_FRICTION_MU g, in a log that never reaches LOW_FRICTION_MU g (a road that carries that is no
low-friction road: on a dry race lap the yaw rate leaves the linear model's in every corner entry);
signals smoothed over ``logs.segments.SMOOTHING`` first.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vsegen.harness.logs.table import Log
from vsegen.harness.physics import segments
from vsegen.model.bicycle import GRAVITY, stability_factor
from vsegen.model.estimator import BEYOND_LINEAR, EVERYWHERE, LOW_FRICTION, REGIMES
from vsegen.model.params import VehicleConfig

LINEAR_LIMIT = 4.0
"""|a_y| (m/s^2) beyond which the tyres leave their linear range on a dry road (the shipped files'
``linear_range``)."""
LOW_FRICTION_MU = 0.6
"""A road with mu at or below this is a low-friction road."""
NEAR_LIMIT = 0.7
"""|a_y| at or above this share of mu g is near the friction limit."""
SATURATION = 0.25
"""Without a mu column: a yaw rate this much (share) off the linear model's is saturation."""
MIN_YAW_RATE = 0.05
"""rad/s: below this steady-state yaw rate the saturation test says nothing."""
QUASI_STEADY_JERK = 2.0
"""|da_y/dt| (m/s^3, of a_y smoothed over ``segments.SMOOTHING``) below which a sample counts as
quasi-steady."""
MIN_TIME = 1.0
"""s of a regime the logs must hold for its settings to be searched."""


@dataclass(frozen=True)
class Coverage:
    """What training logs cover (durations in s, speeds in m/s, accelerations in m/s^2)."""

    logs: int
    duration: float
    speed_min: float
    speed_max: float
    ay_max: float
    beyond_linear: float
    low_friction_limit: float
    quasi_steady: float
    """Share (0..1) of quasi-steady samples."""
    friction_known: bool
    """Whether every log had a ``mu`` column (else low friction was inferred from the yaw rate)."""

    def time_in(self, regime: str) -> float:
        """Seconds of ``regime`` in the logs (their whole duration for EVERYWHERE)."""
        return {EVERYWHERE: self.duration, BEYOND_LINEAR: self.beyond_linear,
                LOW_FRICTION: self.low_friction_limit}[regime]

    def covers(self, regime: str) -> bool:
        return self.time_in(regime) >= MIN_TIME

    def describe(self) -> str:
        """One line for the user (and the tuned file's header)."""
        inferred = "" if self.friction_known else " (inferred from the yaw rate: the logs have no mu column)"
        return (f"{self.logs} log(s), {self.duration:.1f} s: speed {self.speed_min:.1f}..{self.speed_max:.1f} m/s; "
                f"|a_y| up to {self.ay_max:.1f} m/s^2, {self.beyond_linear:.1f} s beyond the linear range "
                f"({LINEAR_LIMIT:g} m/s^2); {self.low_friction_limit:.1f} s near the friction limit on low "
                f"friction (mu <= {LOW_FRICTION_MU:g}){inferred}; quasi-steady {100 * self.quasi_steady:.0f} %, "
                f"transient {100 * (1 - self.quasi_steady):.0f} %")


def coverage(logs: Sequence[Log], config: VehicleConfig) -> Coverage:
    """What ``logs`` cover (see the module docstring); samples after a spin and non-finite samples
    do not count."""
    parts = [_measured(log, config) for log in logs]
    duration = sum(p["duration"] for p in parts)
    speeds = np.concatenate([p["speeds"] for p in parts]) if parts else np.zeros(1)
    steady = sum(p["quasi_steady"] for p in parts)
    return Coverage(
        logs=len(parts), duration=duration,
        speed_min=float(np.min(speeds)) if speeds.size else 0.0,
        speed_max=float(np.max(speeds)) if speeds.size else 0.0,
        ay_max=max((p["ay_max"] for p in parts), default=0.0),
        beyond_linear=sum(p["beyond_linear"] for p in parts),
        low_friction_limit=sum(p["low_friction"] for p in parts),
        quasi_steady=steady / duration if duration > 0 else 0.0,
        friction_known=all("mu" in log for log in logs))


def frozen_settings(regimes: dict[str, str], cover: Coverage, freed: Sequence[str] = ()) -> dict[str, str]:
    """{setting: why it keeps its base value} for the settings (``regimes``: setting -> regime)
    whose regime ``cover`` does not cover, unless ``freed`` names them."""
    return {key: (f"acts in {REGIMES[regime]}; the logs hold {cover.time_in(regime):.1f} s of it, "
                  f"{MIN_TIME:g} s needed")
            for key, regime in regimes.items() if key not in freed and not cover.covers(regime)}


def _measured(log: Log, config: VehicleConfig) -> dict:
    t = np.asarray(log["t"], dtype=float)
    used = segments.finite(log, ("ay", "vx", "r", "delta"))
    if "beta_ref" in log:
        used &= ~np.maximum.accumulate(np.abs(np.nan_to_num(log["beta_ref"])) > np.radians(15.0))
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    window = max(1, round(segments.SMOOTHING / step)) if step > 0 else 1
    ay, vx, r, delta = (segments.smoothed(np.nan_to_num(np.asarray(log[c], dtype=float)), window)
                        for c in ("ay", "vx", "r", "delta"))
    steady = np.abs(segments.derivative(ay, step, window)) < QUASI_STEADY_JERK if len(t) > 5 else used
    if "mu" in log:
        mu = np.asarray(log["mu"], dtype=float)
        low = (mu <= LOW_FRICTION_MU) & (np.abs(ay) >= NEAR_LIMIT * mu * GRAVITY)
    elif np.max(np.abs(ay[used]), initial=0.0) >= LOW_FRICTION_MU * GRAVITY:
        low = np.zeros(len(t), dtype=bool)     # a road that carried this much is no low-friction road
    else:
        low = steady & _saturated(delta, vx, r, ay, config)
    return {"duration": step * int(np.count_nonzero(used)), "speeds": vx[used],
            "ay_max": float(np.max(np.abs(ay[used]), initial=0.0)),
            "beyond_linear": step * int(np.count_nonzero(used & (np.abs(ay) > LINEAR_LIMIT))),
            "low_friction": step * int(np.count_nonzero(used & low)),
            "quasi_steady": step * int(np.count_nonzero(used & steady))}


def _saturated(delta, vx, r, ay, config: VehicleConfig) -> np.ndarray:
    """Samples whose yaw rate departs from the linear bicycle model's steady state for the steer
    angle by more than SATURATION (under- or oversteer at the limit) at a lateral acceleration a
    low-friction road allows."""
    v = config.vehicle
    speed = np.maximum(np.abs(vx), 1.0)
    r_linear = delta * speed / (v["wheelbase"] * (1.0 + stability_factor(v) * speed**2))
    return ((np.abs(r_linear) > MIN_YAW_RATE) & (np.abs(r - r_linear) > SATURATION * np.abs(r_linear))
            & (np.abs(ay) < LOW_FRICTION_MU * GRAVITY))
