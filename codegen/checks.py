"""C conditions of a calibration's checks (model/calibration_checks.py), one per check.

Each condition is true when the check holds and false for NaN (a comparison with NaN is false),
so the generated code tests ``!(condition)`` to find a broken calibration."""

from __future__ import annotations

from vsegen.codegen.precision import literal
from vsegen.model.calibration_checks import Bound, Check, PositiveDefinite, Relation


def condition(check: Check, real: str) -> str:
    """The C expression of ``check`` over the array ``p``."""
    zero = literal(0.0, real)
    if isinstance(check, Bound):
        return f"p[{check.index}] {check.op} {literal(check.value, real)}"
    if isinstance(check, Relation):
        return f"p[{check.left}] {check.op} p[{check.right}]"
    return f"{_determinant(check)} > {zero}"


def _determinant(check: PositiveDefinite) -> str:
    m = [[f"p[{i}]" for i in row] for row in check.indices]
    if len(m) == 1:
        return m[0][0]
    if len(m) == 2:
        return f"(({m[0][0]} * {m[1][1]}) - ({m[0][1]} * {m[1][0]}))"
    minor = [f"(({m[1][a]} * {m[2][b]}) - ({m[1][b]} * {m[2][a]}))" for a, b in ((1, 2), (0, 2), (0, 1))]
    return f"((({m[0][0]} * {minor[0]}) - ({m[0][1]} * {minor[1]})) + ({m[0][2]} * {minor[2]}))"
