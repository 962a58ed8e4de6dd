"""Running a reference estimator over a log (the same shape as the compiled C)."""

from __future__ import annotations

from types import ModuleType

import numpy as np


def run_reference(module: ModuleType, config, inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(outputs n x ny, states (n+1) x nx): init from row 0, then one step per row."""
    state = module.init(config, inputs[0])
    states = [state]
    outputs = []
    for row in inputs:
        state, output = module.step(config, state, row)
        states.append(state)
        outputs.append(output)
    return np.array(outputs), np.array(states)
