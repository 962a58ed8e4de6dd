"""Courses: the driver's target path y(x) and the cone gates a run must stay inside.

ISO 3888-1 double lane change (docs/methods.md, "Sensors of simulated logs"): sections 15 / 30 / 25 /
25 / 15 / 15 m (entry lane, change, offset lane, change back, exit lane, run-out), lateral offset
3.5 m, lane widths 1.1 w + 0.25, 1.2 w + 0.25 and 1.3 w + 0.25 m (w: vehicle width). The target
path is the centre line, with half-cosine transitions over the change sections.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

ISO_SECTIONS = (15.0, 30.0, 25.0, 25.0, 15.0, 15.0)
ISO_OFFSET = 3.5
BODY_OVERHANG = 0.2
"""Vehicle width w = track width + this (m): tyre width and body beyond the track."""


@dataclass(frozen=True)
class Gate:
    """A lane between cones: from x_start to x_end (m), centred at y_centre, ``width`` wide (m)."""

    x_start: float
    x_end: float
    y_centre: float
    width: float


@dataclass(frozen=True)
class Course:
    """A piecewise path of half-cosine lane changes and the gates along it (x, y in m)."""

    knots: tuple[tuple[float, float, float], ...]
    """(x_start, x_end, lateral shift) of each transition."""
    gates: tuple[Gate, ...]
    length: float

    def centre_line(self, x) -> np.ndarray:
        """Target lateral position y (m, positive left) at distance x (m)."""
        x = np.asarray(x, dtype=float)
        y = np.zeros_like(x)
        for start, end, shift in self.knots:
            progress = np.clip((x - start) / (end - start), 0.0, 1.0)
            y = y + shift * 0.5 * (1 - np.cos(np.pi * progress))
        return y

    def outside(self, x: np.ndarray, y: np.ndarray, vehicle_width: float) -> np.ndarray:
        """True where a vehicle of ``vehicle_width`` centred at (x, y) touches a gate's cones."""
        hit = np.zeros(len(x), dtype=bool)
        for gate in self.gates:
            inside = (x >= gate.x_start) & (x <= gate.x_end)
            hit |= inside & (np.abs(y - gate.y_centre) + vehicle_width / 2 > gate.width / 2)
        return hit


def iso_dlc(start: float, vehicle_width: float) -> Course:
    """ISO 3888-1 course whose entry is at x = ``start``."""
    s = start + np.cumsum((0.0, *ISO_SECTIONS))
    w = vehicle_width
    return Course(
        knots=((s[1], s[2], ISO_OFFSET), (s[3], s[4], -ISO_OFFSET)),
        gates=(Gate(s[0], s[1], 0.0, 1.1 * w + 0.25),
               Gate(s[2], s[3], ISO_OFFSET, 1.2 * w + 0.25),
               Gate(s[4], s[5], 0.0, 1.3 * w + 0.25)),
        length=float(s[-1]),
    )


def lane_changes(starts: list[float], transitions: list[float], hold: float, vehicle_width: float,
                 offset: float = ISO_OFFSET) -> Course:
    """Double lane changes starting at ``starts`` (m), each with its transition length (m), a
    ``hold`` m long offset lane, and ISO lane widths on the entry, offset and exit lanes."""
    knots, gates = [], []
    w = vehicle_width
    end = 0.0
    for start, length in zip(starts, transitions):
        up_end = start + length
        down_start = up_end + hold
        end = down_start + length
        knots += [(start, up_end, offset), (down_start, end, -offset)]
        gates += [Gate(start - 15.0, start, 0.0, 1.1 * w + 0.25),
                  Gate(up_end, down_start, offset, 1.2 * w + 0.25),
                  Gate(end, end + 15.0, 0.0, 1.3 * w + 0.25)]
    return Course(tuple(knots), tuple(gates), end + 15.0)


@dataclass(frozen=True)
class Bend:
    """A left-hand bend (a highway curve): ``lead_in`` m straight along x, a clothoid whose
    curvature rises linearly to 1 / ``radius`` over ``transition`` m, then the arc. No cones.
    The centre line y(x) is tabulated from the curvature along the path (heading stays below
    90 degrees over ``length`` m of path)."""

    lead_in: float
    transition: float
    radius: float
    length: float

    def curvature(self, s) -> np.ndarray:
        """Path curvature (1/m, positive left) at path distance ``s`` (m)."""
        return np.clip((np.asarray(s, float) - self.lead_in) / self.transition, 0.0, 1.0) / self.radius

    def centre_line(self, x) -> np.ndarray:
        """Target lateral position y (m, positive left) at x (m)."""
        xs, ys = _bend_table(self)
        return np.interp(x, xs, ys)

    def outside(self, x: np.ndarray, y: np.ndarray, vehicle_width: float) -> np.ndarray:
        return np.zeros(len(x), dtype=bool)


@lru_cache(maxsize=8)
def _bend_table(bend: Bend, step: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of ``bend``'s centre line every ``step`` m of path, heading integrated from the
    curvature (trapezoid), position from the heading."""
    s = np.arange(0.0, bend.length + step, step)
    kappa = bend.curvature(s)
    heading = np.concatenate(([0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * step)))
    if heading.max() >= 0.45 * np.pi:
        raise ValueError(f"a bend of radius {bend.radius} m turns past 80 degrees within "
                         f"{bend.length:.0f} m: expected a shorter drive or a larger radius")
    x = np.concatenate(([0.0], np.cumsum(0.5 * (np.cos(heading[1:]) + np.cos(heading[:-1])) * step)))
    y = np.concatenate(([0.0], np.cumsum(0.5 * (np.sin(heading[1:]) + np.sin(heading[:-1])) * step)))
    return x, y
