"""Yaw rate against the non-driven wheels' speed difference, the gyro check of production ESC
software. Beyond the papers; the rule it serves: never a silently wrong estimate.

Freely rolling wheels on a rigid axle of track t differ in speed by the yaw rate: the rear wheels'
centres move at v_x -+ r t/2, the steered front wheels' along their heading, so

    r_w = R (omega_right - omega_left) / (t cos(delta))     (front axle; rear: cos = 1),

R the rolling radius. The axle must be the non-driven one (``wheel_check_axle``): drive torque
makes a driven wheel slip, and so does braking (the unloaded inner wheel of a braked bend slips
most: 3 times the yaw rate in the downhill braking bend), so the check samples only while the
car neither brakes nor accelerates hard, |a_x| <= ``wheel_check_ax`` (the speed in the logs comes
from the wheels, so their slip does not show against it). Every quantity is the mean of the
checks' period (r, the wheel-speed difference and a_x, summed on each active sample: one sample
carries its sensor's whole noise). The gyro is compared with r_w through a low-pass, held between
samples, on each run of the checks (every check_period T_c),

    m_k = m_k-1 + (1 - exp(-T_c / wheel_check_time)) (mean r - mean r_w - m_k-1),

and |m| > ``wheel_check_limit`` raises status YAW_RATE_MISMATCH: a gyro offset or drift, a frozen
or late yaw rate, a wheel-speed fault, or a tyre far from the nominal radius. A yaw-rate *scale*
error (a DBC factor typed 0.013 for 0.01) makes m proportional to r, small where the car yaws
little; so, with ``wheel_check_scale`` > 0, the mean wheel yaw rate n (|r_w| low-passed alike) is
kept too, and |m| > wheel_check_scale n also raises the bit where n >= ``wheel_check_scale_rate``
(a steered front axle over-reads r by up to 10 % at 4 m/s^2, a gyro on a pitching body under-reads
it over a crest: 0.2 of n stays clear of both). A scale typed wrong stays wrong, but where the car
yaws little (a low-friction slalom) the share is too noisy to judge on one run; so, with
``wheel_check_scale_time`` > 0, the check also learns the share |m| / n over the runs where it
judges it (``model.filters.learned_check``: a running mean of its first runs, judged once it
has sampled ``learned_after``), and while that learned share is beyond ``wheel_check_scale`` raises
the bit wherever n >= ``wheel_check_learned_rate``:
what the last corners showed is kept for the milder ones. The bit stays raised ``wheel_check_hold`` s after
it fell (m passes 0 whenever r does, while an estimate that integrated the wrong r recovers). An estimator has
the check when it reads that axle's wheel speeds (the UKFs in their "wheel_speeds" mode) and
``wheel_check_limit`` > 0; a holding estimator holds it. Every estimator with the input monitors can
be given the wheel speeds: switching the check on adds a_x and that axle's wheel speeds to its inputs
(``model.input_monitors.inputs``), so a yaw-rate scale typed wrong in a DBC (1.3 for 1.0) is flagged
by the estimators that trust r most.
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import status
from vsegen.model.filters import held_flag, learned_check, low_pass
from vsegen.model.input_checks import Watch
from vsegen.model.schema import choice, nonnegative, positive
from vsegen.model.signals import Signal

ORDER = 3
BITS = (status.YAW_RATE_MISMATCH,)

FIELDS = (
    choice("wheel_check_axle", ("rear", "front"), "beyond the papers: the non-driven axle whose "
           "wheel speeds the yaw-rate check reads", default="rear"),
    nonnegative("wheel_check_limit", "rad/s", "beyond the papers: the mean of the yaw rate minus the "
                "non-driven wheels' yaw rate beyond this raises status 32768 YAW_RATE_MISMATCH (a "
                "gyro offset, drift or freeze, a yaw-rate scale typed wrong); above 0 the estimator "
                "also reads a_x and that axle's wheel speeds; 0 = no check", default=0.0),
    positive("wheel_check_time", "s", "time constant of the yaw-rate check's mean (one check period: it "
             "low-passes the period's means of r and the wheel speeds)", default=0.1),
    positive("wheel_check_ax", "m/s^2", "the yaw-rate check samples only while |a_x| is below this "
             "(no braking or drive torque to make the wheels slip)", default=1.0),
    nonnegative("wheel_check_scale", "-", "beyond the papers: the yaw-rate check's mean beyond this "
                "share of the mean |wheel yaw rate| also raises YAW_RATE_MISMATCH (a yaw-rate scale "
                "typed wrong); 0 = off", default=0.0),
    positive("wheel_check_scale_rate", "rad/s", "the share test (wheel_check_scale) judges only where "
             "the mean |wheel yaw rate| is at least this", default=0.1),
    nonnegative("wheel_check_scale_time", "s", "beyond the papers: time constant of the learned share of "
                "the yaw-rate check's mean in the mean |wheel yaw rate| (learned where the share test judges); "
                "beyond wheel_check_scale it raises YAW_RATE_MISMATCH wherever the mean |wheel yaw rate| is at "
                "least wheel_check_learned_rate (a yaw-rate scale typed wrong, kept for the mild corners); 0 = off",
                default=0.0),
    positive("wheel_check_learned_rate", "rad/s", "the learned share (wheel_check_scale_time) raises "
             "YAW_RATE_MISMATCH only where the mean |wheel yaw rate| is at least this", default=0.02),
    nonnegative("wheel_check_hold", "s", "YAW_RATE_MISMATCH stays raised this long after the yaw-rate "
                "check's means agree again, while the estimate recovers from the wrong yaw rate; "
                "0 = off", default=0.0),
)
STATE = Signal("wheel_yaw_residual", "rad/s", "yaw-rate check: mean of r minus the non-driven wheels' "
                                              "yaw rate")
RATE = Signal("wheel_yaw_rate", "rad/s", "yaw-rate check: mean |non-driven wheels' yaw rate| "
                                         "(wheel_check_scale)")
SHARE = Signal("wheel_yaw_share", "-", "yaw-rate check: learned share of the mean of r minus the wheels' "
                                      "yaw rate in their mean |yaw rate| (wheel_check_scale_time)")
SHARE_SAMPLES = Signal("wheel_yaw_share_samples", "-", "yaw-rate check: runs the learned share has taken, "
                                                       "counted up to wheel_check_scale_time")
HOLD = Signal("wheel_yaw_hold_left", "-", "samples YAW_RATE_MISMATCH stays raised (wheel_check_hold)")


def wheels(numeric_settings) -> tuple[str, str]:
    """(left, right) wheel-speed inputs of the checked axle."""
    axle = _axle(numeric_settings)
    return f"omega_{axle}l", f"omega_{axle}r"


def difference(numeric_settings) -> str:
    """The mean the check reads of the checked axle's right minus left wheel speed
    (``model.input_monitors.AVERAGED``)."""
    return f"omega_{_axle(numeric_settings)}_diff"


def _axle(numeric_settings) -> str:
    return "r" if numeric_settings["wheel_check_axle"] == "rear" else "f"


def reads(numeric_settings) -> tuple[str, ...]:
    """The inputs the check reads when it is on (``wheel_check_limit`` > 0), else none: an
    estimator is given them beside its method's own (``model.input_monitors.inputs``)."""
    return ("delta", "ax", "r", *wheels(numeric_settings)) if numeric_settings["wheel_check_limit"] > 0.0 else ()


def enabled(numeric_settings, inputs: tuple[str, ...]) -> bool:
    """Whether an estimator reading ``inputs`` has the check (structural)."""
    checked = reads(numeric_settings)
    return bool(checked) and all(name in inputs for name in checked)


def raises(numeric_settings, inputs: tuple[str, ...]) -> tuple[int, ...]:
    """YAW_RATE_MISMATCH where the check is on."""
    return BITS if enabled(numeric_settings, inputs) else ()


def states(numeric_settings, inputs: tuple[str, ...]) -> tuple[Signal, ...]:
    """The check's state entries (0 at init), none when it is off."""
    if not enabled(numeric_settings, inputs):
        return ()
    return (STATE, *((RATE,) if numeric_settings["wheel_check_scale"] > 0.0 else ()),
            *((SHARE, SHARE_SAMPLES) if _learns_share(numeric_settings) else ()),
            *((HOLD,) if numeric_settings["wheel_check_hold"] > 0.0 else ()))


def _learns_share(numeric_settings) -> bool:
    """Whether the check learns the share (structural)."""
    return numeric_settings["wheel_check_scale"] > 0.0 and numeric_settings["wheel_check_scale_time"] > 0.0


def initial_entries(first: dict, numeric_settings, inputs: tuple[str, ...]) -> dict:
    """Nothing learned at init."""
    return {entry.name: ca.SX(0) for entry in states(numeric_settings, inputs)}


def monitor(watch: Watch) -> tuple[dict, dict]:
    """(new state entries, {YAW_RATE_MISMATCH: 1 while the yaw rates disagree}); call only when
    :func:`enabled`. It reads the period's means (``model.input_monitors.AVERAGED``): r, the
    axle's right minus left wheel speed and a_x, whether the car rolls freely (one sample carries
    its sensor's whole noise; an implausible a_x or wheel-speed difference adds nothing to its sum)."""
    s, u, active, settings, numeric_settings = watch.s, watch.u, watch.active, watch.settings, watch.numeric
    sample_time, vehicle = watch.sample_time, watch.vehicle
    steer = ca.cos(u["delta"]) if numeric_settings["wheel_check_axle"] == "front" else 1
    wheel_yaw_rate = vehicle["wheel_radius"] * u[difference(numeric_settings)] / (vehicle["track_width"] * steer)
    rolling = ca.fabs(u["ax"]) <= settings["wheel_check_ax"]
    residual = low_pass(s[STATE.name], u["r"] - wheel_yaw_rate, settings["wheel_check_time"], sample_time, rolling)
    updates = {STATE.name: residual}
    raised = ca.fabs(residual) > settings["wheel_check_limit"]
    if numeric_settings["wheel_check_scale"] > 0.0:      # a scale error: m grows with the yaw rate
        rate = low_pass(s[RATE.name], ca.fabs(wheel_yaw_rate), settings["wheel_check_time"], sample_time, rolling)
        updates[RATE.name] = rate
        yawing = rate >= settings["wheel_check_scale_rate"]
        scaled = yawing * (ca.fabs(residual) > settings["wheel_check_scale"] * rate)
        if _learns_share(numeric_settings):                # kept for the corners too mild to judge
            share = ca.fabs(residual) / ca.fmax(rate, settings["wheel_check_scale_rate"])
            learned, beyond = learned_check(s, settings, sample_time, SHARE.name, share,
                                            ca.logic_and(rolling, yawing), "wheel_check_scale_time",
                                            "wheel_check_scale")
            updates |= learned
            kept = beyond * (rate >= settings["wheel_check_learned_rate"])
            scaled = scaled + kept - scaled * kept
        raised = raised + scaled - raised * scaled
    updates = {name: ca.if_else(active, value, s[name]) for name, value in updates.items()}
    if numeric_settings["wheel_check_hold"] > 0.0:
        updates[HOLD.name], flag = held_flag(s[HOLD.name], active * raised, active, settings["wheel_check_hold"],
                                             sample_time)
        return updates, {status.YAW_RATE_MISMATCH: flag}
    return updates, {status.YAW_RATE_MISMATCH: active * raised}
