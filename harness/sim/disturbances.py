"""Real-world disturbances of a simulated drive, as options of every plant scenario.

Three kinds, all seeded (a generator of its own, drawn from the log's seed, so that switching a
disturbance on never changes the sensor noise) and reproducible:

* **road** (harness.sim.road): ``bank`` and ``grade`` in % (a constant cross slope and grade
  along the whole drive, added to a road scenario's own profile);
* **sensors**, applied to the measured channels in this order:
  - ``ax_offset``, ``ay_offset`` (m/s^2), appearing at ``offset_time`` (s; 0: from the start);
  - ``gyro_bias`` (rad/s) plus a random walk of ``gyro_drift`` (rad/s per sqrt(s));
  - ``steer_offset`` (rad at the road wheel: a steering-angle zero error);
  - ``mount_roll``, ``mount_pitch``, ``mount_yaw`` (rad): the IMU rotated on the body
    (harness.sim.sensor_model applies it to the specific force and rates);
  - ``latency``: per channel, e.g. ``ay:0.02,r:0.04`` (s; CAN delay, linear interpolation);
  - ``quantise``: per channel LSB, e.g. ``delta:0.001,ay:0.01``;
  - ``scale``: per channel factor, e.g. ``r:1.3`` (a DBC factor typed 0.013 for 0.01: the
    decoded signal is that much too large);
  - ``spikes``: per channel ``count x size``, e.g. ``r:3x0.5`` (single samples at seeded times,
    of seeded sign);
  - ``freeze``: ``channel:start:duration`` (s), e.g. ``r:4:1.5``: the value at ``start`` repeats
    (a stuck CAN signal);
  - ``dropout``: ``channel:start:duration``: NaN (no message); channel ``all`` means every input;
  several entries are separated by commas;
* **truth car** (the estimator's vehicle file is untouched): ``mass_added`` (kg, a point load at
  the CG's height ``cg_shift`` m behind the CG; the CG moves and the yaw inertia grows by the
  parallel-axis terms), ``tyre_scale`` (factor on every tyre's cornering stiffness, the Magic
  Formula's p_Ky1).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from vsegen.harness.sim.road import FLAT, Road, slope_angle

INPUT_CHANNELS = ("delta", "vx", "ax", "ay", "r", "omega_fl", "omega_fr", "omega_rl", "omega_rr")
"""The measured channels a disturbance may name (docs/signals.md)."""

OPTIONS: dict[str, Any] = {
    "bank": 0.0, "grade": 0.0,
    "ax_offset": 0.0, "ay_offset": 0.0, "offset_time": 0.0,
    "gyro_bias": 0.0, "gyro_drift": 0.0, "steer_offset": 0.0,
    "mount_roll": 0.0, "mount_pitch": 0.0, "mount_yaw": 0.0,
    "latency": "", "quantise": "", "scale": "", "spikes": "", "freeze": "", "dropout": "",
    "mass_added": 0.0, "cg_shift": 0.0, "tyre_scale": 1.0,
}
"""The disturbance options and their neutral values (every plant scenario takes them)."""

UNITS: dict[str, str] = {
    "bank": "% cross slope, 3 % = 1.7 deg", "grade": "%", "ax_offset": "m/s^2", "ay_offset": "m/s^2",
    "offset_time": "s", "gyro_bias": "rad/s", "gyro_drift": "rad/s per sqrt(s)", "steer_offset": "rad",
    "mount_roll": "rad", "mount_pitch": "rad", "mount_yaw": "rad", "latency": "channel:s,...",
    "quantise": "channel:LSB,...", "scale": "channel:factor,...", "spikes": "channel:count x size,...",
    "freeze": "channel:start s:duration s", "dropout": "channel:start s:duration s", "mass_added": "kg",
    "cg_shift": "m behind the CG", "tyre_scale": "factor on the cornering stiffness",
}
"""The unit or form of each option, as ``vsegen list`` shows it."""

SEED_OFFSET = 7919
"""The disturbances draw from seed + this, apart from the sensor noise's generator."""


@dataclass(frozen=True)
class Disturbances:
    """The disturbance options of one run (see the module docstring), validated."""

    options: tuple[tuple[str, Any], ...] = ()

    @staticmethod
    def of(**options: Any) -> Disturbances:
        chosen = {k: v for k, v in options.items() if k in OPTIONS and v != OPTIONS[k]}
        disturbances = Disturbances(tuple(sorted(chosen.items())))
        for key in ("latency", "quantise", "scale", "spikes", "freeze", "dropout"):
            disturbances.entries(key)          # raises ValueError on a malformed entry
        if disturbances.get("tyre_scale") <= 0.0:
            raise ValueError(f"tyre_scale = {disturbances.get('tyre_scale')}: expected a factor > 0")
        return disturbances

    def get(self, key: str) -> Any:
        return dict(self.options).get(key, OPTIONS[key])

    def road(self, under: Road = FLAT) -> Road:
        """The road ``under`` the scenario with the ``bank`` and ``grade`` (%) added."""
        return under.tilted(slope_angle(self.get("bank")), slope_angle(self.get("grade")))

    @property
    def mounting(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) of the IMU on the body (rad)."""
        return self.get("mount_roll"), self.get("mount_pitch"), self.get("mount_yaw")

    def entries(self, key: str) -> list[tuple[str, tuple[float, ...]]]:
        """The per-channel entries of option ``key``: (channel, numbers)."""
        shapes = {"latency": 1, "quantise": 1, "scale": 1, "spikes": 2, "freeze": 2, "dropout": 2}
        found = []
        for entry in filter(None, str(self.get(key)).split(",")):
            channel, _, rest = entry.partition(":")
            parts = rest.replace("x", ":", 1).split(":") if key == "spikes" else rest.split(":")
            try:
                numbers = tuple(float(p) for p in parts)
            except ValueError:
                numbers = ()
            allowed = (*INPUT_CHANNELS, "all") if key == "dropout" else INPUT_CHANNELS
            if channel not in allowed or len(numbers) != shapes[key] or min(numbers) < 0.0:
                form = {"latency": "channel:seconds", "quantise": "channel:lsb", "scale": "channel:factor",
                        "spikes": "channel:countxsize", "freeze": "channel:start:duration",
                        "dropout": "channel:start:duration"}[key]
                raise ValueError(f"{key} entry {entry!r}: expected {form} with a channel of "
                                 f"{', '.join(allowed)} and numbers >= 0")
            found.append((channel, numbers))
        return found

    def truth_car(self, config):
        """``config`` with the truth-side changes (mass, CG, tyres) in its [vehicle] and [plant]
        tables; the same object when there are none. The estimator keeps its own file."""
        added, shift, scale = self.get("mass_added"), self.get("cg_shift"), self.get("tyre_scale")
        if added == 0.0 and shift == 0.0 and scale == 1.0:
            return config
        vehicle = dict(config.vehicle)
        m, a = vehicle["mass"], vehicle["cg_to_front_axle"]
        load_at = a + shift                          # from the front axle, m
        mass = m + added
        a_new = (m * a + added * load_at) / mass
        inertia = vehicle["yaw_inertia"] + m * (a - a_new) ** 2 + added * (load_at - a_new) ** 2
        vehicle.update(mass=mass, cg_to_front_axle=a_new, cg_to_rear_axle=vehicle["wheelbase"] - a_new,
                       yaw_inertia=inertia)
        plant = dict(config.plant or {})
        plant["tyre_cornering_factor"] = plant["tyre_cornering_factor"] * scale
        return replace(config, vehicle=MappingProxyType(vehicle), plant=MappingProxyType(plant))

    def apply(self, columns: dict[str, np.ndarray], t: np.ndarray, seed: int) -> dict[str, np.ndarray]:
        """The measured ``columns`` (sampled at times ``t``) with the sensor disturbances."""
        rng = np.random.default_rng(seed + SEED_OFFSET)
        out = {k: np.asarray(v, float).copy() for k, v in columns.items()}
        dt = float(t[1] - t[0])
        appears = t >= self.get("offset_time")
        out["ax"] += self.get("ax_offset") * appears
        out["ay"] += self.get("ay_offset") * appears
        walk = np.cumsum(rng.normal(0.0, self.get("gyro_drift") * np.sqrt(dt), len(t)))
        out["r"] += self.get("gyro_bias") + walk
        out["delta"] += self.get("steer_offset")
        for channel, (delay,) in self.entries("latency"):
            out[channel] = np.interp(t - delay, t, out[channel])
        for channel, (lsb,) in self.entries("quantise"):
            if lsb > 0.0:
                out[channel] = np.round(out[channel] / lsb) * lsb
        for channel, (factor,) in self.entries("scale"):
            out[channel] = out[channel] * factor
        for channel, (count, size) in self.entries("spikes"):
            at = rng.choice(len(t), size=int(count), replace=False)
            out[channel][at] += size * rng.choice((-1.0, 1.0), size=len(at))
        for channel, (start, duration) in self.entries("freeze"):
            held = (t >= start) & (t < start + duration)
            if held.any():
                out[channel][held] = out[channel][np.argmax(held)]
        for channel, (start, duration) in self.entries("dropout"):
            gone = (t >= start) & (t < start + duration)
            for name in (INPUT_CHANNELS if channel == "all" else (channel,)):
                out[name][gone] = np.nan
        return out


NONE = Disturbances()
"""No disturbance: the scenario as it is."""
