"""Status bits every estimator reports in its ``status`` output (an integer, bits OR-ed; 0 = OK).

Part of the signal catalogue (model/signals.py): the C headers and docs/conventions.md take each
bit's value and meaning from :data:`STATUS_BITS`.
"""

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

STATUS_BITS = {
    "LOW_SPEED": (LOW_SPEED, "vx below the low-speed limit (or not yet back above the resume speed): "
                             "the estimator holds"),
    "INVALID_INPUT": (INVALID_INPUT, "an input was NaN, +-Inf or beyond its plausibility limit: the "
                                     "estimator holds, the input is ignored"),
    "REFERENCE_SUSPECT": (REFERENCE_SUSPECT, "a reliability check rejected a measurement for longer than "
                                             "its time-out and accepted it again: the reference (e.g. the "
                                             "steady-state yaw rate) is suspect"),
    "PARAMETERS_PROJECTED": (PARAMETERS_PROJECTED, "identified model parameters left the stable set and "
                                                   "were projected back onto it"),
    "COVARIANCE_REPAIRED": (COVARIANCE_REPAIRED, "the state covariance was not positive definite; it was "
                                                 "repaired (correlations dropped, variances kept) before use"),
    "FILTER_RESTARTED": (FILTER_RESTARTED, "the estimate left the plausible envelope (speed far from the "
                                           "measured one, or an implausible sideslip angle); the filter "
                                           "restarted from this sample"),
    "KINEMATIC_DWELL_LIMITED": (KINEMATIC_DWELL_LIMITED, "the kinematic scheme reached its maximum dwell "
                                                         "with |a_y| still above the threshold: the model-based "
                                                         "scheme runs beyond its linear range until |a_y| falls"),
    "MODEL_INCONSISTENT": (MODEL_INCONSISTENT, "the measurements disagree with the model's predictions "
                                               "(mean squared innovation above residual_limit sensor "
                                               "variances over residual_window): the estimate is suspect"),
    "BEYOND_LINEAR_RANGE": (BEYOND_LINEAR_RANGE, "the lateral acceleration is beyond linear_range, where "
                                                 "the estimate rests on the tyre model (linear, or with a "
                                                 "friction coefficient the road may not offer): the "
                                                 "estimate is suspect"),
    "INVALID_CALIBRATION": (INVALID_CALIBRATION, "the calibration struct breaks a check of the vehicle-file "
                                                 "schema (e.g. a mass <= 0): the estimator holds, outputs 0 "
                                                 "(calibratable builds)"),
    "DEAD_RECKONING": (DEAD_RECKONING, "v_y is integrated without a measurement and its error bound "
                                       "(drift_acceleration plus the speed times drift_yaw_rate, integrated "
                                       "since the particles were drawn) exceeds the speed times "
                                       "tan(drift_limit): beta is suspect"),
}
"""Every status bit by name: (value, meaning)."""
