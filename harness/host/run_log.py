"""Running an estimator over a log: generated C (compiled for the log's sample time, cached) or
the NumPy reference."""

from __future__ import annotations

from vsegen.codegen.generate import render
from vsegen.harness.host.build import load_estimator
from vsegen.harness.logs.table import Log, LogError
from vsegen.harness.reference import REFERENCES
from vsegen.harness.reference.loop import run_reference
from vsegen.model.estimators import build
from vsegen.model.params import VehicleConfig

BACKENDS = ("c", "reference")
SAMPLE_TIME_DIGITS = 9
"""A log's mean sample time is rounded to this many decimals (s) before generating for it."""


def config_for_log(config: VehicleConfig, log: Log) -> VehicleConfig:
    """``config`` at the log's sample time."""
    return config_at(config, log.sample_time)


def config_at(config: VehicleConfig, sample_time: float) -> VehicleConfig:
    """``config`` at ``sample_time`` (s, rounded to SAMPLE_TIME_DIGITS decimals)."""
    sample_time = round(sample_time, SAMPLE_TIME_DIGITS)
    return config if sample_time == config.sample_time else config.with_sample_time(sample_time)


def estimator_inputs(estimator, log: Log):
    """The log's columns the estimator reads, as a matrix; one line when one is missing."""
    missing = log.missing(estimator.inputs.names)
    if missing:
        raise LogError(f"{log.source}:1: missing column '{missing[0]}': estimator {estimator.name} needs "
                       f"{', '.join(estimator.inputs.names)}")
    return log.matrix(estimator.inputs.names)


def run_estimator(config: VehicleConfig, name: str, log: Log, backend: str = "c",
                  real: str | None = None, params: str | None = None) -> Log:
    """Estimates of ``name`` over ``log``: columns ``t`` and the estimator's outputs; ``real`` and
    ``params`` (C only: the form that will be flashed) default to the vehicle file's [codegen]."""
    config = config_for_log(config, log)
    params = params or config.codegen["params"]
    estimator = build(name, config)
    inputs = estimator_inputs(estimator, log)
    if backend == "c":
        form = build(name, config, params)
        outputs, _ = load_estimator(form, render(config, name, real, params)).run(inputs)
    else:
        outputs, _ = run_reference(REFERENCES[name], config, inputs)
    columns = {"t": log["t"].copy()}
    columns.update({s.name: outputs[:, i] for i, s in enumerate(estimator.outputs.signals)})
    return Log(columns, source=f"<{name} on {log.source}>")
