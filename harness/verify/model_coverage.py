"""Model coverage: every decision of an estimator's symbolic step, and which ways the verification
scenarios take it.

A decision is an instruction of the CasADi SX step (``Estimator.step``, the composition of all its
kernels) that chooses: a comparison (<, <=, ==, !=), a logical operation (&&, ||, and ! of a value
that is not itself a decision), a min or a max (which operand it returns), and an if_else whose
condition is not itself a decision (e.g. a state flag). Each is evaluated, with CasADi, on every
sample of every scenario from the state the generated C had before that sample, and counted true
and false. A decision taken both ways is covered; one taken one way only is listed, with the way
taken, the expression it decides on and, when the step was built under
``decision_sites.traced``, the model line that built it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from vsegen.harness.verify.decision_sites import Sites

COMPARISONS = {ca.OP_LT: "<", ca.OP_LE: "<=", ca.OP_EQ: "==", ca.OP_NE: "!="}
LOGICAL = {ca.OP_NOT: "!", ca.OP_AND: "&&", ca.OP_OR: "||"}
CHOICES = {ca.OP_FMIN: "min", ca.OP_FMAX: "max"}
SHOWN = 110
"""Characters of a decision's expression shown in the report."""


@dataclass(frozen=True)
class Decision:
    """One decision of the step: its kind and the expression, the condition whose truth is counted
    (for a min or max: that the first operand is returned)."""

    index: int
    """Its instruction in the step."""
    kind: str
    expression: str
    condition: ca.SX
    site: str | None = None
    """The model line that built it (``decision_sites``), when known."""


@dataclass
class Counts:
    """How often each decision was true and false."""

    decisions: list[Decision]
    true: np.ndarray
    false: np.ndarray

    @property
    def both_ways(self) -> int:
        return int(np.count_nonzero((self.true > 0) & (self.false > 0)))

    def one_way(self) -> list[tuple[Decision, bool]]:
        """The decisions taken one way only, with the way taken."""
        return [(d, bool(self.true[i] > 0)) for i, d in enumerate(self.decisions)
                if (self.true[i] > 0) != (self.false[i] > 0)]

    def never(self) -> list[Decision]:
        return [d for i, d in enumerate(self.decisions) if self.true[i] == 0 and self.false[i] == 0]


def decisions(step: ca.Function, sites: Sites | None = None) -> list[Decision]:
    """The decisions of the SX Function ``step``, in instruction order, with their ``sites``
    when given."""
    outputs = step.instructions_sx()
    inputs = step.sx_in()
    work: dict[int, ca.SX] = {}
    found = []
    for k in range(step.n_instructions()):
        op = step.instruction_id(k)
        if op == ca.OP_OUTPUT:
            continue
        if op == ca.OP_INPUT:
            i, nz = step.instruction_input(k)
            args, value = [], inputs[i][nz]
        else:
            args, value = [work[i] for i in step.instruction_input(k)], outputs[k]
        (out,) = step.instruction_output(k)
        work[out] = value
        decision = _decision(k, op, args, value)
        if decision is not None:
            found.append(decision if sites is None else replace(decision, site=sites.of(value)))
    return found


def _decision(k: int, op: int, args: list[ca.SX], value: ca.SX) -> Decision | None:
    if op == ca.OP_NOT and _is_decision(args[0]):
        return None         # the else branch of an if_else on a decision counted already
    if op in COMPARISONS or op in LOGICAL:
        return Decision(k, "comparison" if op in COMPARISONS else "logic", _shown(value), value)
    if op in CHOICES:
        first = args[0] <= args[1] if op == ca.OP_FMIN else args[0] >= args[1]
        return Decision(k, CHOICES[op], _shown(value), first)
    if op == ca.OP_IF_ELSE_ZERO and not _is_decision(args[0]):
        return Decision(k, "if_else", _shown(args[0]), args[0] != 0)
    return None


def _is_decision(expression: ca.SX) -> bool:
    return expression.is_scalar() and not expression.is_symbolic() and not expression.is_constant() and \
        expression.op() in {**COMPARISONS, **LOGICAL}


def _shown(expression: ca.SX) -> str:
    text = str(expression)
    return text if len(text) <= SHOWN else text[:SHOWN - 1] + "…"


def count(step: ca.Function, runs: Iterable[tuple[np.ndarray, np.ndarray]], sites: Sites | None = None) -> Counts:
    """True and false counts of every decision of ``step`` over ``runs``: (states n x nx, the state
    before each sample; inputs n x nu); ``sites`` as for :func:`decisions`."""
    found = decisions(step, sites)
    evaluate = ca.Function("decisions", step.sx_in(), [ca.vertcat(*[d.condition for d in found])])
    true, false = np.zeros(len(found), dtype=int), np.zeros(len(found), dtype=int)
    for states, inputs in runs:
        values = np.array(evaluate.map(len(states))(states.T, inputs.T))
        taken = values != 0
        true += np.count_nonzero(taken, axis=1)
        false += np.count_nonzero(~taken, axis=1)
    return Counts(found, true, false)
