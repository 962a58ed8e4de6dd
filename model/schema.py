"""What a vehicle file may contain: every key, its unit, its check and its meaning.

This is the single source of truth for parameter names and their validation. Adding an estimator
adds one :class:`EstimatorSchema` to :data:`ESTIMATOR_SCHEMAS`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np


class Invalid(ValueError):
    """A value failed its check; the message says what was expected."""


@dataclass(frozen=True)
class Field:
    """One key of a table: ``check`` returns the normalised value or raises :class:`Invalid`."""

    key: str
    expected: str
    check: Callable[[Any], Any]
    doc: str = ""
    default: Any = None
    """Value used when the key is absent; None makes the key required."""


@dataclass(frozen=True)
class Rule:
    """A check across keys of one table; ``check`` returns a message (``key = value: expected ...``) or ''."""

    key: str
    check: Callable[[Mapping[str, Any]], str]


@dataclass(frozen=True)
class EstimatorSchema:
    fields: tuple[Field, ...]
    rules: tuple[Rule, ...] = field(default_factory=tuple)


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise Invalid("a number")
    value = float(value)
    if not math.isfinite(value):
        raise Invalid("a finite number")
    return value


def _number_field(key: str, expected: str, accept: Callable[[float], bool], doc: str,
                  default: float | None = None) -> Field:
    """A finite number for which ``accept`` holds."""

    def check(value: Any) -> float:
        try:
            number = _number(value)
        except Invalid:
            raise Invalid(expected) from None
        if not accept(number):
            raise Invalid(expected)
        return number

    return Field(key, expected, check, doc, default)


def positive(key: str, unit: str, doc: str = "", default: float | None = None) -> Field:
    """A finite number > 0 in ``unit`` (optional when ``default`` is given)."""
    return _number_field(key, f"a finite number > 0 ({unit})", lambda x: x > 0.0, doc, default)


def nonnegative(key: str, unit: str, doc: str = "", default: float | None = None) -> Field:
    """A finite number >= 0 in ``unit`` (optional when ``default`` is given)."""
    return _number_field(key, f"a finite number >= 0 ({unit})", lambda x: x >= 0.0, doc, default)


def fraction(key: str, doc: str = "", default: float | None = None) -> Field:
    """A number strictly between 0 and 1 (optional when ``default`` is given)."""
    return _number_field(key, "a number between 0 and 1 (exclusive)", lambda x: 0.0 < x < 1.0, doc,
                         default)


def choice(key: str, options: tuple[str, ...], doc: str = "", default: str | None = None) -> Field:
    """One of a fixed set of strings."""
    expected = "one of " + ", ".join(f'"{o}"' for o in options)

    def check(value: Any) -> str:
        if value not in options:
            raise Invalid(expected)
        return value

    return Field(key, expected, check, doc, default)


def spd_matrix(key: str, size: int, unit: str, doc: str = "") -> Field:
    """A symmetric positive-definite ``size``×``size`` matrix, written either as the list of its
    ``size`` diagonal entries or in full as a list of rows. Normalised to a tuple of row tuples."""
    expected = (f"a symmetric positive-definite {size}x{size} matrix ({unit}): a list of {size} "
                f"positive diagonal entries or {size} rows of {size} numbers")

    def check(value: Any) -> tuple[tuple[float, ...], ...]:
        if not isinstance(value, list) or len(value) != size:
            raise Invalid(expected)
        try:
            if all(isinstance(row, list) for row in value):
                if any(len(row) != size for row in value):
                    raise Invalid(expected)
                matrix = np.array([[_number(v) for v in row] for row in value])
            else:
                matrix = np.diag([_number(v) for v in value])
        except Invalid:
            raise Invalid(expected) from None
        if not np.array_equal(matrix, matrix.T):
            raise Invalid(expected + " (it is not symmetric)")
        if np.min(np.linalg.eigvalsh(matrix)) <= 0.0:
            raise Invalid(expected + " (it is not positive definite)")
        return tuple(tuple(float(v) for v in row) for row in matrix)

    return Field(key, expected, check, doc)


def diagonal(key: str, size: int, unit: str, doc: str = "", zero_allowed: bool = False) -> Field:
    """The ``size`` diagonal entries of a diagonal covariance, each > 0 (or >= 0 when
    ``zero_allowed``). Normalised to a tuple of floats."""
    bound = ">= 0" if zero_allowed else "> 0"
    expected = f"a list of {size} numbers {bound} ({unit}), the diagonal"

    def check(value: Any) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != size:
            raise Invalid(expected)
        try:
            entries = tuple(_number(v) for v in value)
        except Invalid:
            raise Invalid(expected) from None
        if any(v < 0.0 or (v == 0.0 and not zero_allowed) for v in entries):
            raise Invalid(expected)
        return entries

    return Field(key, expected, check, doc)


def integer(key: str, low: int, high: int, doc: str = "") -> Field:
    """A whole number from ``low`` to ``high``; stays an int, so it is structural (baked even in
    calibratable mode)."""
    expected = f"a whole number from {low} to {high}"

    def check(value: Any) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise Invalid(expected)
        return value

    return Field(key, expected, check, doc)


def between(key: str, low: float, high: float, doc: str = "", default: float | None = None) -> Field:
    """A number strictly between ``low`` and ``high``."""
    return _number_field(key, f"a number between {low:g} and {high:g} (exclusive)",
                         lambda x: low < x < high, doc, default)


# ------------------------------------------------------------------------------------------------
# [vehicle]: physical parameters (names fixed: other tools depend on them)

VEHICLE: tuple[Field, ...] = (
    positive("mass", "kg", "vehicle mass m"),
    positive("yaw_inertia", "kg*m^2", "yaw moment of inertia I_z"),
    positive("cg_to_front_axle", "m", "a, CG to front axle"),
    positive("cg_to_rear_axle", "m", "b, CG to rear axle"),
    positive("wheelbase", "m", "l = a + b"),
    positive("cornering_stiffness_front", "N/rad", "C_f, front axle (both tyres), positive"),
    positive("cornering_stiffness_rear", "N/rad", "C_r, rear axle (both tyres), positive"),
    positive("wheel_radius", "m", "effective rolling radius R_eff"),
    positive("track_width", "m", "track width (front = rear)"),
    positive("cg_height", "m", "CG height above ground"),
)

# [inputs]: plausibility limits shared by all estimators. A finite input inside its limit is
# plausible; anything else (NaN, +-Inf, beyond the limit) is rejected with status INVALID_INPUT.
INPUT_LIMITS: tuple[Field, ...] = (
    positive("vx_max", "m/s", "largest plausible |vx|"),
    positive("delta_max", "rad", "largest plausible |delta| (front road-wheel angle)"),
    positive("ax_max", "m/s^2", "largest plausible |ax|"),
    positive("ay_max", "m/s^2", "largest plausible |ay|"),
    positive("r_max", "rad/s", "largest plausible |r|"),
    positive("mz_max", "N*m", "largest plausible |mz| (direct yaw moment)", default=2.0e4),
    positive("omega_max", "rad/s", "largest plausible |omega| of a wheel speed", default=400.0),
)

# [plant]: the truth plant of harness/plant (simulation only; never in generated code). Optional.
PLANT: tuple[Field, ...] = (
    positive("tyre_nominal_load", "N", "F_z0 of the Magic Formula load law"),
    positive("tyre_cornering_factor", "-", "p_Ky1: peak of K_y/F_z0 in K_y = p_Ky1 F_z0 sin(2 atan(F_z/(p_Ky2 F_z0)))"),
    positive("tyre_cornering_load_factor", "-", "p_Ky2: load at peak K_y, in units of F_z0"),
    positive("tyre_slip_stiffness_factor", "-", "K_x / F_z: longitudinal slip stiffness per unit load"),
    positive("tyre_shape_lateral", "-", "Magic Formula shape factor C_y"),
    positive("tyre_shape_longitudinal", "-", "Magic Formula shape factor C_x"),
    positive("wheel_inertia_front", "kg*m^2", "spin inertia of one front wheel incl. driveline share"),
    positive("wheel_inertia_rear", "kg*m^2", "spin inertia of one rear wheel"),
    choice("driven_axle", ("front", "rear"), "axle the drive torque goes to"),
    nonnegative("roll_gradient", "rad/(m/s^2)", "body roll per lateral acceleration (quasi-static)"),
    nonnegative("pitch_gradient", "rad/(m/s^2)", "body pitch per longitudinal deceleration (quasi-static)"),
    fraction("roll_stiffness_front_share", "share of lateral load transfer taken by the front axle"),
    positive("load_transfer_time_constant", "s", "lag of load transfer behind the accelerations"),
    nonnegative("drag_area", "m^2", "C_d * A"),
    nonnegative("rolling_resistance", "-", "rolling-resistance coefficient"),
)

# [sensors]: the sensor model of simulated logs (seed 000 Table 2). Optional.
SENSORS: tuple[Field, ...] = (
    nonnegative("gyro_noise", "rad/s", "yaw-rate white noise, 1 sigma"),
    nonnegative("gyro_bias", "rad/s", "yaw-rate bias (used only by scenarios with bias = true)"),
    nonnegative("accel_noise", "m/s^2", "accelerometer white noise, 1 sigma"),
    nonnegative("accel_bias", "m/s^2", "accelerometer bias (used only with bias = true)"),
    nonnegative("wheel_speed_noise", "rad/s", "wheel-speed white noise, 1 sigma"),
)

# [codegen]: how the C is generated for this vehicle (command-line options override). Optional.
REALS = ("double", "float")
PARAMETER_MODES = ("baked", "calibratable")
CODEGEN: tuple[Field, ...] = (
    choice("real", REALS, "C floating-point type of the generated code", default="double"),
    choice("params", PARAMETER_MODES, "parameters as literals (baked) or read at run time from a "
           "const calibration struct (calibratable)", default="baked"),
)

# [estimator]: common to all estimators of the file
SAMPLING: tuple[Field, ...] = (
    positive("sample_time", "s", "estimator sample time T (0.01 s = 100 Hz by default)"),
)

DISCRETISATIONS = ("euler", "tustin", "zoh")


def above(key: str, lower: str, what: str, unit: str = "") -> Rule:
    """Rule: ``key`` must be greater than the table's ``lower`` (``what`` names the value)."""
    def check(settings: Mapping[str, Any]) -> str:
        if settings[key] <= settings[lower]:
            return (f"{key} = {settings[key]!r}: expected {what} above "
                    f"{lower} = {settings[lower]!r}{' ' + unit if unit else ''}")
        return ""
    return Rule(key, check)


def below(key: str, upper: str, what: str, unit: str = "") -> Rule:
    """Rule: ``key`` must be smaller than the table's ``upper``."""
    def check(settings: Mapping[str, Any]) -> str:
        if settings[key] >= settings[upper]:
            return (f"{key} = {settings[key]!r}: expected {what} below "
                    f"{upper} = {settings[upper]!r}{' ' + unit if unit else ''}")
        return ""
    return Rule(key, check)


LOW_SPEED_FIELDS: tuple[Field, ...] = (
    positive("vx_min", "m/s", "below this speed the estimator holds (status LOW_SPEED)"),
    positive("vx_resume", "m/s", "after a low-speed hold, resume at or above this speed"),
)
LOW_SPEED_RULES: tuple[Rule, ...] = (above("vx_resume", "vx_min", "a speed", "m/s (hysteresis)"),)

KF_FIELDS: tuple[Field, ...] = (
    choice("discretisation", DISCRETISATIONS, "method turning A, B into Phi, Gamma"),
    spd_matrix("process_noise", 2, "continuous PSD of [vy, r]: (m/s^2)^2*s, (rad/s^2)^2*s",
               "Q_c; the discrete Q_d = Q_c*T"),
    spd_matrix("measurement_noise", 2, "[ay, r]: (m/s^2)^2, (rad/s)^2", "R"),
    spd_matrix("initial_covariance", 2, "[vy, r]: (m/s)^2, (rad/s)^2",
               "P_0, also the covariance after a hold and at a kinematic-to-dynamic hand-off"),
    *LOW_SPEED_FIELDS,
)
"""The 2-DOF Kalman filter's settings, shared by every estimator that runs it."""

KF2DOF = EstimatorSchema(fields=KF_FIELDS, rules=LOW_SPEED_RULES)

ROLL_CORRECTION = nonnegative(
    "roll_gradient", "rad/(m/s^2)", "body roll per lateral acceleration, to remove the gravity "
    "component a body-fixed accelerometer reads: a_y = a_y,m / (1 + g k); 0 = none (the paper's "
    "literal a_y)", default=0.0)
"""The roll correction of a_y (model.sensors) that seed 000's estimators, ekf_rls and the particle
filters share."""

SEED000_FIELDS: tuple[Field, ...] = (
    choice("prefilter", ("printed", "bessel"), "a_y prefilter: the paper's printed "
           "10000/(s^2+200s+10000) or a phase-normalised 2nd-order Bessel at prefilter_omega"),
    positive("prefilter_omega", "rad/s", "Bessel cut-off (prefilter = \"bessel\" only)"),
    positive("median_span", "s", "median window span (odd length 2 round(span/2T) + 1)"),
    positive("yaw_rate_band", "rad/s", "half-width of the credible band around r_ref"),
    positive("lateral_acceleration_band", "m/s^2", "half-width of the band around vx r"),
    positive("reference_timeout", "s", "after this long of continuous rejection, accept again"),
    positive("threshold", "m/s^2", "switching threshold a_yT on |a_y,f|"),
    ROLL_CORRECTION,
)
"""Seed 000's pre-processing and switching settings (000-switch-sideslip.md §3)."""



SWITCHING = EstimatorSchema(
    fields=(*KF_FIELDS, *SEED000_FIELDS,
            nonnegative("hysteresis", "m/s^2", "beyond the paper (A7): enter the kinematic "
                        "scheme above threshold + hysteresis, leave it below threshold - "
                        "hysteresis; 0 = the paper's single threshold", default=0.0),
            nonnegative("adaptive_memory", "s", "beyond the paper (A10): time constant of the "
                        "memory of the peak |a_y,f| the road has carried; the threshold rises to "
                        "adaptive_fraction times that peak, at most adaptive_max; 0 = off "
                        "(the paper's fixed threshold)", default=0.0),
            fraction("adaptive_fraction", "share of the remembered peak |a_y,f| used as the "
                     "threshold (adaptive_memory > 0 only)", default=0.8),
            positive("adaptive_max", "m/s^2", "upper bound of the adaptive threshold "
                     "(adaptive_memory > 0 only)", default=2.5)),
    rules=(*LOW_SPEED_RULES, below("hysteresis", "threshold", "a number >= 0", "m/s^2")))
FUSION = EstimatorSchema(
    fields=(*KF_FIELDS, *SEED000_FIELDS,
            positive("integral_gain", "1/s", "k_c: integral correction of the kinematic "
                     "integrator towards the KF")),
    rules=LOW_SPEED_RULES)

ARX_DUAL_KF = EstimatorSchema(
    fields=(
        choice("exogenous", ("mz", "mz_delta"), "ARX inputs: the patent's direct yaw moment, or "
               "also the steer angle (E2)"),
        positive("measurement_noise", "(rad/s)^2", "R: gyro noise variance"),
        positive("model_noise", "(rad/s)^2", "Q: variance of the ARX model error e_n per step"),
        positive("ar_drift", "-", "Q_theta of a1 and a2 per step"),
        positive("input_drift", "-", "Q_theta of an input parameter = (input_drift b)^2 per step"),
        positive("ar_initial_variance", "-", "P_theta,0 of a1 and a2"),
        positive("input_initial_factor", "-", "P_theta,0 of an input parameter = (factor b)^2"),
        fraction("stability_radius", "largest root radius of z^2 - a1 z - a2 (E5)"),
        positive("excitation_floor", "-", "skip the parameter update when phi' P phi is below"),
        *LOW_SPEED_FIELDS,
    ),
    rules=LOW_SPEED_RULES)
"""Seed 004's ARX dual Kalman filter (004-arx-dual-kf-yaw-rate.md §3, §5)."""

EKF_RLS = EstimatorSchema(
    fields=(
        choice("stiffness", ("rls", "constant"), "cornering stiffness: estimated online (the "
               "method) or the vehicle file's C_f, C_r (the plain EKF)"),
        choice("weighting", ("stiffness_rate", "integral_only"), "fusion weight lambda: from the "
               "stiffness rate (the method) or 1 (the integral method alone)"),
        choice("stiffness_regressor", ("literal", "ekf_slip", "kinematic_slip"), "RLS regression: "
               "side-wise over alpha_eq = |delta - L r / vx| (the paper), or per axle over the slip "
               "angles of the EKF prior (B2) or of the integral method (forces and slip angles "
               "low-passed alike)"),
        spd_matrix("process_noise", 2, "[beta, r]: rad^2*s, (rad/s)^2*s", "Q_c; Q_d = Q_c*T"),
        positive("measurement_noise", "(rad/s)^2", "R: gyro noise variance"),
        spd_matrix("initial_covariance", 2, "[beta, r]: rad^2, (rad/s)^2", "P_0 of the EKF"),
        fraction("forgetting_factor", "RLS forgetting factor per 1 ms (rescaled to T)"),
        positive("rls_initial_covariance", "1/rad^2", "P_RLS,0 = this times I"),
        positive("rls_covariance_max", "1/rad^2", "bound on trace(P_RLS) (wind-up guard)"),
        positive("slip_min", "rad", "update the RLS only while alpha_eq (per-axle regressors: both "
                 "|slip angles|) is at least this"),
        positive("stiffness_min", "-", "lower clamp of C0 as a factor of C0_nom"),
        positive("stiffness_max", "-", "upper clamp of C0 as a factor of C0_nom"),
        positive("derivative_time_constant", "s", "tau_d of the filtered yaw acceleration, and of "
                 "the low-pass of kinematic_slip"),
        positive("indicator_time_constant", "s", "tau_D of the low-passed stiffness rate"),
        nonnegative("indicator_low", "1/s", "D_1: lambda = 0 below"),
        positive("indicator_high", "1/s", "D_2: lambda = 1 above"),
        ROLL_CORRECTION,
        *LOW_SPEED_FIELDS,
    ),
    rules=(*LOW_SPEED_RULES, above("indicator_high", "indicator_low", "a rate", "1/s"),
           above("stiffness_max", "stiffness_min", "a factor")))
"""Seed 001's EKF with RLS stiffness and stiffness-rate fusion (001-stiffness-rate-fusion.md §3,
§5)."""

def _caps_above_floors(table: Mapping[str, Any]) -> str:
    if all(high > low for high, low in zip(table["process_noise_max"], table["process_noise"])):
        return ""
    return (f"process_noise_max = {list(table['process_noise_max'])!r}: expected every entry "
            f"above its process_noise entry {list(table['process_noise'])!r}")


CAPS_ABOVE_FLOORS = Rule("process_noise_max", _caps_above_floors)
"""An adaptive noise's ceilings lie above its floors, entry by entry (aukf, the particle filters)."""

UKF_FIELDS: tuple[Field, ...] = (
    choice("longitudinal_force", ("wheel_speeds", "free_rolling"), "tyre slip ratios from the "
           "measured wheel speeds (C4.1) or free rolling with a_x a random walk (C4.2)"),
    positive("friction", "-", "road friction mu of the HSRI model (known, C9)"),
    positive("longitudinal_stiffness", "N", "C_x per tyre, N per unit slip (the cornering "
             "stiffness per tyre is half the [vehicle] axle value)"),
    nonnegative("drag_area", "m^2", "C_d A of the drag F_w = 1.2 C_dA u^2 / 2 (0 = none, the "
                "paper)"),
    positive("slip_speed_floor", "m/s", "eps_v: slip ratios divide by max(r omega, eps_v)"),
    _number_field("ut_alpha", "a number in (0, 1]", lambda x: 0.0 < x <= 1.0,
                  "UT spread alpha"),
    nonnegative("ut_beta", "-", "UT prior-distribution factor beta (2 for Gaussian)"),
    nonnegative("ut_kappa", "-", "UT secondary scaling kappa"),
    diagonal("initial_covariance", 6, "[u, v, gamma, Gamma, a_x, a_y]: SI units squared", "P_0",
             zero_allowed=True),
    diagonal("process_noise", 6, "SI units squared per step", "Q (Q_0 of the adaptive filter)"),
    diagonal("measurement_noise", 3, "[a_x, a_y, gamma]: (m/s^2)^2, (m/s^2)^2, (rad/s)^2", "R"),
    nonnegative("restart_speed_error", "m/s", "beyond the spec: restart the filter from the "
                "current sample when |u - v_x| exceeds this (status FILTER_RESTARTED); 0 = never"),
    nonnegative("restart_sideslip", "rad", "beyond the spec: restart when |atan2(v, u)| exceeds "
                "this; 0 = never"),
    *LOW_SPEED_FIELDS,
)
"""Seed 002's UKF on the 3-DOF HSRI model (002-aukf-sage-husa.md §3, §5)."""

UKF = EstimatorSchema(fields=UKF_FIELDS, rules=LOW_SPEED_RULES)
AUKF = EstimatorSchema(
    fields=(*UKF_FIELDS, between("forgetting_factor", 0.95, 0.99, "Sage-Husa fading factor f "
                                 "(the paper: 0.95 < f < 0.99)"),
            choice("noise_safeguard", ("floor", "none"), "Sage-Husa safeguard: Q_ii >= 1e-3 "
                   "Q_0,ii (the spec's §2.10) or none (the literal (15b): Q may turn negative and "
                   "the covariance lose positive definiteness, which the repair then catches)"),
            diagonal("process_noise_max", 6, "SI units squared per step", "ceiling of the adapted "
                     "Q (beyond the spec: without it abusive inputs, e.g. a_y alternating "
                     "+-25 m/s^2, grow Q and P until they overflow)")),
    rules=(*LOW_SPEED_RULES, CAPS_ABOVE_FLOORS))

PF_FIELDS: tuple[Field, ...] = (
    integer("particles", 2, 10000, "N, the particle count (fixed at generation time; the state "
            "holds 6 N reals)"),
    integer("seed", 0, 2 ** 32 - 1, "seed of the filter's PCG32 random stream"),
    choice("observation", ("inertial", "wheel_speed"), "z = [a_x, a_y, r] (the paper's (13)) or "
           "also the logged v_x (D2)"),
    choice("resampling", ("every_sample", "effective_size"), "systematic resampling at every "
           "sample (D4 default) or only when N_eff < N / 2"),
    diagonal("measurement_noise", 3, "[a_x, a_y, r]: m/s^2, m/s^2, rad/s", "R as standard "
             "deviations sigma_ax,m, sigma_ay,m, sigma_r,m (1 sigma)"),
    positive("wheel_speed_noise", "m/s", "sigma_vx,w of the logged v_x (observation = "
             "\"wheel_speed\" only)"),
    diagonal("initial_spread", 2, "[v_x, v_y]: m/s", "1-sigma spread of the initial particles' "
             "speeds (2.9)"),
    diagonal("process_noise", 3, "[a_x, a_y, r] per sample: m/s^2, m/s^2, rad/s", "sigma_ax,0, "
             "sigma_ay,0, sigma_r,0: random-walk step at rest (16)"),
    diagonal("process_noise_max", 3, "[a_x, a_y, r] per sample: m/s^2, m/s^2, rad/s", "caps "
             "sigma_ax,max, sigma_ay,max, sigma_r,max of the adapted random walk (16)"),
    diagonal("speed_noise", 2, "[v_x, v_y] per sample: m/s", "sigma_vx,0, sigma_vy,0 (16)"),
    nonnegative("adaptation_gain_acceleration", "-", "kappa_a of (16); 0 = no adaptation"),
    nonnegative("adaptation_gain_yaw_rate", "-", "kappa_r of (16); 0 = no adaptation"),
    ROLL_CORRECTION,
    *LOW_SPEED_FIELDS,
)
"""Seed 003's particle filter: the adaptive PF of its ref. [17] (003-improved-pf-velocity.md §2,
§3, §5)."""


PF_RULES = (*LOW_SPEED_RULES, CAPS_ABOVE_FLOORS)
PF_ADAPTIVE = EstimatorSchema(fields=PF_FIELDS, rules=PF_RULES)
PF_IMPROVED = EstimatorSchema(
    fields=(*PF_FIELDS,
            diagonal("correction_gain", 3, "-, each at most 1", "G of the proposal correction "
                     "(14): the share of z - [a_x, a_y, r] of each particle it moves towards the "
                     "measurement per sample", zero_allowed=True),
            choice("weights", ("likelihood", "exact_importance"), "the paper's likelihood-only "
                   "weights (D3) or the exact importance ratio of the corrected proposal")),
    rules=(*PF_RULES, Rule("correction_gain", lambda t: "" if max(t["correction_gain"]) <= 1.0
                           else f"correction_gain = {list(t['correction_gain'])!r}: expected "
                                "every entry from 0 to 1")))

ESTIMATOR_SCHEMAS: dict[str, EstimatorSchema] = {
    "kf2dof": KF2DOF,
    "switching": SWITCHING,
    "fusion": FUSION,
    "arx_dual_kf": ARX_DUAL_KF,
    "ekf_rls": EKF_RLS,
    "ukf": UKF,
    "aukf": AUKF,
    "pf_adaptive": PF_ADAPTIVE,
    "pf_improved": PF_IMPROVED,
}
