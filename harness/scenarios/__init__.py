"""Scenarios: named manoeuvres that produce logs (harness.logs.Log) with ground truth.

``SCENARIOS[name].simulate(config, rate_hz, seed, **options)``. ``VERIFICATION_SET`` is the list of
(scenario, options) every estimator is checked on by ``vsegen verify``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from harness.logs import Log
from harness.scenarios import manoeuvres
from model.params import VehicleConfig


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    simulate: Callable[..., Log]
    defaults: dict[str, Any]


SCENARIOS: dict[str, Scenario] = {
    "dlc": Scenario("dlc", "ISO 3888-1 double lane change, path-following driver, constant speed",
                    manoeuvres.dlc, {"speed_kmh": 80.0, "mu": 1.0, "outliers": False}),
    "low_speed": Scenario("low_speed", "slow down to a stop, reverse briefly, drive off again "
                          "(exercises the low-speed hold)", manoeuvres.low_speed, {}),
    "invalid_inputs": Scenario("invalid_inputs", "80 km/h DLC with NaN, Inf and out-of-range "
                               "samples in every input", manoeuvres.invalid_inputs, {}),
}


@dataclass(frozen=True)
class Case:
    """One scenario with its options, as verified and scored."""

    scenario: str
    options: dict[str, Any]

    @property
    def label(self) -> str:
        text = ",".join(f"{k}={v}" for k, v in self.options.items())
        return f"{self.scenario}({text})" if text else self.scenario

    def simulate(self, config: VehicleConfig, rate_hz: float, seed: int = 1) -> Log:
        scenario = SCENARIOS[self.scenario]
        return scenario.simulate(config, rate_hz, seed, **{**scenario.defaults, **self.options})


VERIFICATION_SET: tuple[Case, ...] = (
    Case("dlc", {"speed_kmh": 80.0}),
    Case("dlc", {"speed_kmh": 120.0}),
    Case("dlc", {"speed_kmh": 120.0, "mu": 0.5}),
    Case("dlc", {"speed_kmh": 120.0, "outliers": True}),
    Case("low_speed", {}),
    Case("invalid_inputs", {}),
)
