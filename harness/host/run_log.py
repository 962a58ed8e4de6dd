"""Running an estimator over a log: generated C (compiled for the log's sample time, cached) or
the NumPy reference."""

from __future__ import annotations

from vsegen.codegen.generate import render
from vsegen.harness.host.build import load_estimator
from vsegen.harness.jobs.memo import Memo
from vsegen.harness.logs.table import Log, LogError
from vsegen.model.estimators import build
from vsegen.model.params import VehicleConfig
from vsegen.model.signals import WHEEL_SPEEDS

BACKENDS = ("c", "reference")
COMPILED = Memo(size=16)
"""The compiled C of the estimators this process ran lately, by (parameter hash, real, params): a
campaign's worker builds each estimator once, not once per log."""
SAMPLE_TIME_DIGITS = 9
"""A log's mean sample time is rounded to this many decimals (s) before generating for it."""


def config_at(config: VehicleConfig, sample_time: float) -> VehicleConfig:
    """``config`` at ``sample_time`` (s, rounded to SAMPLE_TIME_DIGITS decimals)."""
    sample_time = round(sample_time, SAMPLE_TIME_DIGITS)
    return config if sample_time == config.sample_time else config.with_sample_time(sample_time)


def inputs_of(config: VehicleConfig, name: str) -> tuple[str, ...]:
    """The log columns estimator ``name`` reads."""
    return build(name, config).inputs.names


def estimator_inputs(estimator, log: Log):
    """The log's columns the estimator reads, as a matrix; one line when one is missing (for wheel
    speeds, with why the estimator cannot do without them)."""
    missing = log.missing(estimator.inputs.names)
    if missing and set(missing) <= set(WHEEL_SPEEDS):
        config = estimator.parameters.numeric
        others = [n for n in config.estimators if not set(WHEEL_SPEEDS) & set(inputs_of(config, n))]
        raise LogError(f"{log.source}:1: missing column '{missing[0]}': estimator {estimator.name} needs the four "
                       f"wheel speeds ({', '.join(WHEEL_SPEEDS)}, rad/s): its 3-DOF model's longitudinal tyre "
                       "forces come from the wheels' slip, which v_x and a_x alone do not give; without wheel "
                       f"speeds run {', '.join(others) or 'an estimator that does not read them'}")
    if missing:
        raise LogError(f"{log.source}:1: missing column '{missing[0]}': estimator {estimator.name} needs "
                       f"{', '.join(estimator.inputs.names)}")
    return log.matrix(estimator.inputs.names)


def run_estimator(config: VehicleConfig, name: str, log: Log, backend: str = "c",
                  real: str | None = None, params: str | None = None) -> Log:
    """Estimates of ``name`` over ``log``: columns ``t`` and the estimator's outputs; ``real`` and
    ``params`` (C only: the form that will be flashed) default to the vehicle file's [codegen]."""
    return EstimatorStream(config, name, log.sample_time, backend, real, params)(log)


class EstimatorStream:
    """An estimator fed a log chunk by chunk (:meth:`__call__` per chunk, in order), its state
    carried across the chunk boundaries: the estimates are bit-identical to one pass over the
    whole log, and memory does not grow with the log. ``real`` and ``params`` (C only: the form
    that will be flashed) default to the vehicle file's [codegen]."""

    def __init__(self, config: VehicleConfig, name: str, sample_time: float, backend: str = "c",
                 real: str | None = None, params: str | None = None):
        self.config = config_at(config, sample_time)
        self.name = name
        self.estimator = build(name, self.config)
        self.backend = backend
        if backend == "c":
            params = params or self.config.codegen["params"]
            real = real or self.config.codegen["real"]
            self.compiled = COMPILED.get((self.config.parameter_hash(name), real, params),
                                         lambda: load_estimator(build(name, self.config, params),
                                                                render(self.config, name, real, params)))
        self.state = None

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.estimator.outputs.signals)

    def __call__(self, chunk: Log) -> Log:
        """The estimates (``t`` and the outputs) of the next chunk of the log."""
        inputs = estimator_inputs(self.estimator, chunk)
        if self.backend == "c":
            outputs, self.state = self.compiled.run_chunk(inputs, self.state)
        else:
            from vsegen.harness.reference import REFERENCES  # here: the references import scipy.signal
            from vsegen.harness.reference.loop import step_reference

            outputs, self.state = step_reference(REFERENCES[self.name], self.config, inputs, self.state)
        columns = {"t": chunk["t"].copy()}
        columns.update({name: outputs[:, i] for i, name in enumerate(self.output_names)})
        return Log(columns, source=f"<{self.name} on {chunk.source}>")
