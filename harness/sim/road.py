"""Road geometry under the truth plant: bank and grade as functions of the distance travelled.

Conventions (ISO 8855 axes of the road plane: x along the car's heading, y left, z up):

* **bank** phi_r (rad): the road's cross slope, positive with the *left* edge up, so that gravity
  pulls the car to the right. A left-hand curve superelevated by e (fraction, e.g. 0.06) has
  phi_r = -atan(e) (its outer, right edge is the higher one); a crossfall that drains to the right
  has phi_r > 0.
* **grade** theta_r (rad): positive uphill in the direction of travel (a 2.5 % grade is
  atan(0.025)).
* **vertical curvature** kappa_v = d theta_r / ds (1/m): positive in a sag (dip), negative over a
  crest; it adds vx^2 kappa_v to the normal specific force (the car is pressed into a dip and
  lightened over a crest).

The road acts in the car's yaw-aligned axes: the car is taken to follow the road, so that its
heading relative to the road's cross-slope direction stays small (cos of a few degrees = 1 to
1e-3). The plant (harness.sim.two_track) takes (phi_r, theta_r, kappa_v) as inputs.

Profiles are piecewise linear in the distance s (m) between stations; kappa_v is the slope of
the grade profile between stations (piecewise constant).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def slope_angle(percent: float) -> float:
    """The angle (rad) of a slope of ``percent`` % (rise over run x 100)."""
    return float(np.arctan(percent / 100.0))


@dataclass(frozen=True)
class Road:
    """Bank and grade (rad) at ``stations`` (m of distance travelled, increasing), linearly
    interpolated between them and held beyond the ends."""

    stations: tuple[float, ...] = (0.0,)
    bank: tuple[float, ...] = (0.0,)
    grade: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        if not (len(self.stations) == len(self.bank) == len(self.grade) >= 1):
            raise ValueError("a road needs one bank and one grade per station")
        if np.any(np.diff(self.stations) <= 0.0):
            raise ValueError("road stations must increase")
        if max(map(abs, (*self.bank, *self.grade))) >= np.pi / 4:
            raise ValueError("road bank and grade must stay below 45 degrees")

    @staticmethod
    def constant(bank: float = 0.0, grade: float = 0.0) -> Road:
        """A road of one ``bank`` and ``grade`` (rad) everywhere."""
        return Road((0.0,), (bank,), (grade,))

    def tilted(self, bank: float = 0.0, grade: float = 0.0) -> Road:
        """This road with ``bank`` and ``grade`` (rad) added everywhere."""
        return Road(self.stations, tuple(b + bank for b in self.bank),
                    tuple(g + grade for g in self.grade))

    @property
    def flat(self) -> bool:
        return not any(self.bank) and not any(self.grade)

    def __call__(self, distance: float) -> np.ndarray:
        """(bank rad, grade rad, vertical curvature 1/m) at ``distance`` (m)."""
        s = np.asarray(self.stations)
        bank = float(np.interp(distance, s, self.bank))
        grade = float(np.interp(distance, s, self.grade))
        i = int(np.searchsorted(s, distance, side="right"))
        if 0 < i < len(s):
            curvature = (self.grade[i] - self.grade[i - 1]) / (s[i] - s[i - 1])
        else:
            curvature = 0.0
        return np.array([bank, grade, curvature])


FLAT = Road()
