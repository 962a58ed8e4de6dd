"""Equivalence of generated C and the NumPy reference over the verification scenarios."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.jobs.memo import Memo
from vsegen.harness.jobs.pool import ProcessPool
from vsegen.harness.reference import LONG_DOUBLE, REFERENCES
from vsegen.harness.sim.scenarios import VERIFICATION_SET, Case
from vsegen.harness.verify.compare import Difference, as_seen_by, difference, for_estimator, relative_errors
from vsegen.harness.verify.crossings import trajectory_across_decisions
from vsegen.model.estimator import Particles
from vsegen.model.estimators import build
from vsegen.model.params import VehicleConfig


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
    flips: int = 0
    """Float particle filters: steps whose resampling selected other particles than the
    reference's because a point lay within float rounding of a cumulative weight (explained
    divergences; ``states`` and ``stepwise`` cover every other step)."""
    crossings: int = 0
    """Steps where the C's state and the reference's lay within rounding on two sides of a
    decision of the reference's step, which went on from the C's state
    (:mod:`harness.verify.crossings`)."""

    @property
    def ok(self) -> bool:
        return self.states.ok and self.stepwise.ok and all(d.ok for d in self.outputs)


def verify(config: VehicleConfig, names: tuple[str, ...], cases: tuple[Case, ...] = VERIFICATION_SET,
           seed: int = 1, real: str | None = None, params: str | None = None,
           on_done: Callable[[CaseResult], None] | None = None,
           workers: ProcessPool | None = None) -> list[CaseResult]:
    """Every estimator of ``names`` on every case: C and reference compared step by step, the
    runs spread over ``workers`` (default: a pool sized by ``harness.jobs.pool.worker_count``).
    ``real`` and ``params`` default to the vehicle file's [codegen] settings. Results come
    estimator by estimator, case by case; ``on_done`` is called as each run finishes."""
    real = real or config.codegen["real"]
    params = params or config.codegen["params"]
    for name in names:
        _check_layouts(config, name, build(name, config, params))
    with nullcontext(workers) if workers else ProcessPool(preload=[__name__]) as pool:
        rate_hz = 1.0 / config.sample_time
        pool.map(_simulate, [(config, case, rate_hz, seed) for case in cases])
        pool.map(_compile, [(config, name, real, params) for name in names])
        jobs = [(config, name, case, seed, real, params) for name in names for case in cases]
        return pool.map(verify_case, jobs,
                        on_done=(lambda _, result: on_done(result)) if on_done else None)


def verify_estimator(config: VehicleConfig, name: str, cases: tuple[Case, ...] = VERIFICATION_SET,
                     seed: int = 1, real: str | None = None,
                     params: str | None = None) -> list[CaseResult]:
    """:func:`verify` for one estimator."""
    return verify(config, (name,), cases, seed, real, params)


def verify_case(config: VehicleConfig, name: str, case: Case, seed: int, real: str,
                params: str) -> CaseResult:
    """Build ``name`` (memoised per process), run C and reference over ``case``, compare."""
    estimator, _, compiled, _ = prepared(config, name, real, params)
    inputs = case_inputs(config, estimator, case, seed, real)
    c_out, c_states = compiled.run(inputs)
    return against_reference(config, name, case.label, real, params, inputs, c_out, c_states)


def case_inputs(config: VehicleConfig, estimator, case: Case, seed: int, real: str) -> np.ndarray:
    """The input rows of ``case`` as C code of type ``real`` receives them."""
    log = case.simulate(config, 1.0 / config.sample_time, seed)
    return as_seen_by(real, log.matrix(estimator.inputs.names))


def against_reference(config: VehicleConfig, name: str, label: str, real: str, params: str, inputs: np.ndarray,
                      c_out: np.ndarray, c_states: np.ndarray, host_libm: bool = True) -> CaseResult:
    """A run of ``name``'s C (outputs n x ny, states (n+1) x nx) on ``inputs`` (the scenario or log
    ``label``) against the reference: whole
    trajectories and every step from the C's own state. ``host_libm`` False (a run on a target,
    with another libm): a particle filter is checked step by step only, as a float or calibratable
    build is (:func:`_particles_step_by_step`), since an ulp of exp or log parts its trajectory."""
    estimator, reference, _, tolerance = prepared(config, name, real, params)
    state_scales = np.array(estimator.states.scales)
    step_scales = np.concatenate([state_scales, estimator.outputs.scales])
    if isinstance(estimator.structure, Particles) and (real == "float" or params == "calibratable"
                                                       or not host_libm):
        return _particles_step_by_step(estimator, reference, config, label, len(inputs), c_states,
                                       c_out, inputs, tolerance, step_scales, real)
    r_out, r_states, crossings = trajectory_across_decisions(reference, config, inputs, c_states,
                                                             tolerance, state_scales)
    outputs = tuple(
        difference(s.name, c_out[:, i], r_out[:, i], tolerance, s.integer, s.scale)
        for i, s in enumerate(estimator.outputs.signals)
    )
    states = difference("state (all entries)", c_states, r_states, tolerance, scale=state_scales)
    stepwise = _stepwise(reference, config, c_states, c_out, inputs, tolerance, step_scales)
    return CaseResult(name, real, label, len(inputs), outputs, states, stepwise, crossings=crossings)


def _check_layouts(config: VehicleConfig, name: str, estimator) -> None:
    for label, model_layout, ref_names in zip(("inputs", "states", "outputs"),
                                              (estimator.inputs, estimator.states, estimator.outputs),
                                              REFERENCES[name].names(config)):
        if tuple(model_layout.names) != tuple(ref_names):
            raise LayoutMismatch(f"{name}: {label} of model {model_layout.names} != reference {ref_names}")


def _simulate(config: VehicleConfig, case: Case, rate_hz: float, seed: int) -> None:
    case.simulate(config, rate_hz, seed)        # fills the log cache for the comparison jobs


def _compile(config: VehicleConfig, name: str, real: str, params: str) -> None:
    prepared(config, name, real, params)       # fills the build cache for the comparison jobs


PREPARED = Memo(size=32)
"""(estimator, reference, compiled C, tolerance) by (vehicle, estimator, real, params)."""


def prepared(config: VehicleConfig, name: str, real: str, params: str):
    """(estimator, reference, compiled C, tolerance) of ``name``, memoised in this process."""
    return PREPARED.get((config.fingerprint(), name, real, params), lambda: _prepare(config, name, real, params))


def _prepare(config: VehicleConfig, name: str, real: str, params: str):
    estimator, compiled = compile_estimator(config, name, real, params)
    reference = REFERENCES[name]
    if isinstance(estimator.structure, Particles) and real == "float":
        reference = reference.drawing(24)    # the float C draws 24-bit uniforms (D5)
    tolerance = for_estimator(real, estimator.rounding_gain, name in LONG_DOUBLE)
    return estimator, reference, compiled, tolerance


FLIP_MARGIN = 1e-5
"""How close to a cumulative weight a resampling point must lie for a float build to be allowed
to select the particle on its other side: the float sum of N weights is off by about
sqrt(N) x 6e-8 (up to N x 6e-8 = 1.2e-5 at N = 200). Measured on the verification set: every
flip lay within 5e-7."""

DECISION_MARGIN = 1e-6
"""How close (relative) the two sides of a ziggurat wedge or tail test must lie for a build to be
allowed to take it the other way: the reference rounds a float build's arithmetic as float does
and exp and ln correctly; a float libm's expf or logf is off by up to an ulp (6e-8)."""


def _particles_step_by_step(estimator, reference, config, label, samples, c_states, c_out, inputs,
                            tolerance, scales, real) -> CaseResult:
    """A particle filter that is not bit-identical to its reference, step by step. Only the
    baked double build on the host is (its trajectory is compared whole); on a target, newlib's
    libm rounds some exp, log or cos to the neighbouring number of glibc's; a calibratable build computes the
    derived constants at run time, a float build rounds every operation, and a particle filter
    amplifies such rounding along its trajectory (weights through exp, resampling, adaptive
    noise: 1-ulp steps grew to 6e-12 relative on pf_adaptive's calibratable double build). A
    float build's resampling may also select another particle where a point lies within float
    rounding of a cumulative weight, after which the two runs draw the same numbers for
    different particles and their trajectories part (D5). So every step is checked from the C's
    own state: the outputs (computed before resampling) and the state either as the
    reference computes them or, a *flip*, as it computes it with one resampling point selecting a
    particle whose cumulative-weight interval lies within FLIP_MARGIN of it (a neighbour, or
    several across weights too small for float; or two such points), or with one ziggurat wedge
    or tail test whose sides lie within DECISION_MARGIN of each other taken the other way."""
    n_state = len(estimator.states)
    expected = np.array([np.concatenate(reference.step(config, c_states[k], row))
                         for k, row in enumerate(inputs)])
    actual, flips = c_states[1:], 0
    if np.all(np.isfinite(actual)) and np.all(np.isfinite(expected)):
        worst = relative_errors(actual, expected[:, :n_state], tolerance,
                                scales[:n_state]).max(axis=1)
        for k in np.flatnonzero(worst > tolerance.relative):
            for taken in _flip_sets(reference.alternatives(config, c_states[k], inputs[k],
                                                           FLIP_MARGIN, DECISION_MARGIN)):
                state, output = reference.step_flipped(config, c_states[k], inputs[k], taken)
                if difference("", actual[k], state, tolerance, scale=scales[:n_state]).ok:
                    expected[k], flips = np.concatenate([state, output]), flips + 1
                    break
    outputs = tuple(difference(s.name, c_out[:, i], expected[:, n_state + i], tolerance,
                               s.integer, s.scale)
                    for i, s in enumerate(estimator.outputs.signals))
    states = difference("step from the C state", actual, expected[:, :n_state],
                        tolerance, scale=scales[:n_state])
    return CaseResult(estimator.name, real, label, samples, outputs, states, states, flips)
    # (no whole-trajectory comparison: after the first flip the runs part by design, D5)


def _flip_sets(alternatives: list[tuple]) -> Iterator[tuple[tuple, ...]]:
    """What one step may have taken the other way: each alternative alone, then two resampling
    points each selecting a neighbour (two points near cumulative weights in one step happen
    about once in 10^3 steps at N = 200)."""
    yield from ((a,) for a in alternatives)
    points = [a for a in alternatives if a[0] == "resample"]
    yield from ((a, b) for i, a in enumerate(points) for b in points[i + 1:] if a[1] != b[1])


def _stepwise(reference, config, c_states, c_out, inputs, tolerance, scales) -> Difference:
    """Each reference step from the C's state k against the C's state k+1 and output k."""
    expected = [np.concatenate(reference.step(config, c_states[k], row))
                for k, row in enumerate(inputs)]
    actual = np.hstack([c_states[1:], c_out])
    return difference("step from the C state", actual, np.array(expected), tolerance,
                      scale=scales)
