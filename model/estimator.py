"""The one shape every estimator has, and the registry of estimators.

    state_0 = init(input_0);   state_k+1, output_k = step(state_k, input_k)   for k = 0, 1, ...

``init`` and ``step`` are CasADi SX Functions of flat vectors with named layouts, so codegen, the
harness, equivalence checks and benchmarks are written once for all estimators.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import casadi as ca

from model.calibration import Parameters
from model.layout import Layout


@dataclass(frozen=True)
class Estimator:
    """A built estimator for one vehicle configuration.

    Attributes:
        name: estimator name (``[estimator.<name>]``, C prefix ``vse_<name>_``).
        summary: one line: what it estimates and how.
        inputs, states, outputs: layouts of the flat vectors.
        init: Function ``init(input[, params]) -> (state)``.
        step: Function ``step(state, input[, params]) -> (state_next, output)``.
        parameters: where the parameter values come from (``params`` is an input when they are
            calibratable).
        notes: facts worth printing in generated files (e.g. discretisation error bound).
    """

    name: str
    summary: str
    inputs: Layout
    states: Layout
    outputs: Layout
    init: ca.Function
    step: ca.Function
    parameters: Parameters
    notes: Mapping[str, str] = field(default_factory=dict)


def make_functions(name: str, inputs: Layout, states: Layout, outputs: Layout, input_sym: ca.SX,
                   state_sym: ca.SX, init_state: ca.SX, next_state: ca.SX, output: ca.SX,
                   parameters: Parameters):
    """The ``init`` and ``step`` Functions with the naming every estimator uses."""
    extra = parameters.inputs()
    extra_names = ["params"] * len(extra)
    init = ca.Function(f"vse_{name}_kernel_init", [input_sym, *extra], [init_state],
                       ["input", *extra_names], ["state"])
    step = ca.Function(f"vse_{name}_kernel_step", [state_sym, input_sym, *extra],
                       [next_state, output], ["state", "input", *extra_names],
                       ["state_next", "output"])
    for fn, layout, label in ((init, states, "state"), (step, states, "state_next")):
        if fn.numel_out(label) != len(layout):
            raise ValueError(f"{name}: {label} has {fn.numel_out(label)} entries, layout {len(layout)}")
    if step.numel_out("output") != len(outputs) or step.numel_in("input") != len(inputs):
        raise ValueError(f"{name}: output or input size does not match its layout")
    return init, step
