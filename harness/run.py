"""Running an estimator over a log: generated C (compiled for the log's sample time, cached) or
the NumPy reference."""

from __future__ import annotations

from codegen.generate import render
from harness.build import load_estimator
from harness.logs import Log, LogError
from harness.reference import REFERENCES
from harness.reference.run import run_reference
from model.estimators import build
from model.params import VehicleConfig

BACKENDS = ("c", "reference")
SAMPLE_TIME_DIGITS = 9
"""A log's mean sample time is rounded to this many decimals (s) before generating for it."""


def config_for_log(config: VehicleConfig, log: Log) -> VehicleConfig:
    """``config`` at the log's sample time."""
    sample_time = round(log.sample_time, SAMPLE_TIME_DIGITS)
    return config if sample_time == config.sample_time else config.with_sample_time(sample_time)


def run_estimator(config: VehicleConfig, name: str, log: Log, backend: str = "c",
                  real: str | None = None) -> Log:
    """Estimates of ``name`` over ``log``: columns ``t`` and the estimator's outputs; ``real``
    (C only) defaults to the vehicle file's [codegen] real."""
    config = config_for_log(config, log)
    estimator = build(name, config)
    missing = log.missing(estimator.inputs.names)
    if missing:
        raise LogError(f"{log.source}:1: missing column '{missing[0]}': estimator {name} needs "
                       f"{', '.join(estimator.inputs.names)}")
    inputs = log.matrix(estimator.inputs.names)
    if backend == "c":
        outputs, _ = load_estimator(estimator, render(config, name, real)).run(inputs)
    else:
        outputs, _ = run_reference(REFERENCES[name], config, inputs)
    columns = {"t": log["t"].copy()}
    columns.update({s.name: outputs[:, i] for i, s in enumerate(estimator.outputs.signals)})
    return Log(columns, source=f"<{name} on {log.source}>")
