"""Closed-loop simulation of the truth plant with a steering law, a speed law and a friction
profile, recorded at the log rate."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from vsegen.harness.sim.road import FLAT, Road
from vsegen.harness.sim.two_track import INPUT, STATE, TRUTH, Plant, build_plant
from vsegen.model.params import ParameterError, VehicleConfig

DISTANCE = STATE.index("distance")
PLANT_RATE = 1000.0
"""Minimum plant integration rate (Hz); the plant runs at an integer multiple of the log rate."""


@dataclass
class Run:
    """Truth at the log rate: time, plant states, inputs and algebraic truth, one row per sample.
    Runs are cached and shared, so the accessors return copies."""

    t: np.ndarray
    states: np.ndarray
    inputs: np.ndarray
    truth: np.ndarray

    def state(self, name: str) -> np.ndarray:
        return self.states[:, STATE.index(name)].copy()

    def input(self, name: str) -> np.ndarray:
        return self.inputs[:, INPUT.index(name)].copy()

    def truth_of(self, name: str) -> np.ndarray:
        return self.truth[:, TRUTH.index(name)].copy()

    @property
    def beta(self) -> np.ndarray:
        return np.arctan2(self.state("vy"), self.state("vx"))


def substeps(rate_hz: float) -> int:
    """Plant steps per log sample."""
    return max(1, int(np.ceil(PLANT_RATE / rate_hz - 1e-9)))


def plant_for(config: VehicleConfig, rate_hz: float) -> Plant:
    """The (cached) plant of ``config`` integrating at a multiple of ``rate_hz``."""
    if config.plant is None:
        raise ParameterError(f"{config.source}: no [plant] table: expected the truth-plant "
                             f"parameters to simulate (see vehicles/c_class.toml)")
    return _plant(tuple(sorted(config.vehicle.items())), tuple(sorted(config.plant.items())),
                  1.0 / (rate_hz * substeps(rate_hz)))


@lru_cache(maxsize=8)
def _plant(vehicle: tuple, params: tuple, dt: float) -> Plant:
    return build_plant(dict(vehicle), dict(params), dt)


@dataclass(frozen=True)
class FrictionProfile:
    """Road friction by segments: ``values[i]`` until ``switches[i]`` (s of time, or m of
    travelled distance X when ``by`` is "distance"), the last value after the last switch."""

    values: tuple[float, ...]
    switches: tuple[float, ...] = ()
    by: str = "time"

    def __post_init__(self) -> None:
        if len(self.values) != len(self.switches) + 1:
            raise ValueError("a friction profile needs one value more than switches")
        if self.by not in ("time", "distance"):
            raise ValueError("friction switches are by 'time' or 'distance'")

    def __call__(self, t: float, state: np.ndarray) -> float:
        where = t if self.by == "time" else state[STATE.index("X")]
        return self.values[int(np.searchsorted(self.switches, where, side="right"))]


def simulate(config: VehicleConfig, rate_hz: float, duration: float, speed: float,
             steer: Callable[[float, np.ndarray], float],
             torques: Callable[[float, np.ndarray], np.ndarray],
             mu: Callable[[float, np.ndarray], float], y0: float = 0.0,
             progress: Callable[[float], None] | None = None, road: Road = FLAT) -> Run:
    """Integrate from straight running at ``speed`` (m/s) for ``duration`` s. ``steer``,
    ``torques`` and ``mu`` are called every plant step with (t, state), ``road`` with the
    distance travelled; ``progress`` (if given) with the fraction done, every simulated second."""
    plant = plant_for(config, rate_hz)
    sub = substeps(rate_hz)
    samples = int(round(duration * rate_hz)) + 1
    state = plant.initial_state(speed, y0)
    states = np.zeros((samples, len(STATE)))
    inputs = np.zeros((samples, len(INPUT)))
    truth = np.zeros((samples, len(TRUTH)))
    for k in range(samples * sub):
        t = k * plant.dt
        u = np.concatenate(([steer(t, state)], torques(t, state), [mu(t, state)],
                            road(state[DISTANCE])))
        if k % sub == 0:
            states[k // sub], inputs[k // sub], truth[k // sub] = state, u, plant.truth(state, u)
            if progress and (k // sub) % int(rate_hz) == 0:
                progress(k / (samples * sub))
        state = plant.step(state, u)
        if not np.all(np.isfinite(state)):
            raise RuntimeError(f"truth plant diverged at t = {t:.3f} s")
    return Run(np.arange(samples) / rate_hz, states, inputs, truth)
