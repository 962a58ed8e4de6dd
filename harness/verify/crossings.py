"""The reference's trajectory alongside the C's, across the reference's own decisions.

A deterministic estimator decides with thresholds (ekf_rls re-seeds its kinematic integral when
its stiffness-rate indicator falls to ``indicator_low``; the RLS updates only on excited samples;
the holds). When the C's state and the reference's lie within rounding of each other but on two
sides of such a threshold, the two runs take the two branches and part by far more than their
rounding, although every step of the C matches the reference's step from the C's own state.
Measured: rwd_saloon's float calibratable ekf_rls on the fishhook, indicator 0.5 within 4e-7 of
``indicator_low``, kinematic integral re-seeded in one run and not the other: 2.4e-5 rad apart,
then 2.5e-4 apart in the fusion weight through the RLS.

Such a step is a *crossing*: the reference's step is discontinuous between its own state and the
C's, proven by bisection (the two successors stay apart while the states between them shrink to
adjacent doubles). The comparison then continues from the reference's step from the C's state.
No estimator declares its decisions: the proof is on the reference's own step function, and a
mere drift (the step is continuous) is never excused.
"""

from __future__ import annotations

import numpy as np

from vsegen.harness.verify.compare import Tolerance, peak_guard, relative_errors

SCREEN_GROWTH = 100.0
"""A step is examined for a crossing when it widens the gap between the two runs in some state
entry by more than this factor (rounding alone widens it by a few ulps per step)..."""

SCREEN_FLOOR = 0.1
"""... to more than this fraction of the tolerance. Smaller gaps need no explanation, and at a gap
of a few ulps the bisection ends on adjacent states whose successors differ by rounding alone
(measured: kf2dof's double step on the sine steer, 1.5e-14 apart from states an ulp apart, a
hundredth of the tolerance: no decision there)."""

BISECTIONS = 60
"""Halvings of the segment between the two states: 2^-60 of a gap of a tolerance is below one
ulp of any state entry, so successors still apart then are apart across a discontinuity."""


def trajectory_across_decisions(reference, config, inputs: np.ndarray, c_states: np.ndarray,
                                tolerance: Tolerance, scales: np.ndarray):
    """The reference run over ``inputs`` from its own initial state, crossing to its step from
    the C's state wherever the C's run (``c_states``, (n+1) x nx) crossed a decision of the
    reference's step (module docstring). Returns (outputs n x ny, states (n+1) x nx, crossings)."""
    guard = peak_guard(c_states)

    def gaps(a, b) -> np.ndarray:
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            return np.full(len(a), np.inf)
        return relative_errors(a[None], b[None], tolerance, scales, guard)[0]

    def gap(a, b) -> float:
        return float(gaps(a, b).max(initial=0.0))

    state = reference.init(config, inputs[0])
    states, outputs, crossings = [state], [], 0
    before = gaps(state, c_states[0])
    for k, row in enumerate(inputs):
        following, output = reference.step(config, state, row)
        after = gaps(following, c_states[k + 1])
        widened = (after > SCREEN_FLOOR * tolerance.relative) & (after > SCREEN_GROWTH * before)
        if (np.all(np.isfinite(after)) and widened.any() and before.max() <= tolerance.relative
                and _discontinuous(reference, config, state, c_states[k], row, gap)):
            following, output = reference.step(config, c_states[k], row)
            after, crossings = gaps(following, c_states[k + 1]), crossings + 1
        states.append(following)
        outputs.append(output)
        state, before = following, after
    return np.array(outputs), np.array(states), crossings


def _discontinuous(reference, config, own: np.ndarray, other: np.ndarray, row: np.ndarray, gap) -> bool:
    """Whether the reference's step jumps somewhere on the segment from state ``own`` to
    ``other``: bisect toward the half whose ends' successors lie further apart; a jump is what
    is left when the segment has shrunk to nothing."""
    def successor(s: float) -> np.ndarray:
        return reference.step(config, own + s * (other - own), row)[0]

    low, high = 0.0, 1.0
    at_low, at_high = successor(low), successor(high)
    jump = gap(at_low, at_high)
    for _ in range(BISECTIONS):
        middle = 0.5 * (low + high)
        at_middle = successor(middle)
        if gap(at_low, at_middle) >= gap(at_middle, at_high):
            high, at_high = middle, at_middle
        else:
            low, at_low = middle, at_middle
    return gap(at_low, at_high) >= 0.5 * jump
