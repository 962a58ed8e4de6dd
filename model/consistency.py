"""Consistency monitor shared by the estimators: do the model's predictions still explain the
measurements? Beyond the papers; the rule it serves: never a silently wrong estimate.

Each sample, the prior innovations nu_i = z_i - h_i(x-) (i over the measured channels) are
compared with the car's sensor noise sigma_i (``sensor_noise``, from ``vsegen identify``; not the
filter's R, which is a tuning knob and often far from the sensor's noise):

    m_k = a m_k-1 + (1 - a) (1/n) sum_i min(nu_i^2 / sigma_i^2, 100),   a = exp(-T / residual_window):

one sample counts at most 100 variances (a 10-sigma outlier, e.g. seed 000's gyro spikes, moves m
by at most 100/n (1 - a), far below the limit).

While the model explains the data, m stays near 1 plus the prior's own share; when it no longer
does (tyres beyond the model's friction, a wrong parameter, an unmodelled disturbance), m rises.
m > ``residual_limit`` raises the status bit MODEL_INCONSISTENT for as long as it lasts and
``residual_hold`` seconds longer (the error built up while the model failed outlasts the
innovations, which calm down as soon as the filter has absorbed it); an estimator may also act on
the sample m first exceeds the limit (the UKFs restart). ``residual_window`` = 0 switches the
monitor off (no state, no status).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from vsegen.model.estimator import Derived
from vsegen.model.filters import whole_samples
from vsegen.model.schema import SMALLEST_SIGMA, Field, diagonal, nonnegative, positive
from vsegen.model.signals import Signal

OUTLIER_CAP = 100.0
"""Most one channel's squared innovation counts, in sensor variances (a 10-sigma outlier)."""
CHANNELS = {"ax": ("ax_noise", "m/s^2"), "ay": ("ay_noise", "m/s^2"), "r": ("gyro_noise", "rad/s")}
"""Measured channels by name: the identified quantity that is its sensor noise, and its unit."""
TABLE_2 = {"ax": 0.3, "ay": 0.3, "r": 0.017453}
"""Seed 000 Table 2's sensor noise (1 sigma), the default before a car's logs are identified."""


def fields(channels: tuple[str, ...]) -> tuple[Field, ...]:
    """The monitor's settings for an estimator measuring ``channels`` (keys of :data:`CHANNELS`)."""
    units = ", ".join(CHANNELS[c][1] for c in channels)
    return (
        nonnegative("residual_window", "s", "beyond the papers: time constant of the consistency "
                    "monitor's mean of the squared innovations; 0 = no monitor", default=0.0),
        positive("residual_limit", "-", "mean squared innovation, in units of the sensor noise "
                 "variance, above which status MODEL_INCONSISTENT is raised", default=6.0),
        nonnegative("residual_hold", "s", "how long MODEL_INCONSISTENT stays raised after the mean "
                    "fell below the limit", default=0.0),
        diagonal("sensor_noise", len(channels), f"[{', '.join(channels)}]: {units}",
                 "the sensors' noise, 1 sigma (the consistency monitor's yardstick)",
                 default=tuple(TABLE_2[c] for c in channels), minimum=SMALLEST_SIGMA),
    )


LINEAR_RANGE = nonnegative(
    "linear_range", "m/s^2", "beyond the papers: above this |a_y|, measured or as the filter's model "
    "predicts it, the tyres leave their linear range, where the estimate rests on the tyre model (a "
    "linear one, or one with a friction coefficient the road may not offer) and the status says "
    "BEYOND_LINEAR_RANGE (about half the friction limit: 4 for a dry road); 0 = never", default=0.0)
"""For estimators whose sideslip rests on a tyre model (kf2dof, ukf, aukf). The model's a_y leads
the measured one into a manoeuvre (the steer angle acts on it first), and on a slippery road it
asks for more than the tyres give."""
LINEAR_RANGE_HOLD = nonnegative(
    "linear_range_hold", "s", "beyond the papers: BEYOND_LINEAR_RANGE stays raised this long after "
    "|a_y| fell back within linear_range (a car sliding at the limit dips below it for a moment); "
    "0 = off", default=0.0)
LINEAR_RANGE_STATE = Signal("linear_range_hold_left", "-", "samples BEYOND_LINEAR_RANGE stays raised "
                            "(linear_range_hold)")


def beyond_linear_range(ay, settings, ay_model=None, friction_scale=None):
    """1 when |``ay``| (measured), or |``ay_model``| (the filter's prior a_y, where it has one),
    exceeds ``linear_range`` (> 0), times the estimated ``friction_scale`` where the filter has one
    (the linear range shrinks with the road's friction: on a road of a third of the file's friction
    the tyres saturate at a third of the a_y)."""
    seen = ca.fabs(ay) if ay_model is None else ca.fmax(ca.fabs(ay), ca.fabs(ay_model))
    limit = settings["linear_range"] if friction_scale is None else settings["linear_range"] * friction_scale
    return ca.logic_and(settings["linear_range"] > 0, seen > limit)


def holds_linear_range(numeric_settings) -> bool:
    """Whether BEYOND_LINEAR_RANGE is held after it fell (structural)."""
    return numeric_settings["linear_range"] > 0.0 and numeric_settings["linear_range_hold"] > 0.0


def derived(channels: tuple[str, ...]) -> dict[str, Derived]:
    """``sensor_noise`` follows from the identified noise of each channel."""
    return {"sensor_noise": Derived(tuple(CHANNELS[c][0] for c in channels),
                                    lambda *sigmas: list(sigmas))}


def enabled(numeric_settings) -> bool:
    """Whether the generated code has the monitor (structural: ``residual_window`` > 0 when it is
    generated, also in calibratable mode)."""
    return numeric_settings["residual_window"] > 0.0


STATES = (
    Signal("residual", "-", "consistency monitor: mean squared innovation in sensor variances"),
    Signal("residual_hold_left", "-", "consistency monitor: samples MODEL_INCONSISTENT stays raised"),
)
"""The monitor's state entries (when it is on), 0 at init."""


def initial_entries(monitored: bool) -> dict[str, ca.SX]:
    """The monitor's state entries at init (0), or none when it is off."""
    return {entry.name: ca.SX(0) for entry in STATES} if monitored else {}


@dataclass(frozen=True)
class Monitored:
    """One step of the monitor: the new state entries, whether the estimate is suspect (status
    MODEL_INCONSISTENT) and whether the mean first exceeded the limit on this sample."""

    updates: dict
    suspect: object
    first: object


def monitor(s: dict, innovation, settings, sample_time: float) -> Monitored:
    """The monitor's step from the state entries ``s`` (:data:`STATES`) and the prior
    ``innovation``; call only when :func:`enabled`."""
    mean = averaged(s["residual"], innovation, settings, sample_time)
    now, before = inconsistent(mean, settings), inconsistent(s["residual"], settings)
    hold_samples = whole_samples(settings["residual_hold"], sample_time)
    left = ca.if_else(now, hold_samples, ca.fmax(s["residual_hold_left"] - 1, 0))
    return Monitored({"residual": mean, "residual_hold_left": left},
                     ca.logic_or(now, s["residual_hold_left"] > 0),
                     ca.logic_and(now, ca.logic_not(before)))


def averaged(previous, innovation, settings, sample_time: float):
    """m_k from m_k-1 = ``previous`` and the prior ``innovation`` (CasADi column, one entry per
    channel, in ``sensor_noise`` order), ``settings`` the estimator's (numbers or calibration
    symbols); call only when :func:`enabled`."""
    sigma = settings["sensor_noise"]
    n = len(sigma)
    ratio = sum(ca.fmin(innovation[i] * innovation[i] / (sigma[i] * sigma[i]), OUTLIER_CAP)
                for i in range(n)) / n
    keep = ca.exp(-sample_time / ca.fabs(settings["residual_window"]))  # a calibrated -0 keeps nothing
    return keep * previous + (1 - keep) * ratio


def inconsistent(mean_square, settings):
    """1 while the monitor's mean ``mean_square`` exceeds ``residual_limit``."""
    return mean_square > settings["residual_limit"]
