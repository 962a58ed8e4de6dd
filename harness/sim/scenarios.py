"""Scenarios: named manoeuvres that produce logs (harness.logs.table.Log) with ground truth.

``SCENARIOS[name]`` has a ``simulate(config, rate_hz, seed, **options)`` and the defaults of its
options; the names are stable (scripts rely on them). ``VERIFICATION_SET`` is the list of
(scenario, options) every estimator is checked on by ``vsegen verify``; ``SCORED_SET`` those of
them with a vehicle's truth.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from vsegen.harness.jobs.memo import Memo
from vsegen.harness.logs.table import Log
from vsegen.harness.sim import manoeuvres
from vsegen.harness.sim.disturbances import OPTIONS as DISTURBANCE_OPTIONS
from vsegen.harness.sim.log_cache import cached_log, log_key
from vsegen.model.params import ParameterError, VehicleConfig


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    simulate: Callable[..., Log]
    defaults: dict[str, Any] = field(default_factory=dict)
    scored: bool = True
    """False for a synthetic run whose truth columns are nominal (verified, never scored)."""


_NOISE = {"bias": False, **DISTURBANCE_OPTIONS}
SCENARIOS: dict[str, Scenario] = {s.name: s for s in (
    Scenario("dlc", "ISO 3888-1 double lane change, path-following driver, speed held",
             manoeuvres.dlc, {"speed_kmh": 80.0, "mu": 1.0, "outliers": False, **_NOISE,
                              "yaw_moment": 0.0}),
    Scenario("continuous_dlc", "seed 000: three DLCs back to back, friction 0.85 -> 0.5 -> 0.35",
             manoeuvres.continuous_dlc,
             {"speed_kmh": 120.0, "mu_sequence": "0.85,0.5,0.35", "switch_times": "9,18",
              "switch_by": "time", "duration": 30.0, "outliers": False, **_NOISE,
              "yaw_moment": 0.0}),
    Scenario("step_steer", "seed 001: front wheels stepped to 0.05 rad, speed held",
             manoeuvres.step_steer, {"speed_kmh": 80.0, "mu": 1.0, "delta": 0.05, "t_step": 1.0,
                                     "duration": 6.0, **_NOISE}),
    Scenario("sine_steer", "seed 003: sinusoidal steering, speed held", manoeuvres.sine_steer,
             {"speed_kmh": 80.0, "mu": 1.0, "amplitude": 0.02, "frequency": 0.5, "duration": 10.0,
              **_NOISE, "yaw_moment": 0.0}),
    Scenario("fishhook", "seed 002: NHTSA-style fishhook", manoeuvres.fishhook,
             {"speed_kmh": 96.0, "mu": 0.8, "amplitude": 0.06, "duration": 7.0, **_NOISE}),
    Scenario("hil_sine", "seed 000 HIL-like: pedal held (vx rising from 12.5 m/s), sine steering "
             "of growing amplitude", manoeuvres.hil_sine,
             {"mu": 0.85, "v_start": 12.5, "v_end": 30.0, "speed_tau": 15.0, "frequency": 0.25,
              "ay_start": 0.1, "ay_end": 0.7, "duration": 40.0, "outliers": False, **_NOISE}),
    Scenario("banked_curve", "highway bend R 400 m at 100 km/h, 6 % superelevation run off along "
             "the clothoid", manoeuvres.banked_curve,
             {"speed_kmh": 100.0, "mu": 1.0, "radius": 400.0, "superelevation": 6.0, "duration": 14.0,
              "outliers": False, **_NOISE}),
    Scenario("crossfall_lane_change", "lane change and back at 100 km/h on a 2.5 % crossfall",
             manoeuvres.crossfall_lane_change,
             {"speed_kmh": 100.0, "mu": 1.0, "crossfall": 2.5, "duration": 10.0, "outliers": False,
              **_NOISE}),
    Scenario("downhill_brake_curve", "braking 90 -> 50 km/h at 3 m/s^2 into a bend of R 120 m on a "
             "6 % downhill", manoeuvres.downhill_brake_curve,
             {"speed_kmh": 90.0, "end_speed_kmh": 50.0, "deceleration": 3.0, "mu": 1.0,
              "radius": 120.0, "downhill": 6.0, "duration": 10.0, "outliers": False, **_NOISE}),
    Scenario("crest_dip", "straight over a crest and through a dip (grade 0 -> 8 -> -8 -> 0 %) at "
             "90 km/h, gentle sine steering", manoeuvres.crest_dip,
             {"speed_kmh": 90.0, "mu": 1.0, "peak_grade": 8.0, "amplitude": 0.01, "frequency": 0.2,
              "duration": 22.0, "outliers": False, **_NOISE}),
    Scenario("low_speed", "slow down to a stop, reverse briefly, drive off again (low-speed hold)",
             manoeuvres.low_speed),
    Scenario("invalid_inputs", "80 km/h DLC with NaN, Inf and out-of-range samples in every input",
             manoeuvres.invalid_inputs),
    Scenario("input_extremes", "synthetic, noise-free: inputs at the edges of every decision (no "
             "excitation, wheel lift, a rejected yaw rate, a diverged speed, each input beyond its limit)",
             manoeuvres.input_extremes, scored=False),
)}


class ScenarioError(ValueError):
    """An unknown scenario or option; the message is one line."""


def parse_option(scenario: str, text: str) -> tuple[str, Any]:
    """``key=value`` for ``scenario``, typed like the option's default."""
    defaults = SCENARIOS[scenario].defaults
    key, sep, value = text.partition("=")
    if not sep or key not in defaults:
        known = ", ".join(f"{k}={v}" for k, v in defaults.items()) or "none"
        raise ScenarioError(f"scenario '{scenario}': unknown option '{text}': expected key=value "
                            f"with a key of: {known}")
    default = defaults[key]
    try:
        if isinstance(default, bool):
            if value.lower() not in ("true", "false", "1", "0", "yes", "no"):
                raise ValueError
            return key, value.lower() in ("true", "1", "yes")
        return key, type(default)(value)
    except ValueError:
        raise ScenarioError(f"scenario '{scenario}': option {key} = {value!r}: expected a "
                            f"{type(default).__name__} like {default!r}") from None


@dataclass(frozen=True)
class Case:
    """One scenario with its options, as verified and scored."""

    scenario: str
    options: tuple[tuple[str, Any], ...] = ()

    @staticmethod
    def of(scenario: str, **options: Any) -> Case:
        return Case(scenario, tuple(sorted(options.items())))

    @property
    def label(self) -> str:
        text = ",".join(f"{k}={v}" for k, v in self.options)
        return f"{self.scenario}({text})" if text else self.scenario

    def simulate(self, config: VehicleConfig, rate_hz: float, seed: int = 1,
                 progress: Callable[[float], None] | None = None) -> Log:
        """The log of this case, simulated once per truth car, rate and seed: memoised in
        memory and kept on disk (``harness.sim.log_cache``); each call gets its own copy."""
        scenario = SCENARIOS[self.scenario]
        options = {**scenario.defaults, **dict(self.options)}
        key = log_key(config, self.scenario, options, rate_hz, seed)
        log = LOGS.get(key, lambda: cached_log(key, lambda: self._simulate(config, rate_hz, seed, progress)))
        return Log({k: v.copy() for k, v in log.columns.items()}, log.source, dict(log.notes))

    def _simulate(self, config, rate_hz, seed, progress) -> Log:
        scenario = SCENARIOS[self.scenario]
        try:
            return scenario.simulate(config, rate_hz, seed, progress=progress,
                                     **{**scenario.defaults, **dict(self.options)})
        except ValueError as exc:
            if isinstance(exc, (ScenarioError, ParameterError)):
                raise
            raise ScenarioError(f"scenario {self.label}: {exc}") from None


LOGS = Memo(size=64)
"""Simulated logs of this process by cache key."""


VERIFICATION_SET: tuple[Case, ...] = (
    Case.of("dlc", speed_kmh=80.0),
    Case.of("dlc", speed_kmh=120.0),
    Case.of("dlc", speed_kmh=120.0, outliers=True),
    Case.of("continuous_dlc"),
    Case.of("step_steer"),
    Case.of("sine_steer"),
    Case.of("fishhook"),
    Case.of("dlc", speed_kmh=120.0, mu=0.5),
    Case.of("hil_sine", mu=0.85),
    Case.of("dlc", speed_kmh=80.0, yaw_moment=1000.0),
    Case.of("sine_steer", yaw_moment=1000.0),
    Case.of("dlc", speed_kmh=80.0, freeze="r:3:1,ay:5:1,ax:7:1"),
    Case.of("low_speed"),
    Case.of("invalid_inputs"),
    Case.of("input_extremes"),
)
SCORED_SET: tuple[Case, ...] = tuple(c for c in VERIFICATION_SET if SCENARIOS[c.scenario].scored)
"""The verification cases with a vehicle's truth (the accuracy and silence checks run these)."""
