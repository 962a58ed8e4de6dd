"""Status bits every estimator reports in its ``status`` output (an integer, bits OR-ed; 0 = OK).

Part of the signal catalogue (model/signals.py): the C headers and docs/signals.md take each
bit's value and meaning from :data:`BITS`; an estimator declares the bits it can raise by these
constants (``model.estimator.Definition.status_bits``).
"""

from dataclasses import dataclass

OK = 0
LOW_SPEED = 1
INVALID_INPUT = 2
REFERENCE_SUSPECT = 4
PARAMETERS_PROJECTED = 8
COVARIANCE_REPAIRED = 16
FILTER_RESTARTED = 32
KINEMATIC_DWELL_LIMITED = 64
MODEL_INCONSISTENT = 128
BEYOND_LINEAR_RANGE = 256
INVALID_CALIBRATION = 512
DEAD_RECKONING = 1024
INPUT_FROZEN = 2048
SCHEMES_DISAGREE = 4096
LATERAL_INCONSISTENT = 8192
STEERING_OFFSET = 16384
YAW_RATE_MISMATCH = 32768


@dataclass(frozen=True)
class StatusBit:
    """One status bit: its name (the C macro's suffix), value and meaning."""

    name: str
    value: int
    meaning: str


BITS: tuple[StatusBit, ...] = (
    StatusBit("LOW_SPEED", LOW_SPEED,
              "vx below the low-speed limit (or not yet back above the resume speed): the estimator "
              "holds"),
    StatusBit("INVALID_INPUT", INVALID_INPUT,
              "an input was NaN, +-Inf or beyond its plausibility limit: the estimator holds, the input "
              "is ignored"),
    StatusBit("REFERENCE_SUSPECT", REFERENCE_SUSPECT,
              "a reliability check rejected a measurement for longer than its time-out and accepted it "
              "again: the reference (e.g. the steady-state yaw rate) is suspect"),
    StatusBit("PARAMETERS_PROJECTED", PARAMETERS_PROJECTED,
              "identified model parameters left the stable set and were projected back onto it"),
    StatusBit("COVARIANCE_REPAIRED", COVARIANCE_REPAIRED,
              "the state covariance was not positive definite; it was repaired (correlations dropped, "
              "variances kept) before use"),
    StatusBit("FILTER_RESTARTED", FILTER_RESTARTED,
              "the estimate left the plausible envelope (speed far from the measured one, or an "
              "implausible sideslip angle); the filter restarted from this sample"),
    StatusBit("KINEMATIC_DWELL_LIMITED", KINEMATIC_DWELL_LIMITED,
              "the kinematic scheme reached its maximum dwell with |a_y| still above the threshold: the "
              "model-based scheme runs beyond its linear range until |a_y| falls"),
    StatusBit("MODEL_INCONSISTENT", MODEL_INCONSISTENT,
              "the measurements disagree with the model's predictions (mean squared innovation above "
              "residual_limit sensor variances over residual_window): the estimate is suspect"),
    StatusBit("BEYOND_LINEAR_RANGE", BEYOND_LINEAR_RANGE,
              "the lateral acceleration is beyond linear_range, where the estimate rests on the tyre "
              "model (linear, or with a friction coefficient the road may not offer): the estimate is "
              "suspect"),
    StatusBit("INVALID_CALIBRATION", INVALID_CALIBRATION,
              "the calibration struct breaks a check of the vehicle-file schema (e.g. a mass <= 0): the "
              "estimator holds, outputs 0 (calibratable builds)"),
    StatusBit("DEAD_RECKONING", DEAD_RECKONING,
              "v_y is integrated without a measurement and its error bound (drift_acceleration plus the "
              "speed times drift_yaw_rate, integrated since the particles were drawn) exceeds the speed "
              "times tan(drift_limit): beta is suspect"),
    StatusBit("INPUT_FROZEN", INPUT_FROZEN,
              "an inertial input (a_x, a_y or r) has repeated its value bit for bit for frozen_time, or "
              "the path curvature changed at a constant steer angle (steer_check_limit): a stuck sensor "
              "or CAN signal; the estimate is suspect"),
    StatusBit("SCHEMES_DISAGREE", SCHEMES_DISAGREE,
              "the kinematic and the model-based scheme disagree by more than disagreement_limit in "
              "their share of the output (a road bank, a sensor offset, a frozen or late signal, or a "
              "model error): the estimate is suspect"),
    StatusBit("LATERAL_INCONSISTENT", LATERAL_INCONSISTENT,
              "in quasi-steady driving the lateral acceleration differs from r v_x by more than "
              "lateral_check_limit on average: a road bank, an accelerometer offset or mounting tilt, "
              "a yaw-rate or speed error; the estimate is suspect"),
    StatusBit("STEERING_OFFSET", STEERING_OFFSET,
              "the steering-angle zero learned in straight driving (steering_offset) is beyond "
              "steering_offset_limit: the steering-angle sensor needs its zero calibrated; the "
              "model-based estimate is suspect"),
    StatusBit("YAW_RATE_MISMATCH", YAW_RATE_MISMATCH,
              "the yaw rate differs from the non-driven wheels' speed difference by more than "
              "wheel_check_limit on average: a gyro offset, drift or freeze, or a wheel-speed fault; "
              "the estimate is suspect"),
)
"""Every status bit, in value order."""
BY_VALUE: dict[int, StatusBit] = {bit.value: bit for bit in BITS}


def described(values) -> tuple[StatusBit, ...]:
    """The StatusBit of each value in ``values`` (status constants), in the order given."""
    return tuple(BY_VALUE[value] for value in values)
