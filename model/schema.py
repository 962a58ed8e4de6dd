"""What a vehicle file may contain: every key, its unit, its check and its meaning.

This is the validation vocabulary (field kinds, cross-key rules) and the tables every vehicle file
has ([vehicle], [inputs], [plant], [sensors], [codegen], sampling); each estimator declares its own
``[estimator.<name>]`` :class:`EstimatorSchema` in its module (``model/estimators/``) from these
pieces.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsegen.model import signals


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
    bounds: tuple[tuple[str, float], ...] = ()
    """What ``check`` asks of every number of the value, as (operator, bound) pairs, e.g.
    ((">", 0.0),): the calibration checks the generated C repeats at run time."""
    positive_definite: bool = False
    """A symmetric matrix that must be positive definite (also checked at run time)."""
    unit: str = ""
    """The value's unit, as the vehicle file reference writes it (e.g. "kg", "(m/s)^2"); "-" for a
    ratio, "" where the key is not a number (e.g. a choice)."""


@dataclass(frozen=True)
class Rule:
    """A check across keys of one table; ``check`` returns a message (``key = value: expected ...``) or ''."""

    key: str
    check: Callable[[Mapping[str, Any]], str]
    relation: tuple[str, str, str | float] | None = None
    """(key, operator, other key or number) when the rule compares numbers, entry by entry for
    lists (checked at run time too)."""


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


def number_field(key: str, expected: str, accept: Callable[[float], bool], doc: str,
                  default: float | None = None, bounds: tuple[tuple[str, float], ...] = (),
                  unit: str = "-") -> Field:
    """A finite number in ``unit`` for which ``accept`` holds (``bounds``: the same as operator
    pairs)."""

    def check(value: Any) -> float:
        try:
            number = _number(value)
        except Invalid:
            raise Invalid(expected) from None
        if not accept(number):
            raise Invalid(expected)
        return number

    return Field(key, expected, check, doc, default, bounds, unit=unit)


PHYSICAL_MAXIMUM = {
    "kg": 1e5, "kg*m^2": 1e7, "m": 100.0, "N/rad": 1e8, "N": 1e8, "N*m": 1e7, "m/s": 200.0, "m/s^2": 1e3,
    "rad": 10.0, "rad/s": 1e4, "rad/s^2": 1e5, "rad/(m/s^2)": 1.0, "s": 1e4, "Hz": 1e3, "m^2": 100.0,
    "1/s": 1e4, "1/rad^2": 1e12, "-": 1e6, "(rad/s)^2": 1e6,
}
"""The largest magnitude a setting in a unit may have: beyond any vehicle (a 100 t truck, 200 m/s)
yet far inside float range, so a calibration can never overflow the estimator's arithmetic. The
generated C of a calibratable build checks these bounds at run time too (and the A2L file gives
them as limits)."""
COMPOUND_MAXIMUM = 1e12
"""The same for a setting whose entries have mixed units (covariances: a yaw moment's variance
reaches 1e8 (N*m)^2)."""


SMALLEST_SIGMA = 1e-6
"""The smallest 1-sigma noise a setting the code divides by may take (in its unit: m/s^2, rad/s):
far below any vehicle sensor, and its square stays a normal float."""


def physical_maximum(unit: str) -> float:
    """The largest magnitude of a setting in ``unit`` (:data:`PHYSICAL_MAXIMUM`)."""
    return PHYSICAL_MAXIMUM.get(unit, COMPOUND_MAXIMUM)


def positive(key: str, unit: str, doc: str = "", default: float | None = None,
             minimum: float | None = None) -> Field:
    """A number in ``unit`` above 0 (at least ``minimum``, the smallest physical value, when given)
    and at most the unit's physical maximum (optional when ``default`` is given)."""
    high = physical_maximum(unit)
    if minimum is None:
        return number_field(key, f"a finite number > 0 and <= {high:g} ({unit})", lambda x: 0.0 < x <= high,
                            doc, default, ((">", 0.0), ("<=", high)), unit)
    return number_field(key, f"a number from {minimum:g} to {high:g} ({unit})", lambda x: minimum <= x <= high,
                        doc, default, ((">=", minimum), ("<=", high)), unit)


def nonnegative(key: str, unit: str, doc: str = "", default: float | None = None) -> Field:
    """A number >= 0 in ``unit``, at most the unit's physical maximum (optional when ``default``
    is given)."""
    high = physical_maximum(unit)
    return number_field(key, f"a finite number >= 0 and <= {high:g} ({unit})", lambda x: 0.0 <= x <= high,
                        doc, default, ((">=", 0.0), ("<=", high)), unit)


def fraction(key: str, doc: str = "", default: float | None = None) -> Field:
    """A number strictly between 0 and 1 (optional when ``default`` is given)."""
    return number_field(key, "a number between 0 and 1 (exclusive)", lambda x: 0.0 < x < 1.0, doc,
                        default, ((">", 0.0), ("<", 1.0)))


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
    high = physical_maximum(unit)
    expected = (f"a symmetric positive-definite {size}x{size} matrix ({unit}): a list of {size} "
                f"positive diagonal entries or {size} rows of {size} numbers, each at most {high:g} in magnitude")

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
        if np.max(np.abs(matrix)) > high:
            raise Invalid(expected)
        if not np.array_equal(matrix, matrix.T):
            raise Invalid(expected + " (it is not symmetric)")
        if np.min(np.linalg.eigvalsh(matrix)) <= 0.0:
            raise Invalid(expected + " (it is not positive definite)")
        return tuple(tuple(float(v) for v in row) for row in matrix)

    return Field(key, expected, check, doc, bounds=((">=", -high), ("<=", high)), positive_definite=True, unit=unit)


def diagonal(key: str, size: int, unit: str, doc: str = "", zero_allowed: bool = False,
             default: tuple[float, ...] | None = None, minimum: float = 0.0,
             entries: str = "the diagonal") -> Field:
    """The ``size`` diagonal entries of a diagonal covariance, each > 0 (or >= 0 when
    ``zero_allowed``; at least ``minimum`` when given, e.g. a noise sigma the code divides by), or
    other positive numbers (``entries`` says what they are, e.g. "front, rear").
    Normalised to a tuple of floats."""
    low = (">=", minimum) if minimum > 0.0 else (">=" if zero_allowed else ">", 0.0)
    bound = f"{low[0]} {low[1]:g}"
    high = physical_maximum(unit)
    expected = f"a list of {size} numbers {bound} and <= {high:g} ({unit}), {entries}"

    def check(value: Any) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != size:
            raise Invalid(expected)
        try:
            entries = tuple(_number(v) for v in value)
        except Invalid:
            raise Invalid(expected) from None
        if any(v < max(minimum, 0.0) or (v == 0.0 and not zero_allowed) or v > high for v in entries):
            raise Invalid(expected)
        return entries

    return Field(key, expected, check, doc, default, (low, ("<=", high)), unit=unit)


def vector(key: str, size: int, unit: str, doc: str = "",
           default: tuple[float, ...] | None = None) -> Field:
    """``size`` finite numbers in ``unit`` (e.g. a position). Normalised to a tuple of floats."""
    expected = f"a list of {size} finite numbers ({unit})"

    def check(value: Any) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != size:
            raise Invalid(expected)
        try:
            return tuple(_number(v) for v in value)
        except Invalid:
            raise Invalid(expected) from None

    return Field(key, expected, check, doc, default, unit=unit)


def integer(key: str, low: int, high: int, doc: str = "") -> Field:
    """A whole number from ``low`` to ``high``; stays an int, so it is structural (baked even in
    calibratable mode)."""
    expected = f"a whole number from {low} to {high}"

    def check(value: Any) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise Invalid(expected)
        return value

    return Field(key, expected, check, doc, unit="-")


def share(key: str, doc: str = "", default: float | None = None) -> Field:
    """A number from 0 to 1, both included."""
    return number_field(key, "a number from 0 to 1", lambda x: 0.0 <= x <= 1.0, doc, default,
                        ((">=", 0.0), ("<=", 1.0)))


def between(key: str, low: float, high: float, doc: str = "", default: float | None = None) -> Field:
    """A number strictly between ``low`` and ``high``."""
    return number_field(key, f"a number between {low:g} and {high:g} (exclusive)",
                        lambda x: low < x < high, doc, default, ((">", low), ("<", high)))


# ------------------------------------------------------------------------------------------------
# [vehicle]: physical parameters (names fixed: other tools depend on them)

VEHICLE: tuple[Field, ...] = (
    positive("mass", "kg", "vehicle mass m", minimum=10.0),
    positive("yaw_inertia", "kg*m^2", "yaw moment of inertia I_z", minimum=1.0),
    positive("cg_to_front_axle", "m", "a, CG to front axle", minimum=0.01),
    positive("cg_to_rear_axle", "m", "b, CG to rear axle", minimum=0.01),
    positive("wheelbase", "m", "l = a + b", minimum=0.1),
    positive("cornering_stiffness_front", "N/rad", "C_f, front axle (both tyres), positive", minimum=100.0),
    positive("cornering_stiffness_rear", "N/rad", "C_r, rear axle (both tyres), positive", minimum=100.0),
    positive("wheel_radius", "m", "effective rolling radius R_eff", minimum=0.01),
    positive("track_width", "m", "track width (front = rear)", minimum=0.1),
    positive("cg_height", "m", "CG height above ground", minimum=0.01),
)
"""Physical bounds: from a 10 kg robot car to a 100 t truck (PHYSICAL_MAXIMUM)."""

# [inputs]: plausibility limits shared by all estimators. A finite input inside its limit is
# plausible; anything else (NaN, +-Inf, beyond the limit) is rejected with status INVALID_INPUT.
INPUT_LIMITS: tuple[Field, ...] = tuple(
    positive(key, entries[0].signal.unit, f"largest plausible |{'|, |'.join(e.name for e in entries)}|",
             default=entries[0].limit_default)
    for key, entries in signals.inputs_by_limit().items())
"""[inputs]: one plausibility limit per input (wheel speeds share one), from model.signals."""

# [plant]: the truth plant of harness/sim (simulation only; never in generated code). Optional.
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
    nonnegative("roll_gradient", "rad/(m/s^2)", "body roll per lateral acceleration (steady state)"),
    nonnegative("roll_frequency", "Hz", "natural frequency of the body's roll mode; 0 = quasi-static "
                "roll (roll_gradient times the lagged a_y of the load transfer)", default=0.0),
    positive("roll_damping_ratio", "-", "damping ratio of the roll mode (roll_frequency > 0 only)",
             default=0.4),
    vector("sensor_position", 3, "m", "position of the inertial sensors (accelerometers, gyro) from "
           "the CG in body axes x forward, y left, z up; they sit on the rolling body",
           default=(0.0, 0.0, 0.0)),
    nonnegative("pitch_gradient", "rad/(m/s^2)", "body pitch per longitudinal deceleration (quasi-static)"),
    fraction("roll_stiffness_front_share", "share of lateral load transfer taken by the front axle"),
    positive("load_transfer_time_constant", "s", "lag of load transfer behind the accelerations"),
    nonnegative("drag_area", "m^2", "C_d * A"),
    nonnegative("rolling_resistance", "-", "rolling-resistance coefficient"),
    positive("driver_bandwidth", "rad/s", "the simulated driver: natural frequency of its closed-loop "
             "path error (a calmer driver keeps a softer car inside the cones)", default=2.0),
    positive("driver_damping", "-", "the simulated driver: damping ratio of its closed-loop path error",
             default=0.8),
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
def forms_field(key: str, doc: str) -> Field:
    """A list of forms "<estimator>:<real>-<params>", e.g. "switching:float-calibratable"
    (optional, empty when absent); normalised to a tuple of (estimator, real, params)."""
    expected = (f'a list of "<estimator>:<real>-<params>" strings, <real> one of {", ".join(REALS)} and '
                f'<params> one of {", ".join(PARAMETER_MODES)} (e.g. "switching:float-calibratable")')

    def check(value: Any) -> tuple[tuple[str, str, str], ...]:
        if not isinstance(value, list):
            raise Invalid(expected)
        forms = []
        for entry in value:
            match = re.fullmatch(r"([a-z0-9_]+):([a-z]+)-([a-z]+)", entry) if isinstance(entry, str) else None
            if not match or match.group(2) not in REALS or match.group(3) not in PARAMETER_MODES:
                raise Invalid(expected)
            forms.append(match.groups())
        return tuple(dict.fromkeys(forms))

    return Field(key, expected, check, doc, ())


CODEGEN: tuple[Field, ...] = (
    choice("real", REALS, "C floating-point type of the generated code", default="double"),
    choice("params", PARAMETER_MODES, "parameters as literals (baked) or read at run time from a "
           "const calibration struct (calibratable)", default="baked"),
    forms_field("forms", "forms flashed besides the default one, each generated into generated/<vehicle>/"
                "<estimator>-<real>-<params>/, checked by `generate --check` and verified by `verify`"),
)

# [estimator]: common to all estimators of the file
def fingerprint_field(key: str, doc: str) -> Field:
    """A short hexadecimal fingerprint (8 to 64 digits); optional, '' when absent."""
    expected = "a string of 8 to 64 hexadecimal digits"

    def check(value: Any) -> str:
        if not isinstance(value, str) or not re.fullmatch(r"[0-9a-f]{8,64}", value):
            raise Invalid(expected)
        return value

    return Field(key, expected, check, doc, "")


SAMPLING: tuple[Field, ...] = (
    positive("sample_time", "s", "estimator sample time T (0.01 s = 100 Hz by default)"),
    fingerprint_field("derived_for", "fingerprint of the [vehicle] table the car-specific estimator "
                                     "settings were derived for (written by vsegen identify, or by hand "
                                     "after review)"),
)

DISCRETISATIONS = ("euler", "tustin", "zoh")


def above(key: str, lower: str, what: str, unit: str = "") -> Rule:
    """Rule: ``key`` must be greater than the table's ``lower`` (``what`` names the value)."""
    def check(settings: Mapping[str, Any]) -> str:
        if settings[key] <= settings[lower]:
            return (f"{key} = {settings[key]!r}: expected {what} above "
                    f"{lower} = {settings[lower]!r}{' ' + unit if unit else ''}")
        return ""
    return Rule(key, check, (key, ">", lower))


def below(key: str, upper: str, what: str, unit: str = "") -> Rule:
    """Rule: ``key`` must be smaller than the table's ``upper``."""
    def check(settings: Mapping[str, Any]) -> str:
        if settings[key] >= settings[upper]:
            return (f"{key} = {settings[key]!r}: expected {what} below "
                    f"{upper} = {settings[upper]!r}{' ' + unit if unit else ''}")
        return ""
    return Rule(key, check, (key, "<", upper))


LOW_SPEED_FIELDS: tuple[Field, ...] = (
    positive("vx_min", "m/s", "below this speed the estimator holds (status LOW_SPEED)"),
    positive("vx_resume", "m/s", "after a low-speed hold, resume at or above this speed"),
)
LOW_SPEED_RULES: tuple[Rule, ...] = (above("vx_resume", "vx_min", "a speed", "m/s (hysteresis)"),)

TYRE_MODELS = ("linear", "saturating")
"""The Kalman filter's axle-force models (model.tyres)."""
MINIMUM_FRICTION = 0.05
"""The lowest tyre_friction a file may give: below wet ice (about 0.1), and the saturating model's
C alpha / (mu F_z) stays finite."""

KF_FIELDS: tuple[Field, ...] = (
    choice("discretisation", DISCRETISATIONS, "method turning A, B into Phi, Gamma"),
    spd_matrix("process_noise", 2, "continuous PSD of [vy, r]: (m/s^2)^2*s, (rad/s^2)^2*s",
               "Q_c; the discrete Q_d = Q_c*T"),
    nonnegative("process_noise_load", "m/s^2", "beyond the papers: the process noise grows with the "
                "measured lateral acceleration, Q_c (1 + (a_y / process_noise_load)^2), |a_y| counted up "
                "to 6 m/s^2, a load below 0.1 as 0.1: the model's tyre forces err in proportion to the force "
                "they carry, so the filter trusts the model in straight driving (less noise in beta) and "
                "the measurements in a hard corner; 0 = a constant Q_c (the papers)", default=0.0),
    spd_matrix("measurement_noise", 2, "[ay, r]: (m/s^2)^2, (rad/s)^2", "R"),
    spd_matrix("initial_covariance", 2, "[vy, r]: (m/s)^2, (rad/s)^2",
               "P_0, also the covariance after a hold and at a kinematic-to-dynamic hand-off"),
    choice("tyre_model", TYRE_MODELS, "axle forces of the model: \"linear\" F = C alpha (the paper) | "
           "\"saturating\" F = mu F_z tanh(C alpha / (mu F_z)), an extended KF right at the friction limit",
           default="linear"),
    diagonal("tyre_friction", 2, "-", "[front, rear] peak lateral axle force over the axle's static load "
             "(the tyres' friction; tyre_model = \"saturating\" only)", default=(1.0, 1.0),
             minimum=MINIMUM_FRICTION, entries="front, rear"),
    nonnegative("friction_floor", "-", "each axle's friction is at least this times the measured |a_y| / g "
                "(the road carries what the car does; a tyre_friction set too low cannot make the filter "
                "read the measured a_y as a runaway slip angle; 0 = tyre_friction alone; tyre_model = "
                "\"saturating\" only)", default=1.15),
    nonnegative("friction_noise", "1/s", "beyond the papers: the filter estimates a friction scale rho "
                "(1 = tyre_friction) as a third state, a random walk of this intensity (rho^2 per s) that "
                "the measurements move where the tyres saturate, so a slippery road lowers the model's "
                "friction; 0 = tyre_friction and the floor alone (tyre_model = \"saturating\" only)",
                default=0.0),
    positive("friction_time", "s", "the estimated friction scale returns to 1 (the file's tyre_friction) "
             "with this time constant where the driving no longer shows the friction (friction_noise > 0 "
             "only)", default=5.0),
    *LOW_SPEED_FIELDS,
)
"""The 2-DOF Kalman filter's settings, shared by every estimator that runs it."""

ROLL_CORRECTION = nonnegative(
    "roll_gradient", "rad/(m/s^2)", "body roll per lateral acceleration, to remove the gravity "
    "component a body-fixed accelerometer reads: a_y = a_y,m / (1 + g k); 0 = none (the paper's "
    "literal a_y)", default=0.0)
"""The roll correction of a_y (model.sensors) that seed 000's estimators, ekf_rls and the particle
filters share."""

def _caps_above_floors(table: Mapping[str, Any]) -> str:
    if all(high > low for high, low in zip(table["process_noise_max"], table["process_noise"])):
        return ""
    return (f"process_noise_max = {list(table['process_noise_max'])!r}: expected every entry "
            f"above its process_noise entry {list(table['process_noise'])!r}")


CAPS_ABOVE_FLOORS = Rule("process_noise_max", _caps_above_floors, ("process_noise_max", ">", "process_noise"))
"""An adaptive noise's ceilings lie above its floors, entry by entry (aukf, the particle filters)."""


def rounded(value: float, digits: int = 4) -> float:
    """``value`` to ``digits`` significant digits, for a value written into a vehicle file by a
    tool (what the file shows is what the code uses)."""
    return float(f"{value:.{digits}g}")


def shown(value: Any) -> str:
    """A validated setting as a vehicle file would write it, short: numbers to 4 significant digits,
    a list as [a, b], a matrix setting as the list of its diagonal."""
    if isinstance(value, tuple):
        entries = [row[i] if isinstance(row, tuple) else row for i, row in enumerate(value)]
        return "[" + ", ".join(f"{v:.4g}" for v in entries) + "]"
    return f"{value:.4g}" if isinstance(value, float) else str(value)
