"""The learned kinematic offset of the seed-000 estimators (switching, fusion). Beyond the paper;
the bank- and bias-robust design of docs/robustness.md.

The kinematic derivative v_y' = a_y - r v_x is 0 on average in straight driving; a road bank
(g sin(phi_r) in a body-fixed a_y), an accelerometer offset or tilt and a gyro bias (times v_x)
make it c instead, and the kinematic integrator drifts by c per second. c is learned while the
car drives nearly straight, |a_y,f - c| and |r v_x| both below ``offset_band`` (where v_y' and the
roll and lever-arm terms vanish; centred on c, so that an offset near the band is not truncated):

    c_k = c_k-1 + (1 - exp(-T / offset_memory)) (a_y - r v_x - c_k-1),

and the kinematic scheme integrates a_y - r v_x - c. A bank and an accelerometer offset look the
same in a_y and r, but not to the dynamic scheme's KF, which compares a_y with the tyre forces of
its model: an offset is in the accelerometer only, while the tyres really push against a bank
(the accelerometer reads them right; gravity pulls the other way). The KF takes s c off its a_y
measurement, s = ``offset_sensor_share``: s = 0 is right for a bank and leaves an offset's whole
error in the KF's measurement (the dominant error: measured, its sideslip error grows with it),
s = 1 the reverse. The two cannot be told apart from these inputs; the shipped 0.4 balances
their worst cases (docs/robustness.md). (Adding the bank's share as gravity to the KF's v_y' was
tried and changed the errors by 2 %: left out.) (Liao & Borrelli, IEEE TVT 2019, separate them with GPS, which the
method's inputs do not have.) ``offset_memory`` = 0 switches it off (the paper).
"""

from __future__ import annotations

import casadi as ca

from vsegen.model.filters import low_pass
from vsegen.model.schema import nonnegative, positive, share
from vsegen.model.signals import Signal

FIELDS = (
    nonnegative("offset_memory", "s", "beyond the paper: time constant of the learned kinematic "
                "offset c, the mean of a_y - r v_x in near-straight driving (a road bank, "
                "accelerometer and gyro biases); the kinematic scheme integrates a_y - r v_x - c; "
                "0 = off (the paper)", default=0.0),
    positive("offset_band", "m/s^2", "the offset is learned only while |a_y,f - c| and |r v_x| are "
             "below this (near-straight driving, where v_y' and the roll and lever-arm terms vanish; "
             "offset_memory > 0 only)", default=0.5),
    share("offset_sensor_share", "beyond the paper: the share s of the learned offset c the KF "
          "takes for an accelerometer offset, off its a_y measurement (the rest is road bank, "
          "which the accelerometer reads right); 0 = all bank, 1 = all sensor; a_y and r cannot "
          "tell the two apart (docs/robustness.md); offset_memory > 0 only", default=0.0),
)
OFFSET = Signal("kin_offset", "m/s^2", "learned kinematic offset c: mean of a_y - r v_x in "
                                      "near-straight driving (offset_memory)")


def enabled(numeric_settings) -> bool:
    """Whether the generated code learns the offset (structural)."""
    return numeric_settings["offset_memory"] > 0.0


def states(numeric_settings) -> tuple[Signal, ...]:
    """The offset's state entry (0 at init), none when it is off."""
    return (OFFSET,) if enabled(numeric_settings) else ()


def near_straight(settings, ay_filtered, r_checked, vx, offset):
    """Whether the offset learns on this sample: |a_y,f - c| and |r v_x| below offset_band (the
    larger of the two, one comparison)."""
    return ca.fmax(ca.fabs(ay_filtered - offset), ca.fabs(r_checked * vx)) < settings["offset_band"]


def learned(settings, sample_time: float, previous, ay, r, vx, learning):
    """c_k from c_k-1 = ``previous`` and the checked a_y, r and the speed, while ``learning``."""
    return low_pass(previous, ay - r * vx, settings["offset_memory"], sample_time, learning)


def update(settings, sample_time: float, previous, pre, vx, allowed):
    """c_k for this sample from c_k-1 = ``previous``, the shared pre-processing ``pre`` (filtered
    and checked a_y, r) and the measured speed ``vx``: learned while ``allowed`` (only on an
    active sample, where v_x is plausible) and :func:`near_straight`."""
    learning = ca.logic_and(allowed, near_straight(settings, pre.ay_filtered, pre.r_checked, vx, previous))
    return learned(settings, sample_time, previous, pre.updates["ay_last"], pre.updates["r_last"], vx, learning)


def sensor_part(settings, offset):
    """s c (s = offset_sensor_share): what the KF takes off its a_y measurement."""
    return settings["offset_sensor_share"] * offset
