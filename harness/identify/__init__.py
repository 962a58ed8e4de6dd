"""``vsegen identify``: a car's parameters and the estimators' car-specific settings from
ordinary driving logs (no ground truth needed; ``beta_ref``/``vy_ref`` are used where every log has one).

Order: sensor offsets and noise from straight driving, then the roll gradient and the stability
factor from quasi-steady cornering (with the gyro offset removed), then C_f, C_r and the tyres'
friction from every sample at speed (filter error, :mod:`.bicycle_fit`; offsets, noise weights and
the roll gradient applied). An offset is removed
only where it is significant (its 95 % interval excludes 0): removing a noise-sized offset would
only add its uncertainty to everything downstream. Each parameter is
identified only where the logs excite it; otherwise it is refused with the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from vsegen.harness.identify.bicycle_fit import cornering_stiffness
from vsegen.harness.identify.estimates import (
    Estimate,
    Refusal,
    roll_gradient,
    sensor_offsets_and_noise,
    stability_factor,
)
from vsegen.harness.logs.table import Log
from vsegen.model.params import VehicleConfig

FALLBACK_NOISE = {"gyro_noise": 0.017453, "ay_noise": 0.3, "ax_noise": 0.3}
"""Weights of the stiffness fit when the noise is not identified (seed 000 Table 2's sensors)."""


@dataclass(frozen=True)
class Identification:
    """What the logs supported (:class:`Estimate`) and what not (:class:`Refusal`), in order."""

    results: tuple[Estimate | Refusal, ...]
    uses_reference: bool
    """Every log had a reference lateral velocity or sideslip, and the stiffness fit used it."""

    @property
    def estimates(self) -> dict[str, Estimate]:
        return {r.name: r for r in self.results if isinstance(r, Estimate)}

    @property
    def refusals(self) -> list[Refusal]:
        return [r for r in self.results if isinstance(r, Refusal)]

    def value(self, name: str) -> float | None:
        estimate = self.estimates.get(name)
        return None if estimate is None else estimate.value


def base_roll_gradient(config: VehicleConfig) -> float:
    """The roll gradient the base file's estimators use (0 if none has one)."""
    values = [s["roll_gradient"] for s in config.estimators.values() if "roll_gradient" in s]
    return float(values[0]) if values else 0.0


def identify(logs: Sequence[Log], config: VehicleConfig) -> Identification:
    """Identify from ``logs`` what they support; ``config`` gives mass, geometry and I_z."""
    results: list[Estimate | Refusal] = list(sensor_offsets_and_noise(logs))
    offsets = {r.name: r.value if r.significant else 0.0 for r in results
               if isinstance(r, Estimate) and r.name.endswith("_offset")}
    gyro_offset = offsets.get("gyro_offset", 0.0)
    results.append(roll_gradient(logs, gyro_offset, offsets.get("ay_offset", 0.0)))
    results.append(stability_factor(logs, config.vehicle["wheelbase"], gyro_offset))
    known = {r.name: r.value for r in results if isinstance(r, Estimate)}
    quantities = {**FALLBACK_NOISE, "roll_gradient": base_roll_gradient(config), **known, **offsets}
    results.extend(cornering_stiffness(logs, config.vehicle, quantities))
    referenced = all("beta_ref" in log or "vy_ref" in log for log in logs)
    return Identification(tuple(results), referenced)
