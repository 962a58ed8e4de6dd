"""Cross-checks of the inputs against each other, as production ESC software checks its sensors.
Beyond the papers; the rule they serve: never a silently wrong estimate.

The checks look at *quasi-steady* driving only, where the kinematics give a relation between the
inputs that no tyre parameter enters. A sample is quasi-steady when the steer angle has stayed
near the value delta_0 it had ``steady_time`` ago, |delta - delta_0| v_x^2 / l <= ``steady_band``
(the change of a_y the steer change would ask for in a kinematic turn; the stretch restarts
whenever it leaves the band), so the yaw rate and the lateral velocity have settled. The checks
run every ``check_period`` T_c (model.input_monitors) on the period's mean a_y and r, so a steer
angle can leave the band and come back between two runs: the lateral check and the steering-angle
zero also want the yaw rate *settled*, |r - r_last run| v_x <= ``settle_band`` (a transient's v_y'
is no offset; above the gyro noise):

* **lateral check** (status LATERAL_INCONSISTENT): with v_y' = 0 the lateral specific force is
  a_y = r v_x. While quasi-steady, settled and |a_y| <= ``lateral_check_range`` (where body roll adds at
  most about 0.1 m/s^2 to a body-fixed accelerometer), the residual a_y - r v_x is averaged,

      e_k = e_k-1 + g_n (a_y - r v_x - e_k-1),   g_n = max(1 / (n + 1), 1 - exp(-T_c / lateral_check_time)),

  n the runs it has sampled (a running mean of its first runs, then a first-order low-pass:
  ``model.filters.learned_mean``; a bank or an offset there from the start is told within a few
  runs of straight driving), and held outside those stretches. |e| > ``lateral_check_limit`` raises
  the bit once the mean has sampled ``learned_after`` (a running mean of fewer runs is too noisy
  for the limit; or lateral_check_time if shorter): a road bank (g sin(phi_r) in a_y: 0.51 m/s^2
  for 3 deg), an accelerometer offset or mounting tilt, a yaw-rate or speed error. Every estimator
  that integrates a_y or trusts a_y against r is suspect then.
* **steering-angle zero** (status STEERING_OFFSET): driving straight (quasi-steady, settled, |a_y| <=
  ``steering_offset_range``, v_x >= ``steering_offset_speed``), the road-wheel angle of the
  kinematic (Ackermann) turn is l r / v_x; understeer adds K_us a_y, below 0.001 rad per m/s^2 for
  passenger cars, so the zero is learned as

      d_k = d_k-1 + g_n (delta - l r / v_x - d_k-1),   g_n = max(1 / (n + 1), 1 - exp(-T_c / steering_offset_time)),

  (a running mean of its first n runs, then a low-pass, as the lateral check's, so an offset there
  at start-up is told within a few runs, as an ESC learns its steering sensor's zero fast after
  start-up and then slowly), and |d| > ``steering_offset_limit`` raises the bit once the zero has
  sampled ``learned_after``: the steering-angle sensor's zero is off (a service calibration, an
  alignment or a sensor exchange), so every model-based scheme sees a steer angle the car does not
  have. The learned zero d is a state (``steering_offset``).
* **steer angle follows the car** (status INPUT_FROZEN): at a constant steer angle the path
  curvature r / v_x stays constant once settled (understeer changes it by a few per cent with the
  speed). With the curvature low-passed,

      kappa_k = kappa_k-1 + (1 - exp(-T_c / steer_check_time)) (r / v_x - kappa_k-1),

  kappa_0 = kappa when the stretch turns quasi-steady, the change of the lateral acceleration the
  path asks for, (kappa - kappa_0) v_x^2, is checked while the stretch lasts and |a_y| <=
  ``steer_check_range`` (away from the friction limit, where the path does bend away at a held
  steer angle); beyond ``steer_check_limit`` it raises the bit: the car turns while
  its steer angle stands still, a steering-angle signal frozen at any value (a bit-for-bit
  repetition test cannot tell a steering wheel held still from a stuck sensor).

A holding estimator holds the checks with the rest of its state. A limit of 0 switches its check
off (no state, no status; the quasi-steady detector exists while any is on).
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import status
from vsegen.model.filters import learned_check, low_pass, whole_samples
from vsegen.model.input_checks import Watch
from vsegen.model.schema import nonnegative, positive
from vsegen.model.signals import Signal

ORDER = 2
INPUTS = ("delta", "vx", "ay", "r")
"""The inputs the checks read; an estimator without all of them has no cross-checks."""

FIELDS = (
    positive("steady_time", "s", "beyond the papers: the steer angle must stay within steady_band "
             "this long before the cross-checks take a sample as quasi-steady", default=0.3),
    positive("steady_band", "m/s^2", "a quasi-steady stretch ends when the steer angle has moved "
             "so far that a kinematic turn would change a_y by this, |delta - delta_0| v_x^2 / l",
             default=0.2),
    positive("settle_band", "m/s^2", "the lateral check and the steering zero sample only while the yaw "
             "rate has moved less than this over v_x since the checks' last run (|r - r_last| v_x: settled, "
             "no transient; above the gyro's noise)", default=0.6),
    nonnegative("lateral_check_limit", "m/s^2", "beyond the papers: the mean of a_y - r v_x in "
                "quasi-steady driving beyond this raises status 8192 LATERAL_INCONSISTENT (a road "
                "bank, an accelerometer offset or tilt, a yaw-rate or speed error); 0 = no check",
                default=0.0),
    positive("lateral_check_time", "s", "time constant of the lateral check's mean", default=0.5),
    positive("learned_after", "s", "the lateral check, the steering zero and the yaw-rate check's learned "
             "share judge their mean only once it has sampled this long (in runs of check_period; a running "
             "mean of fewer runs is too noisy), or their time constant if that is shorter", default=0.3),
    positive("lateral_check_range", "m/s^2", "the lateral check samples only while |a_y| is below "
             "this (body roll's share of a_y stays small)", default=1.5),
    nonnegative("steering_offset_limit", "rad", "beyond the papers: the steering-angle zero learned "
                "in straight driving beyond this raises status 16384 STEERING_OFFSET; 0 = no "
                "learning", default=0.0),
    positive("steering_offset_time", "s", "time constant of the learned steering-angle zero",
             default=5.0),
    positive("steering_offset_range", "m/s^2", "the steering zero is learned only while |a_y| is "
             "below this (straight driving)", default=0.5),
    positive("steering_offset_speed", "m/s", "the steering zero is learned only at or above this "
             "speed (a gyro bias b shifts it by l b / v_x)", default=15.0),
    nonnegative("steer_check_limit", "m/s^2", "beyond the papers: at a constant steer angle, a "
                "change of the path's lateral acceleration (r - kappa_0 v_x) v_x beyond this raises "
                "status 2048 INPUT_FROZEN (a frozen steering-angle signal); 0 = no check", default=0.0),
    positive("steer_check_time", "s", "time constant of the steer check's low-passed path curvature (of "
             "the check period's mean yaw rate, itself an average)", default=0.05),
    positive("steer_check_range", "m/s^2", "the steer check runs only while |a_y| is below this (the "
             "friction limit, where the path bends away at a held steer angle, lies beyond it)",
             default=6.0),
)

_STEADY = (Signal("steady_delta", "rad", "cross-checks: steer angle at the start of the quasi-steady "
                  "stretch"),
           Signal("steady_samples", "-", "cross-checks: runs the stretch has lasted (at most "
                  "steady_time / check_period)"),
           Signal("steady_r", "rad/s", "cross-checks: yaw rate at their last run"))
_CHECKS = (
    ("lateral_check_limit", status.LATERAL_INCONSISTENT,
     (Signal("lateral_residual", "m/s^2", "lateral check: mean of a_y - r v_x in quasi-steady driving"),
      Signal("lateral_residual_samples", "-", "lateral check: runs its mean has taken (at most "
             "lateral_check_time / check_period)"))),
    ("steering_offset_limit", status.STEERING_OFFSET,
     (Signal("steering_offset", "rad", "learned steering-angle zero (road wheel)"),
      Signal("steering_offset_samples", "-", "steering-angle zero: runs it has learned from (at most "
             "steering_offset_time / check_period)"))),
    ("steer_check_limit", status.INPUT_FROZEN,
     (Signal("curvature", "1/m", "steer check: low-passed path curvature r / v_x"),
      Signal("steady_curvature", "1/m", "steer check: low-passed path curvature when the stretch turned "
             "quasi-steady"))),
)
"""Each check: the setting whose value > 0 switches it on, the bit it raises and its state entries
(0 at init)."""
BITS = tuple(bit for _, bit, _ in _CHECKS)


def _on(numeric_settings, limit_key: str) -> bool:
    return numeric_settings[limit_key] > 0.0


def reads(numeric_settings) -> tuple[str, ...]:
    """None beside the method's: an estimator without all of :data:`INPUTS` has no cross-checks."""
    return ()


def enabled(numeric_settings, inputs: tuple[str, ...]) -> bool:
    """Whether an estimator reading ``inputs`` has any cross-check (structural: a limit > 0 when
    it is generated, also in calibratable mode)."""
    return all(name in inputs for name in INPUTS) and any(_on(numeric_settings, key) for key, _, _ in _CHECKS)


def raises(numeric_settings, inputs: tuple[str, ...]) -> tuple[int, ...]:
    """The bits of the checks that are on."""
    if not enabled(numeric_settings, inputs):
        return ()
    return tuple(bit for key, bit, _ in _CHECKS if _on(numeric_settings, key))


def states(numeric_settings, inputs: tuple[str, ...]) -> tuple[Signal, ...]:
    """The checks' state entries (none when all are off)."""
    if not enabled(numeric_settings, inputs):
        return ()
    return (*_STEADY, *(entry for key, _, entries in _CHECKS if _on(numeric_settings, key) for entry in entries))


def initial_entries(first: dict, numeric_settings, inputs: tuple[str, ...]) -> dict:
    """The entries at init: a stretch starting at the first sample, nothing learned."""
    firsts = {"steady_delta": first["delta"], "steady_r": first["r"]}
    return {entry.name: firsts.get(entry.name, ca.SX(0)) for entry in states(numeric_settings, inputs)}


def monitor(watch: Watch) -> tuple[dict, dict]:
    """(new state entries, {status bit: 1 while raised}) on a step (the inputs are plausible on an
    active sample); call only when :func:`enabled`. Flags and selections are arithmetic,
    f a + (1 - f) b for a flag f (exact for f in {0, 1})."""
    s, u, active, settings, sample_time = watch.s, watch.u, watch.active, watch.settings, watch.sample_time
    numeric_settings, wheelbase = watch.numeric, watch.vehicle["wheelbase"]
    limit = whole_samples(settings["steady_time"], sample_time)
    moved = ca.fabs(u["delta"] - s["steady_delta"]) * u["vx"] * u["vx"] > settings["steady_band"] * wheelbase
    samples = (1 - moved) * ca.fmin(s["steady_samples"] + 1, limit)
    steady = samples >= limit
    settled = steady * (ca.fabs(u["r"] - s["steady_r"]) * u["vx"] <= settings["settle_band"])
    updates = {"steady_delta": moved * u["delta"] + (1 - moved) * s["steady_delta"], "steady_samples": samples,
               "steady_r": u["r"]}
    raised = {}
    if _on(numeric_settings, "lateral_check_limit"):
        sampled = settled * (ca.fabs(u["ay"]) <= settings["lateral_check_range"])
        learned, raised[status.LATERAL_INCONSISTENT] = learned_check(
            s, settings, sample_time, "lateral_residual", u["ay"] - u["r"] * u["vx"], sampled,
            "lateral_check_time", "lateral_check_limit")
        updates |= learned
    if _on(numeric_settings, "steering_offset_limit"):
        sampled = settled * (ca.fabs(u["ay"]) <= settings["steering_offset_range"]) * (
            u["vx"] >= settings["steering_offset_speed"])
        kinematic_zero = u["delta"] - wheelbase * u["r"] / ca.fmax(u["vx"], settings["steering_offset_speed"])
        learned, raised[status.STEERING_OFFSET] = learned_check(
            s, settings, sample_time, "steering_offset", kinematic_zero, sampled, "steering_offset_time",
            "steering_offset_limit")
        updates |= learned
    if _on(numeric_settings, "steer_check_limit"):
        curvature = low_pass(s["curvature"], u["r"] / u["vx"], settings["steer_check_time"], sample_time)
        turned_steady = steady * (s["steady_samples"] < limit)
        reference = turned_steady * curvature + (1 - turned_steady) * s["steady_curvature"]
        checked = steady * (ca.fabs(u["ay"]) <= settings["steer_check_range"])
        change = (curvature - reference) * u["vx"] * u["vx"]
        updates |= {"curvature": curvature, "steady_curvature": reference}
        raised[status.INPUT_FROZEN] = checked * (ca.fabs(change) > settings["steer_check_limit"])
    return ({k: ca.if_else(active, v, s[k]) for k, v in updates.items()},
            {bit: active * flag for bit, flag in raised.items()})
