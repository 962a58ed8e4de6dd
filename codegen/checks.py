"""C conditions of a calibration's checks (model/calibration_checks.py), one per check.

Each condition is true when the check holds and false for NaN (a comparison with NaN is false),
so the generated code tests ``!(condition)`` to find a broken calibration."""

from __future__ import annotations

from vsegen.codegen.precision import literal
from vsegen.model.calibration_checks import Bound, Check, PositiveDefinite, Relation, StateMatrixNorm


def condition(check: Check, real: str) -> str:
    """The C expression of ``check`` over the array ``p``."""
    zero = literal(0.0, real)
    if isinstance(check, Bound):
        return f"p[{check.index}] {check.op} {literal(check.value, real)}"
    if isinstance(check, Relation):
        return f"p[{check.left}] {check.op} p[{check.right}]"
    if isinstance(check, StateMatrixNorm):
        return _state_matrix_norm(check, real)
    return f"{_determinant(check)} > {zero}"


def _determinant(check: PositiveDefinite) -> str:
    m = [[f"p[{i}]" for i in row] for row in check.indices]
    if len(m) == 1:
        return m[0][0]
    if len(m) == 2:
        return f"(({m[0][0]} * {m[1][1]}) - ({m[0][1]} * {m[1][0]}))"
    minor = [f"(({m[1][a]} * {m[2][b]}) - ({m[1][b]} * {m[2][a]}))" for a, b in ((1, 2), (0, 2), (0, 1))]
    return f"((({m[0][0]} * {minor[0]}) - ({m[0][1]} * {minor[1]})) + ({m[0][2]} * {minor[2]}))"


def _state_matrix_norm(check: StateMatrixNorm, real: str) -> str:
    """model.bicycle.state_matrix_norm_bound in C: each row sum of |A(vx)| over vx_min <= vx <=
    vx_max within the limit. Written so that a NaN, a zero or a negative divisor fails it."""
    p = {key: f"p[{i}]" for key, i in check.index.items()}
    m, iz, a, b = p["mass"], p["yaw_inertia"], p["cg_to_front_axle"], p["cg_to_rear_axle"]
    cf, cr, vx_min, vx_max = (p["cornering_stiffness_front"], p["cornering_stiffness_rear"], p["vx_min"],
                              p["vx_max"])
    zero, limit = literal(0.0, real), literal(check.limit, real)
    difference = f"(({b} * {cr}) - ({a} * {cf}))"
    coupling = f"(({difference} < {zero}) ? -{difference} : {difference})"  # |.| without libm
    row1 = f"((((({cf} + {cr}) + {coupling}) / {m}) / {vx_min}) + {vx_max})"
    restoring = f"((({a} * {a}) * {cf}) + (({b} * {b}) * {cr}))"
    row2 = f"((({coupling} + {restoring}) / {iz}) / {vx_min})"
    return (f"({m} > {zero}) && ({iz} > {zero}) && ({vx_min} > {zero}) && ({row1} <= {limit})"
            f" && ({row2} <= {limit})")
