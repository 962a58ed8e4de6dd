"""Equivalence of generated C and the NumPy reference over the verification scenarios."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from codegen.generate import render
from harness.build import load_estimator
from harness.compare import Difference, as_seen_by, difference, for_estimator
from harness.reference import REFERENCES
from harness.reference.run import run_reference
from harness.scenarios import VERIFICATION_SET, Case
from model.estimators import build
from model.params import VehicleConfig


class LayoutMismatch(RuntimeError):
    """The reference and the symbolic model disagree on a vector layout."""


@dataclass(frozen=True)
class CaseResult:
    estimator: str
    real: str
    case: str
    samples: int
    outputs: tuple[Difference, ...]
    states: Difference
    """Worst case over all state entries."""
    stepwise: Difference
    """Worst case over every step taken by the reference from the C's own state."""

    @property
    def ok(self) -> bool:
        return self.states.ok and self.stepwise.ok and all(d.ok for d in self.outputs)


def verify_estimator(config: VehicleConfig, name: str, cases: tuple[Case, ...] = VERIFICATION_SET,
                     seed: int = 1, real: str | None = None, params: str | None = None,
                     progress=None) -> list[CaseResult]:
    """Build ``name`` for ``config``, run C and reference over ``cases``, compare step by step.
    ``real`` and ``params`` default to the vehicle file's [codegen] settings."""
    real = real or config.codegen["real"]
    params = params or config.codegen["params"]
    estimator = build(name, config, params)
    reference = REFERENCES[name]
    for label, model_layout, ref_names in zip(("inputs", "states", "outputs"),
                                              (estimator.inputs, estimator.states, estimator.outputs),
                                              reference.names(config)):
        if tuple(model_layout.names) != tuple(ref_names):
            raise LayoutMismatch(f"{name}: {label} of model {model_layout.names} != reference {ref_names}")
    compiled = load_estimator(estimator, render(config, name, real, params))
    tolerance = for_estimator(real, estimator.rounding_gain)
    state_scales = np.array(estimator.states.scales)
    step_scales = np.concatenate([state_scales, estimator.outputs.scales])
    results = []
    for case in cases:
        log = case.simulate(config, 1.0 / config.sample_time, seed)
        inputs = as_seen_by(real, log.matrix(estimator.inputs.names))
        c_out, c_states = compiled.run(inputs)
        r_out, r_states = run_reference(reference, config, inputs)
        outputs = tuple(
            difference(s.name, c_out[:, i], r_out[:, i], tolerance, s.integer, s.scale)
            for i, s in enumerate(estimator.outputs.signals)
        )
        states = difference("state (all entries)", c_states, r_states, tolerance,
                            scale=state_scales)
        stepwise = _stepwise(reference, config, c_states, c_out, inputs, tolerance, step_scales)
        results.append(CaseResult(name, real, case.label, len(log), outputs, states, stepwise))
        if progress:
            progress()
    return results


def _stepwise(reference, config, c_states, c_out, inputs, tolerance, scales) -> Difference:
    """Each reference step from the C's state k against the C's state k+1 and output k."""
    expected = [np.concatenate(reference.step(config, c_states[k], row))
                for k, row in enumerate(inputs)]
    actual = np.hstack([c_states[1:], c_out])
    return difference("step from the C state", actual, np.array(expected), tolerance,
                      scale=scales)
