"""Status bits every estimator reports in its ``status`` output (an integer, bits OR-ed)."""

OK = 0
LOW_SPEED = 1
"""vx below the low-speed limit (or not yet back above the resume speed): estimator holds."""
INVALID_INPUT = 2
"""An input was NaN, +-Inf or beyond its plausibility limit: estimator holds, the input is ignored."""

REFERENCE_SUSPECT = 4
"""A reliability check rejected its measurement for longer than its time-out and accepted it
again: the reference (e.g. the steady-state yaw rate) is suspect."""

PARAMETERS_PROJECTED = 8
"""Identified model parameters left the stable set and were projected back onto it."""
COVARIANCE_REPAIRED = 16
"""The state covariance was not positive definite; it was repaired (correlations dropped, variances
kept) before the step used it."""
FILTER_RESTARTED = 32
"""The estimate left the plausible envelope (speed far from the measured one, or an implausible
sideslip angle); the filter restarted from this sample."""
STATUS_BITS = {"LOW_SPEED": LOW_SPEED, "INVALID_INPUT": INVALID_INPUT,
               "REFERENCE_SUSPECT": REFERENCE_SUSPECT, "PARAMETERS_PROJECTED": PARAMETERS_PROJECTED,
               "COVARIANCE_REPAIRED": COVARIANCE_REPAIRED, "FILTER_RESTARTED": FILTER_RESTARTED}
