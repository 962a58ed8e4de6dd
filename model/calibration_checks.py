"""The schema's checks on a calibratable estimator's calibration, for the generated C to repeat.

A vehicle file is validated on load (model/schema.py); a calibration flashed onto the ECU is not.
So the generated code of a calibratable estimator checks, before every step, every check the
schema makes on the entries of its calibration struct: each number's bounds (``Field.bounds``,
e.g. mass > 0), the comparisons between keys (``Rule.relation``, e.g. vx_resume > vx_min) and
the positive definiteness of a symmetric matrix (Sylvester's criterion on its calibrated
entries, up to 3 x 3) and, for an estimator with a discretised bicycle model, that the model's
state-matrix norm stays within the range its discretisation was planned for (a stiffness of 9e6
N/rad or a yaw inertia of 5 kg m^2 pass every bound and would make the prediction explode).
A step with an invalid calibration holds (status INVALID_CALIBRATION).
A rule that is not a comparison (``Rule.relation`` None) is not repeated; :func:`unchecked_rules`
lists them (none today, a test keeps it so).
"""

from __future__ import annotations

from dataclasses import dataclass

from vsegen.model.bicycle import state_matrix_norm_bound
from vsegen.model.calibration import CALIBRATION_MARGIN
from vsegen.model.schema import INPUT_LIMITS, VEHICLE, EstimatorSchema, Field


@dataclass(frozen=True)
class Bound:
    """p[index] <op> value."""

    index: int
    op: str
    value: float
    says: str


@dataclass(frozen=True)
class Relation:
    """p[left] <op> p[right]."""

    left: int
    op: str
    right: int
    says: str


@dataclass(frozen=True)
class PositiveDefinite:
    """The symmetric matrix whose row-major entries are p[indices[i][j]] is positive definite."""

    indices: tuple[tuple[int, ...], ...]
    says: str


@dataclass(frozen=True)
class StateMatrixNorm:
    """:func:`vsegen.model.bicycle.state_matrix_norm_bound` of the entries p[index[key]] (keys
    :data:`NORM_OPERANDS`) is <= limit (1/s)."""

    index: dict[str, int]
    limit: float
    says: str


Check = Bound | Relation | PositiveDefinite | StateMatrixNorm

NORM_OPERANDS = ("mass", "yaw_inertia", "cg_to_front_axle", "cg_to_rear_axle", "cornering_stiffness_front",
                 "cornering_stiffness_rear", "vx_min", "vx_max")
"""The calibration entries the bicycle model's state matrix norm bound reads."""


def calibration_checks(schema: EstimatorSchema, names: tuple[str, ...]) -> tuple[Check, ...]:
    """The checks on the calibration entries ``names`` (``Parameters.names``) of an estimator with
    ``schema``: those of [vehicle], [inputs] and its own table whose values are all calibrated."""
    index = {name: i for i, name in enumerate(names)}
    fields = {f.key: f for f in (*VEHICLE, *INPUT_LIMITS, *schema.fields)}
    checks: list[Check] = []
    for key, field in fields.items():
        entries = _entries(key, index)
        for name in entries:
            checks += [Bound(index[name], op, value, f"{name} {op} {value:g}") for op, value in field.bounds]
        if field.positive_definite and entries:
            checks += _positive_definite(key, field, index)
    for rule in schema.rules:
        if rule.relation is not None:
            checks += _relation(*rule.relation, index)
    return tuple(checks)


def dynamics_checks(schema: EstimatorSchema, names: tuple[str, ...],
                    values: tuple[float, ...]) -> tuple[Check, ...]:
    """For an estimator that discretises the bicycle model (a ``discretisation`` setting) with
    every operand calibrated: the state-matrix norm bound over vx_min..vx_max stays within
    CALIBRATION_MARGIN times its value at generation, the range the discretisation (the ZOH
    series' terms and squarings) was planned for."""
    if "discretisation" not in {f.key for f in schema.fields} or not set(NORM_OPERANDS) <= set(names):
        return ()
    value = dict(zip(names, values))
    index = {key: names.index(key) for key in NORM_OPERANDS}
    limit = CALIBRATION_MARGIN * state_matrix_norm_bound(value, value["vx_min"], value["vx_max"])
    return (StateMatrixNorm(index, limit, f"||A(vx)||_inf <= {limit:.6g} 1/s for vx_min <= vx <= vx_max"),)


def entry_fields(schema: EstimatorSchema, names: tuple[str, ...]) -> dict[str, Field]:
    """The schema field each calibration entry of ``names`` comes from (its unit and meaning)."""
    index = {name: i for i, name in enumerate(names)}
    fields = {f.key: f for f in (*VEHICLE, *INPUT_LIMITS, *schema.fields)}
    return {name: field for key, field in fields.items() for name in _entries(key, index)}


def _relation(left: str, op: str, right: str | float, index: dict[str, int]) -> list[Check]:
    """A rule's comparison on the calibrated entries: key with key, list with list entry by entry,
    or every entry with a number."""
    if isinstance(right, float):
        return [Bound(index[name], op, right, f"{name} {op} {right:g}") for name in _entries(left, index)]
    pairs = list(zip(_entries(left, index), _entries(right, index)))
    return [Relation(index[a], op, index[b], f"{a} {op} {b}") for a, b in pairs]


def unchecked_rules(schema: EstimatorSchema) -> tuple[str, ...]:
    """The keys of the rules the generated C does not repeat (not a comparison of two numbers)."""
    return tuple(rule.key for rule in schema.rules if rule.relation is None)


def _entries(key: str, index: dict[str, int]) -> list[str]:
    """The calibration entries of ``key``: itself, or its list entries ``key_i`` / matrix entries
    ``key_ij`` (numbered from 1)."""
    if key in index:
        return [key]
    prefix = key + "_"
    return [name for name in index if name.startswith(prefix) and name[len(prefix):].isdigit()]


def _positive_definite(key: str, field: Field, index: dict[str, int]) -> list[Check]:
    """Sylvester's criterion (every leading minor > 0) on the matrix ``key`` when all its upper
    entries are calibrated (n <= 3)."""
    upper = {name[len(key) + 1:]: i for name, i in index.items()
             if name.startswith(key + "_") and len(name) == len(key) + 3}
    n = max(int(k[0]) for k in upper)
    if n > 3 or len(upper) != n * (n + 1) // 2:
        return []
    rows = tuple(tuple(upper[f"{min(i, j) + 1}{max(i, j) + 1}"] for j in range(n)) for i in range(n))
    return [PositiveDefinite(tuple(row[:size] for row in rows[:size]),
                             f"{key}: leading {size}x{size} minor > 0") for size in range(1, n + 1)]
