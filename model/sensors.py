"""What estimators undo of body-fixed sensors (docs/conventions.md, "Units and signs")."""

from __future__ import annotations

from vsegen.model.bicycle import GRAVITY


def roll_corrected(ay_measured, roll_gradient):
    """a_y at the CG from a body-fixed accelerometer: a_y,m = a_y cos(phi) + g sin(phi) with
    phi = k a_y gives, to first order, a_y = a_y,m / (1 + g k) (k = roll_gradient, rad/(m/s^2);
    0 = no correction). Works on numbers and CasADi expressions."""
    return ay_measured * (1.0 / (1.0 + GRAVITY * roll_gradient))
