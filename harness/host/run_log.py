"""Running an estimator over a log: generated C (compiled for the log's sample time, cached) or
the NumPy reference."""

from __future__ import annotations

from vsegen.codegen.generate import render
from vsegen.harness.host.build import load_estimator
from vsegen.harness.jobs.memo import Memo
from vsegen.harness.logs.table import Log, LogError
from vsegen.model.estimators import build, monitor_only_inputs
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
    config = estimator.parameters.numeric
    checked_only = monitor_only_inputs(config, estimator.name)
    if missing and set(missing) <= set(checked_only):
        raise LogError(f"{log.source}:1: missing column '{missing[0]}': estimator {estimator.name}'s yaw-rate check "
                       f"reads {', '.join(checked_only)}; for logs without them set "
                       f"[estimator.{estimator.name}] wheel_check_limit = 0")
    if missing and set(missing) <= set(WHEEL_SPEEDS):
        others = [n for n in config.estimators if not set(WHEEL_SPEEDS) & set(inputs_of(config, n))]
        raise LogError(f"{log.source}:1: missing column '{missing[0]}': estimator {estimator.name} needs the four "
                       f"wheel speeds ({', '.join(WHEEL_SPEEDS)}, rad/s): its 3-DOF model's longitudinal tyre "
                       "forces come from the wheels' slip, which v_x and a_x alone do not give; without wheel "
                       f"speeds run {', '.join(others) or 'an estimator that does not read them'}, or set "
                       f"[estimator.{estimator.name}] longitudinal_force = \"free_rolling\" (no longitudinal "
                       "tyre forces, a_x a random walk: a different estimator, to be scored before it is trusted)")
    if missing:
        raise LogError(f"{log.source}:1: missing column '{missing[0]}': estimator {estimator.name} needs "
                       f"{', '.join(estimator.inputs.names)}")
    return log.matrix(estimator.inputs.names)


def run_estimator(config: VehicleConfig, name: str, log: Log, backend: str = "c",
                  real: str | None = None, params: str | None = None) -> Log:
    """Estimates of ``name`` over ``log``: columns ``t`` and the estimator's outputs; ``real`` and
    ``params`` (C only: the form that will be flashed) default to the vehicle file's [codegen]."""
    return EstimatorStream(config, name, log.sample_time, backend, real, params)(log)


def without_unlogged_check(config: VehicleConfig, name: str, log: Log) -> VehicleConfig | None:
    """``config`` with estimator ``name``'s yaw-rate check off (``wheel_check_limit`` = 0) when
    ``log`` lacks only inputs that check reads beside the method's (``monitor_only_inputs``);
    else None."""
    missing = log.missing(inputs_of(config, name))
    if not missing or not set(missing) <= set(monitor_only_inputs(config, name)):
        return None
    return config.with_settings(name, wheel_check_limit=0.0)


class EstimatorStream:
    """An estimator fed a log chunk by chunk (:meth:`__call__` per chunk, in order), its state
    carried across the chunk boundaries: the estimates are bit-identical to one pass over the
    whole log, and memory does not grow with the log. ``real`` and ``params`` (C only: the form
    that will be flashed) default to the vehicle file's [codegen]. A log without the wheel speeds
    only the yaw-rate check reads runs without the check (:func:`without_unlogged_check`), said in
    :attr:`notes`."""

    def __init__(self, config: VehicleConfig, name: str, sample_time: float, backend: str = "c",
                 real: str | None = None, params: str | None = None):
        self.name = name
        self.backend = backend
        self.real, self.params = real, params
        self.notes: list[str] = []
        """What was changed for this log, a line each."""
        self._load(config_at(config, sample_time))
        self.state = None

    def _load(self, config: VehicleConfig) -> None:
        self.config = config
        self.estimator = build(self.name, config)
        if self.backend == "c":
            params = self.params or config.codegen["params"]
            real = self.real or config.codegen["real"]
            self.compiled = COMPILED.get((config.parameter_hash(self.name), real, params),
                                         lambda: load_estimator(build(self.name, config, params),
                                                                render(config, self.name, real, params)))

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.estimator.outputs.signals)

    def __call__(self, chunk: Log) -> Log:
        """The estimates (``t`` and the outputs) of the next chunk of the log."""
        if self.state is None and (unchecked := without_unlogged_check(self.config, self.name, chunk)):
            missing = chunk.missing(self.estimator.inputs.names)
            self.notes.append(f"{self.name} runs without its yaw-rate check: the log has no {', '.join(missing)} "
                              "(the flashed C reads them; set wheel_check_limit = 0 for a car without them)")
            self._load(unchecked)
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
