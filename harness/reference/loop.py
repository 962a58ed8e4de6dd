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


def step_reference(module: ModuleType, config, inputs: np.ndarray, state=None) -> tuple[np.ndarray, object]:
    """(outputs n x ny, state after the last row) from ``state`` (None: init from row 0): a log run
    chunk by chunk, the state carried, gives the outputs of :func:`run_reference`."""
    if state is None:
        state = module.init(config, inputs[0])
    outputs = []
    for row in inputs:
        state, output = module.step(config, state, row)
        outputs.append(output)
    return np.array(outputs), state
