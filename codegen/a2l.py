"""What the ASAP2 (A2L) file of a calibratable build describes, entry by entry.

INCA, CANape and similar tools calibrate an ECU through an A2L file: each CHARACTERISTIC is one
calibration value at an address (here an entry of the const calibration struct), each
MEASUREMENT one variable they may read while the ECU runs (here the estimator's state and
outputs). The generated file links every object to its C symbol with ``SYMBOL_LINK "symbol"
offset`` (ASAP2 1.7) and leaves the addresses 0 until ``vsegen a2l --elf`` fills them from the
linked firmware (harness/target/a2l_link.py).

Layout rules the offsets rely on: the calibration struct and the state hold ``real`` members only
(4 or 8 bytes, back to back); the outputs hold reals and ``int`` members (4 bytes: ``status``, a
switching estimator's ``mode``), each at the next multiple of its own size, as C places them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from vsegen.model.calibration_checks import Bound, calibration_checks, entry_fields
from vsegen.model.estimator import Estimator, Particles
from vsegen.model.estimators import SCHEMAS

DATATYPES = {"float": ("FLOAT32_IEEE", 4, 3.4e38), "double": ("FLOAT64_IEEE", 8, 1.7e308)}
"""real -> (ASAP2 data type, size in bytes, largest magnitude used as an open limit)."""
STATUS_TYPE = ("SLONG", 4, 2147483647)
"""The outputs' ``int`` members, ``status`` and ``mode`` (32 bits on every target vsegen builds for)."""


@dataclass(frozen=True)
class Quantity:
    """One CHARACTERISTIC or MEASUREMENT."""

    name: str
    """A2L identifier, e.g. ``vse_kf2dof_calibration.mass``."""
    doc: str
    unit: str
    datatype: str
    symbol: str
    """The C object the address is relative to."""
    offset: int
    """Bytes from the symbol's address."""
    lower: float
    upper: float
    count: int = 1
    """Entries of an array (the particle block of a particle filter), else 1."""

    @property
    def limits(self) -> str:
        """The lower and upper limit as the A2L writes them: whole numbers for an integer type."""
        if self.datatype == STATUS_TYPE[0]:
            return f"{int(self.lower)} {int(self.upper)}"
        return f"{self.lower:.9g} {self.upper:.9g}"


@dataclass(frozen=True)
class Description:
    """Everything the A2L file lists for one generated estimator."""

    characteristics: tuple[Quantity, ...]
    measurements: tuple[Quantity, ...]
    conversions: dict[str, str]
    """unit -> COMPU_METHOD name."""


def state_symbol(prefix: str) -> str:
    """Default symbol of the measured state: the one the kit's example defines."""
    return f"{prefix}_example_state"


def output_symbol(prefix: str) -> str:
    """Default symbol of the measured outputs: the one the kit's example defines."""
    return f"{prefix}_example_output"


def describe(estimator: Estimator, real: str, prefix: str) -> Description:
    """The calibration entries (limits from the schema's run-time checks), the state entries and
    the outputs of ``estimator`` as built for ``real``."""
    datatype, size, open_limit = DATATYPES[real]
    names = estimator.parameters.names
    fields = entry_fields(SCHEMAS[estimator.name], names)
    lower, upper = [-open_limit] * len(names), [open_limit] * len(names)
    for check in calibration_checks(SCHEMAS[estimator.name], names):
        if isinstance(check, Bound) and check.op in (">", ">="):
            lower[check.index] = max(lower[check.index], check.value)
        elif isinstance(check, Bound):
            upper[check.index] = min(upper[check.index], check.value)
    characteristics = tuple(
        Quantity(f"{prefix}_calibration.{name}", fields[name].doc or name, entry_unit(fields[name].unit, name),
                 datatype, f"{prefix}_calibration", i * size, lower[i], upper[i])
        for i, name in enumerate(names))
    states = estimator.states.signals
    particles = _particle_block(estimator)
    named = states[:len(states) - particles[1]] if particles else states
    measurements = [Quantity(f"{prefix}_state.{s.name}", s.doc, s.unit, datatype, state_symbol(prefix),
                             i * size, -open_limit, open_limit) for i, s in enumerate(named)]
    if particles:
        measurements.append(Quantity(f"{prefix}_state.particles", f"{particles[0]} particles, entries as "
                                     f"{prefix.upper()}_PARTICLE_*", "-", datatype, state_symbol(prefix),
                                     len(named) * size, -open_limit, open_limit, particles[1]))
    offset = 0
    for s in estimator.outputs.signals:
        kind, member, limit = STATUS_TYPE if s.integer else (datatype, size, open_limit)
        offset = -(-offset // member) * member          # the next multiple of the member's size
        measurements.append(Quantity(f"{prefix}_output.{s.name}", s.doc, s.unit, kind, output_symbol(prefix),
                                     offset, 0.0 if s.integer else -limit, limit))
        offset += member
    units = sorted({q.unit for q in (*characteristics, *measurements)})
    return Description(characteristics, tuple(measurements), _conversion_names(units))


def entry_unit(unit: str, entry: str) -> str:
    """The unit of calibration entry ``entry`` of a key whose unit is ``unit``: a list or matrix
    key's unit "[vy, r]: (m/s)^2, (rad/s)^2" gives entry ``..._1`` or ``..._11`` "(m/s)^2" and
    ``..._22`` "(rad/s)^2", "[v_x, v_y]: m/s" gives "m/s"; an off-diagonal entry, or any other
    key, keeps ``unit`` ("-" if none)."""
    listed = re.fullmatch(r".*\[([^\]]*)\]:\s*(.*)", unit)
    digits = re.search(r"_(\d{1,2})$", entry)
    if listed and digits:
        units = [u.strip() for u in listed.group(2).split(", ")]
        if len(units) == 1:
            return units[0]
        rows = {int(d) for d in digits.group(1)}
        if len(units) == len(listed.group(1).split(",")) and len(rows) == 1 and max(rows) <= len(units):
            return units[max(rows) - 1]
    return unit or "-"


def _particle_block(estimator: Estimator) -> tuple[int, int] | None:
    """(particle count, entries in the particle block) of a particle filter's state, else None."""
    structure = estimator.structure
    if not isinstance(structure, Particles):
        return None
    return structure.count, structure.count * len(structure.particle)


def _conversion_names(units: list[str]) -> dict[str, str]:
    """A distinct COMPU_METHOD identifier per unit, e.g. "m/s^2" -> "CM_m_s_2"."""
    names: dict[str, str] = {}
    for unit in units:
        base = "CM_" + (re.sub(r"[^A-Za-z0-9]+", "_", unit).strip("_") or "none")
        name, n = base, 1
        while name in names.values():
            n += 1
            name = f"{base}_{n}"
        names[unit] = name
    return names


def text(value: str) -> str:
    """``value`` as the body of an ASAP2 string (no double quotes, no line breaks)."""
    return value.replace('"', "'").replace("\n", " ")
