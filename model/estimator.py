"""The one shape every estimator has, and the registry of estimators.

    state_0 = init(input_0);   state_k+1, output_k = step(state_k, input_k)   for k = 0, 1, ...

``init`` and ``step`` are CasADi SX Functions of flat vectors with named layouts, so codegen, the
harness, equivalence checks and benchmarks are written once for all estimators.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import casadi as ca

from model.layout import Layout


@dataclass(frozen=True)
class Estimator:
    """A built estimator for one vehicle configuration.

    Attributes:
        name: estimator name (``[estimator.<name>]``, C prefix ``vse_<name>_``).
        summary: one line: what it estimates and how.
        inputs, states, outputs: layouts of the flat vectors.
        init: Function ``init(input) -> (state)``.
        step: Function ``step(state, input) -> (state_next, output)``.
        notes: facts worth printing in generated files (e.g. discretisation error bound).
    """

    name: str
    summary: str
    inputs: Layout
    states: Layout
    outputs: Layout
    init: ca.Function
    step: ca.Function
    notes: Mapping[str, str] = field(default_factory=dict)


def make_functions(name: str, inputs: Layout, states: Layout, outputs: Layout, input_sym: ca.SX,
                   state_sym: ca.SX, init_state: ca.SX, next_state: ca.SX, output: ca.SX):
    """The ``init`` and ``step`` Functions with the naming every estimator uses."""
    init = ca.Function(f"vse_{name}_kernel_init", [input_sym], [init_state], ["input"], ["state"])
    step = ca.Function(f"vse_{name}_kernel_step", [state_sym, input_sym], [next_state, output],
                       ["state", "input"], ["state_next", "output"])
    for fn, layout, label in ((init, states, "state"), (step, states, "state_next")):
        if fn.numel_out(label) != len(layout):
            raise ValueError(f"{name}: {label} has {fn.numel_out(label)} entries, layout {len(layout)}")
    if step.numel_out("output") != len(outputs) or step.numel_in("input") != len(inputs):
        raise ValueError(f"{name}: output or input size does not match its layout")
    return init, step
