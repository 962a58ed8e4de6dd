"""The signal catalogue: every log column and the entries every estimator shares, described once.

Each entry has a name, a unit, a meaning with its sign convention and, for inputs, how it is
checked. Estimator layouts take their input signals from here (:func:`inputs`), the input guard its
limits and neutral values, the log reader its column lists and unit checks, the fuzzer its
ordinary magnitudes, and docs/conventions.md its log-format table (:func:`markdown_table`, kept
equal by a test). Units are SI, axes ISO 8855 (x forward, y left, z up).
"""

from __future__ import annotations

from dataclasses import dataclass

from vsegen.model.status import STATUS_BITS


@dataclass(frozen=True)
class Signal:
    """One entry of a flat vector: name (a log column for inputs), unit, meaning, C type kind."""

    name: str
    unit: str
    doc: str
    integer: bool = False
    scale: float = 1.0
    """Magnitude (in ``unit``) at which rounding of this entry is judged: the equivalence check's
    floor is multiplied by it. 1 for the O(1) SI signals; e.g. about 1e4 for a car's yaw moment in
    N*m, whose rounding comes from force moments of that size."""


@dataclass(frozen=True)
class UnitCheck:
    """A range that catches a column logged in the wrong unit: more than a few percent of its
    finite samples beyond ``limit`` means the unit is wrong (single glitches pass)."""

    limit: float
    hint: str
    """What a larger value looks like, e.g. 'looks like km/h'."""


@dataclass(frozen=True)
class Input:
    """A sensor column an estimator reads."""

    signal: Signal
    limit_key: str
    """The ``[inputs]`` key of its plausibility limit (|value| <= limit, else INVALID_INPUT)."""
    typical: float
    """Magnitude of ordinary values (fuzzing, test signals)."""
    required: bool = True
    absent_value: float | None = None
    """For an optional input: the value a log without the column means (None: the estimator needs
    the column)."""
    unit_check: UnitCheck | None = None
    limit_default: float | None = None
    """Value of the limit when the vehicle file leaves it out (None: the file must give it)."""

    @property
    def name(self) -> str:
        return self.signal.name

    @property
    def neutral(self) -> float | None:
        """What an implausible first sample is replaced by: 0, except vx (None: the estimator's
        low-speed limit)."""
        return None if self.name == "vx" else 0.0


TIME = Signal("t", "s", "time, strictly increasing with a constant step")

WHEEL_SPEEDS = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
_CORNERS = {"fl": "front left", "fr": "front right", "rl": "rear left", "rr": "rear right"}

INPUTS = (
    Input(Signal("delta", "rad", "front road-wheel steer angle (not the steering-wheel angle), positive left"),
          "delta_max", 0.1, unit_check=UnitCheck(1.0, "looks like degrees or a steering-wheel angle")),
    Input(Signal("vx", "m/s", "longitudinal speed as the ECU computes it (wheel speeds x effective radius)"),
          "vx_max", 40.0, unit_check=UnitCheck(150.0, "looks like km/h")),
    Input(Signal("ax", "m/s^2", "longitudinal acceleration, body-fixed sensor at the CG, positive forward"),
          "ax_max", 5.0, unit_check=UnitCheck(100.0, "looks like the wrong unit")),
    Input(Signal("ay", "m/s^2", "lateral acceleration, body-fixed sensor at the CG, positive left"),
          "ay_max", 8.0, unit_check=UnitCheck(100.0, "looks like the wrong unit")),
    Input(Signal("r", "rad/s", "gyro yaw rate, positive counter-clockwise seen from above"),
          "r_max", 0.5, unit_check=UnitCheck(10.0, "looks like deg/s")),
    *(Input(Signal(name, "rad/s", f"wheel speed {_CORNERS[name[6:]]}, positive rolling forward"),
            "omega_max", 120.0, required=False, limit_default=400.0) for name in WHEEL_SPEEDS),
    Input(Signal("mz", "N*m", "direct yaw moment applied by the chassis controls, positive counter-clockwise"),
          "mz_max", 3000.0, required=False, absent_value=0.0, limit_default=2.0e4),
)
"""Every sensor column, required ones first."""

TRUTH = (
    Signal("beta_ref", "rad", "reference sideslip angle at the CG, atan2(vy_ref, vx_ref)"),
    Signal("vx_ref", "m/s", "reference longitudinal speed at the CG"),
    Signal("vy_ref", "m/s", "reference lateral speed at the CG, positive left"),
    Signal("r_ref", "rad/s", "reference yaw rate, positive counter-clockwise"),
    Signal("mu", "-", "road friction coefficient"),
    Signal("off_course", "-", "1 from where a simulated run touched a cone or spun (latched), else 0"),
)
"""Optional ground truth, used only for scoring and plotting."""

STATUS = Signal("status", "-", "status bits: an OR of the STATUS values defined in this header (0 = OK)", integer=True)
HOLDING = Signal("holding", "-", "1 while holding (low speed or invalid input), else 0")
HOLDING_REASON = Signal("holding", "-", "2 while holding at low speed, 1 on an invalid input, else 0")
"""State entries of the hold rule: whether (or why) the estimator held at the last sample."""

INPUT = {entry.name: entry for entry in INPUTS}
REQUIRED_INPUTS = tuple(entry.name for entry in INPUTS if entry.required)
OPTIONAL_INPUTS = tuple(entry.name for entry in INPUTS if not entry.required)
LOG_COLUMN_UNITS = {**{entry.name: entry.signal.unit for entry in INPUTS},
                    **{signal.name: signal.unit for signal in TRUTH}}
"""Every column a log may have (inputs, then ground truth) with its SI unit."""


def inputs(*names: str) -> tuple[Signal, ...]:
    """The catalogue's signals of the named input columns, in the order given."""
    return tuple(INPUT[name].signal for name in names)


def inputs_by_limit() -> dict[str, tuple[Input, ...]]:
    """The inputs grouped by the ``[inputs]`` limit that bounds them, in catalogue order."""
    groups: dict[str, tuple[Input, ...]] = {}
    for entry in INPUTS:
        groups[entry.limit_key] = (*groups.get(entry.limit_key, ()), entry)
    return groups


def markdown_table() -> str:
    """The log-format table of docs/conventions.md: every column, its unit and meaning."""
    rows = [("t", TIME.unit, TIME.doc, "required")]
    rows += [(e.name, e.signal.unit, e.signal.doc, "required" if e.required else
              "optional" + ("" if e.absent_value is None else f", absent means {e.name} = {e.absent_value:g}"))
             for e in INPUTS]
    rows += [(s.name, s.unit, s.doc, "optional ground truth") for s in TRUTH]
    lines = ["| column | unit | meaning | presence |", "| --- | --- | --- | --- |"]
    lines += [f"| `{name}` | {unit} | {doc} | {presence} |" for name, unit, doc, presence in rows]
    return "\n".join(lines)


def status_table() -> str:
    """The status-bit table of docs/conventions.md: value, name and meaning of every bit."""
    lines = ["| bit | name | meaning |", "| --- | --- | --- |"]
    lines += [f"| {value} | {name} | {meaning} |" for name, (value, meaning) in STATUS_BITS.items()]
    return "\n".join(lines)
