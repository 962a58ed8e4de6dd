"""Signal-processing building blocks (symbolic where they run per step, numeric where they are
designed at generation time): second-order prefilter, median of a window, reliability check
against a reference with hold-last-valid. Specified in docs/methods.md, seed 000
§2.2, §2.3 and §2.6.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import casadi as ca


@dataclass(frozen=True)
class Biquad:
    """Discrete y[k] = n0 x[k] + n1 x[k-1] + n2 x[k-2] - d1 y[k-1] - d2 y[k-2]."""

    n0: float
    n1: float
    n2: float
    d1: float
    d2: float

    @property
    def dc_gain(self) -> float:
        return (self.n0 + self.n1 + self.n2) / (1.0 + self.d1 + self.d2)


def lowpass_2nd(omega: float, damping: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Analog omega^2 / (s^2 + 2 damping omega s + omega^2) as (numerator, denominator)."""
    return (omega * omega,), (1.0, 2.0 * damping * omega, omega * omega)


def printed_prefilter() -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Seed 000's printed prefilter 10000 / (s^2 + 200 s + 10000) (critically damped, 100 rad/s)."""
    return (10000.0,), (1.0, 200.0, 10000.0)


def bessel_prefilter(omega: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Second-order Bessel low-pass, phase-normalised at ``omega`` rad/s:
    omega^2 / (s^2 + sqrt(3) omega s + omega^2) (= scipy.signal.bessel(2, omega, analog=True,
    norm='phase'))."""
    return lowpass_2nd(omega, math.sqrt(3.0) / 2.0)


def tustin_biquad(numerator: Sequence[float], denominator: Sequence[float], T: float) -> Biquad:
    """Bilinear (Tustin) transform s = (2/T)(z - 1)/(z + 1) of b0 / (s^2 + a1 s + a0), where
    ``numerator`` = (b0,) and ``denominator`` = (1, a1, a0)."""
    (b0,), (one, a1, a0) = numerator, denominator
    if one != 1.0:
        raise ValueError("the denominator must be monic")
    c = 2.0 / T
    norm = c * c + a1 * c + a0
    return Biquad(b0 / norm, 2.0 * b0 / norm, b0 / norm, (2.0 * a0 - 2.0 * c * c) / norm,
                  (c * c - a1 * c + a0) / norm)


def biquad_step(f: Biquad, x: ca.SX, x1: ca.SX, x2: ca.SX, y1: ca.SX, y2: ca.SX) -> ca.SX:
    """y[k] from x[k], x[k-1], x[k-2], y[k-1], y[k-2]."""
    return f.n0 * x + f.n1 * x1 + f.n2 * x2 - f.d1 * y1 - f.d2 * y2


def whole_samples(duration, T: float):
    """A duration (s; a number or a calibration symbol) in whole samples of T: floor(d / T + 1/2)."""
    return ca.floor(duration / T + 0.5)


def held_flag(left, raised, active, duration, T: float):
    """(samples left, flag) of a 0/1 flag ``raised`` held for ``duration`` (s, a number or a
    calibration symbol; N = :func:`whole_samples`) after it was last 1: the count restarts at N
    while raised and counts down on ``active`` samples (a holding estimator holds it)."""
    samples = whole_samples(duration, T)
    counted = raised * samples + (1 - raised) * ca.fmax(left - 1, 0)
    return ca.if_else(active, counted, left), raised + (1 - raised) * active * (left > 0)


def low_pass(previous, value, time_constant, T: float, sampled=None):
    """One step of the first-order low-pass y_k = y_k-1 + (1 - exp(-T / time_constant)) (x_k -
    y_k-1); with a 0/1 flag ``sampled``, the step is taken only where it is 1 (held elsewhere, a
    select of the step, so a ``value`` that is not finite where it is 0 never reaches the state).
    ``time_constant`` may be a calibration symbol; a number folds the gain at generation time."""
    step = (1 - ca.exp(-T / time_constant)) * (value - previous)
    return previous + (step if sampled is None else ca.if_else(sampled, step, 0))


def learned_mean(previous, taken, value, time_constant, T: float, sampled):
    """One step of a mean learned from the samples where the 0/1 flag ``sampled`` is 1 (held
    elsewhere): y_k = y_k-1 + g (x_k - y_k-1) with g = max(1 / (n + 1), 1 - exp(-T / time_constant)),
    n the samples taken so far, counted up to N = ``time_constant`` / T in whole samples. It starts
    as the running mean of its first samples, so it knows from a few of them what a first-order
    low-pass from 0 (:func:`low_pass`) would need several time constants for, and forgets as that
    low-pass once N samples are in. Returns (mean, samples taken); ``time_constant`` may be a
    calibration symbol."""
    gain = ca.fmax(1 / (taken + 1), 1 - ca.exp(-T / time_constant))
    return (previous + ca.if_else(sampled, gain * (value - previous), 0),
            taken + sampled * (taken < whole_samples(time_constant, T)))


def learned_check(s, settings, sample_time: float, entry: str, value, sampled, time_key: str,
                  limit_key: str) -> tuple[dict, ca.SX]:
    """(new entries, flag) of a check on a learned mean: state entry ``entry`` of ``s`` learns
    ``value`` where ``sampled`` (:func:`learned_mean`, time constant setting ``time_key``), counting
    its samples in ``entry``_samples; the flag is 1 where |mean| > setting ``limit_key`` once the
    mean has sampled setting ``learned_after``, or its time constant if that is shorter (its count
    stops there). ``settings`` numbers or calibration symbols."""
    count, time_constant = f"{entry}_samples", settings[time_key]
    mean, taken = learned_mean(s[entry], s[count], value, time_constant, sample_time, sampled)
    judged = taken >= ca.fmin(whole_samples(settings["learned_after"], sample_time),
                              whole_samples(time_constant, sample_time))
    return {entry: mean, count: taken}, judged * (ca.fabs(mean) > settings[limit_key])


def tustin_derivative(time_constant: float, T: float) -> tuple[float, float]:
    """(n, d) of the Tustin-discretised filtered derivative s / (time_constant s + 1):
    y[k] = n (x[k] - x[k-1]) - d y[k-1]."""
    norm = 2.0 * time_constant + T
    return 2.0 / norm, (T - 2.0 * time_constant) / norm


def median_window(samples_per_second: float, span: float) -> int:
    """Odd window length covering ``span`` seconds: 2 round(span / (2 T)) + 1 (spec A2)."""
    return 2 * round(span * samples_per_second / 2.0) + 1


def median(values: Sequence[ca.SX]) -> ca.SX:
    """Median of an odd number of values by a partial selection network of fmin/fmax
    (branch-free; (n+1)/2 bubble passes put the median in place)."""
    items = list(values)
    n = len(items)
    if n % 2 == 0:
        raise ValueError("the median window must be odd")
    middle = n // 2
    for top in range(n - 1, middle - 1, -1):  # bubble the largest remaining value to `top`
        for i in range(top):
            low, high = ca.fmin(items[i], items[i + 1]), ca.fmax(items[i], items[i + 1])
            items[i], items[i + 1] = low, high
    return items[middle]


@dataclass(frozen=True)
class Checked:
    """Result of a reliability check: the value to use, the new last-accepted value, the new
    count of consecutive rejections, and whether the time-out forced acceptance."""

    value: ca.SX
    last: ca.SX
    rejections: ca.SX
    forced: ca.SX


def reliability_check(measured: ca.SX, reference: ca.SX, band: float, last: ca.SX,
                      rejections: ca.SX, timeout_steps: int) -> Checked:
    """Accept ``measured`` if |measured - reference| <= band, else use ``last`` (hold last valid);
    after ``timeout_steps`` consecutive rejections accept the measurement again (spec A6)."""
    inside = ca.fabs(measured - reference) <= band
    forced = ca.logic_and(ca.logic_not(inside), rejections + 1 >= timeout_steps)
    accept = ca.logic_or(inside, forced)
    return Checked(
        value=ca.if_else(accept, measured, last),
        last=ca.if_else(accept, measured, last),
        rejections=ca.if_else(accept, 0, rejections + 1),
        forced=forced,
    )
