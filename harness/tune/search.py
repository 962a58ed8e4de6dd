"""``vsegen tune``: an estimator's numeric settings searched against logs with ground truth.

Each candidate is scored by running the **generated C** (the calibratable double build, compiled
once per worker with a writable calibration, :func:`harness.host.build.load_tuning_estimator`) over every
training log; the objective compares its sideslip angle with ``beta_ref`` (or its yaw rate with
``r_ref`` for a yaw-rate estimator). The search is Optuna's TPE sampler with a fixed seed, asking
a fixed batch of candidates at a time, so the candidates and their scores are the same whether the
runs went serially, to a local cluster or to a remote scheduler (:mod:`harness.jobs.pool`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from vsegen.harness.host.build import load_tuning_estimator
from vsegen.harness.host.run_log import config_at, estimator_inputs
from vsegen.harness.jobs.memo import Memo
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.logs.table import Log
from vsegen.harness.project.vehicles import with_settings
from vsegen.model.calibration import calibration_values
from vsegen.model.estimator import Tunable
from vsegen.model.estimators import DEFINITIONS, build
from vsegen.model.params import ParameterError, VehicleConfig, parse_vehicle
from vsegen.model.schema import rounded, shown

OBJECTIVES = ("rmse", "max", "mean")
"""Per log: RMSE, largest |error| or mean |error|; averaged over the logs."""
SPIN_SIDESLIP = np.radians(15.0)
"""A log is scored up to the first sample where |beta_ref| exceeds this (the car spins: beyond
what a sideslip estimator is specified for, and a few seconds of it would decide the search)."""
DEGREES = 180.0 / np.pi


class TuneError(ValueError):
    """The tuning request cannot be met (e.g. no ground truth); the message is one line."""


@dataclass(frozen=True)
class Scored:
    """One log prepared for scoring: the estimator's inputs and the truth of the scored output."""

    name: str
    inputs: np.ndarray
    truth: np.ndarray
    output: int
    sample_time: float


@dataclass(frozen=True)
class Dimension:
    """One searched number: entry ``index`` of setting ``key`` (None for a scalar)."""

    key: str
    index: int | None
    range: Tunable

    @property
    def label(self) -> str:
        return self.key if self.index is None else f"{self.key}[{self.index}]"


def scored_output(config: VehicleConfig, name: str) -> tuple[str, str]:
    """(output, truth column): beta against beta_ref, or r against r_ref for yaw-rate estimators."""
    outputs = build(name, config).outputs.names
    return ("beta", "beta_ref") if "beta" in outputs else ("r", "r_ref")


def prepare(config: VehicleConfig, name: str, logs: Sequence[Log]) -> list[Scored]:
    """The logs as the estimator reads them; one-line error when one lacks the truth column."""
    output, truth = scored_output(config, name)
    estimator = build(name, config)
    prepared = []
    for log in logs:
        if truth not in log:
            raise TuneError(f"{log.source}:1: missing column '{truth}': tune scores {name}'s {output} "
                            f"against it (a log with ground truth, e.g. an optical or GNSS/INS reference)")
        inputs = estimator_inputs(estimator, log)
        reference = np.asarray(log[truth], dtype=float)
        if truth == "beta_ref":
            spin = np.flatnonzero(np.abs(reference) > SPIN_SIDESLIP)
            if spin.size:
                reference = reference.copy()
                reference[spin[0]:] = np.nan
        prepared.append(Scored(str(log.source).rsplit("/", 1)[-1], inputs,
                               reference, estimator.outputs.index(output), log.sample_time))
    return prepared


def dimensions(config: VehicleConfig, name: str) -> list[Dimension]:
    """Every number ``tune`` searches for ``name``: its tunable settings, list entries and matrix
    diagonals one by one."""
    settings = config.settings(name)
    dims = []
    for key, tunable in DEFINITIONS[name].tunable.items():
        if not tunable.applies(settings):
            continue
        value = settings[key]
        if isinstance(value, tuple):
            dims += [Dimension(key, i, tunable) for i in range(len(value))]
        else:
            dims.append(Dimension(key, None, tunable))
    return dims


def settings_text(text: str, name: str, config: VehicleConfig, point: dict[str, float],
                  comment: str | None = None) -> str:
    """The vehicle file ``text`` with the searched numbers of ``point`` (by label) written in, each
    changed line's comment replaced by ``comment`` (plus the value it replaced) if given."""
    values: dict[str, object] = {}
    settings = config.settings(name)
    for dim in dimensions(config, name):
        if dim.label not in point:
            continue
        if dim.index is None:
            values[dim.key] = point[dim.label]
        else:
            current = values.get(dim.key) or [row[i] if isinstance(row, tuple) else row
                                               for i, row in enumerate(settings[dim.key])]
            current[dim.index] = point[dim.label]
            values[dim.key] = current
    comments = None if comment is None else {key: f"{comment}; was {shown(settings[key])}" for key in values}
    return with_settings(text, f"estimator.{name}", comments=comments, **values)


BUILDS = Memo(size=16)
"""Per worker process: the tuning build of (vehicle fingerprint, estimator, sample time)."""


def evaluate(config: VehicleConfig, name: str, calibration: tuple[float, ...], log: Scored,
             objective: str) -> float:
    """The objective of one candidate calibration on one log (rad or rad/s; a job for the cluster)."""
    config = config_at(config, log.sample_time)
    key = (config.fingerprint(), name, config.sample_time)
    estimator = BUILDS.get(key, lambda: load_tuning_estimator(config, name))
    estimator.set_calibration(calibration)
    outputs, _ = estimator.run(log.inputs)
    error = outputs[:, log.output] - log.truth
    error = error[np.isfinite(error)]
    if objective == "rmse":
        return float(np.sqrt(np.mean(error**2)))
    if objective == "max":
        return float(np.max(np.abs(error)))
    return float(np.mean(np.abs(error)))


def objective_value(config: VehicleConfig, name: str, logs: Sequence[Log], objective: str = "rmse") -> float:
    """The objective of ``config``'s own settings over ``logs``, mean over the logs (in process)."""
    calibration = calibration_values(config, name, build(name, config, "calibratable").parameters.names)
    return float(np.mean([evaluate(config, name, calibration, log, objective) for log in prepare(config, name, logs)]))


@dataclass
class Trial:
    point: dict[str, float]
    score: float


@dataclass
class TuneResult:
    """The search's trials (in order), the best point and the scores before and after."""

    dimensions: list[Dimension]
    trials: list[Trial]
    best: Trial
    baseline_train: float
    tuned_train: float
    baseline_holdout: float | None
    tuned_holdout: float | None
    text: str
    """The tuned vehicle file."""


def _calibration(text: str, source: str, vehicle_name: str, name: str,
                 names: tuple[str, ...]) -> tuple[float, ...] | None:
    """The calibration vector (entries ``names``) of a candidate file, or None if its settings
    break a rule."""
    try:
        config = parse_vehicle(text, source, vehicle_name)
    except ParameterError:
        return None
    return calibration_values(config, name, names)


def tune(text: str, config: VehicleConfig, name: str, train: Sequence[Log], holdout: Sequence[Log],
         trials: int, objective: str = "rmse", seed: int = 1, batch: int = 8, scheduler: str | None = None,
         on_progress: Callable[[int, int], None] | None = None) -> TuneResult:
    """Search ``name``'s tunable settings of the vehicle file ``text`` (validated as ``config``)."""
    import optuna

    if objective not in OBJECTIVES:
        raise TuneError(f"--objective {objective}: expected one of {', '.join(OBJECTIVES)}")
    if not DEFINITIONS[name].tunable:
        raise TuneError(f"estimator {name} declares no tunable settings")
    train_logs, holdout_logs = prepare(config, name, train), prepare(config, name, holdout)
    dims = dimensions(config, name)
    names = build(name, config, "calibratable").parameters.names
    total_runs = trials * len(train_logs) + 2 * (len(train_logs) + len(holdout_logs))
    done = 0

    def progress(*_):
        nonlocal done
        done += 1
        if on_progress:
            on_progress(done, total_runs)

    def scores(cluster: DaskPool, calibrations: list[tuple[float, ...] | None], logs: list[Scored]) -> list[float]:
        jobs = [(config, name, c, log, objective) for c in calibrations if c is not None for log in logs]
        flat = iter(cluster.map(evaluate, jobs, progress))
        return [float(np.mean([next(flat) for _ in logs])) if c is not None else float("inf") for c in calibrations]

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, n_startup_trials=min(10, trials))
    study = optuna.create_study(direction="minimize", sampler=sampler)
    base = calibration_values(config, name, names)
    history: list[Trial] = []
    with DaskPool(scheduler) as cluster:
        baseline_train, = scores(cluster, [base], train_logs)
        while len(history) < trials:
            asked = [study.ask() for _ in range(min(batch, trials - len(history)))]
            points = [{d.label: t.suggest_float(d.label, d.range.low, d.range.high, log=d.range.log)
                       for d in dims} for t in asked]
            calibrations = [_calibration(settings_text(text, name, config, p), config.source, config.name,
                                         name, names) for p in points]
            for trial, point, value in zip(asked, points, scores(cluster, calibrations, train_logs)):
                if np.isfinite(value):
                    study.tell(trial, value)
                else:
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                history.append(Trial(point, value))
        best = min(history, key=lambda t: t.score)
        if best.score >= baseline_train:  # nothing beat the settings we started from
            best = Trial({}, baseline_train)
        tuned_text = settings_text(text, name, config, {k: rounded(v) for k, v in best.point.items()},
                                   f"tuned by vsegen tune ({objective} over {len(train_logs)} log(s), "
                                   f"{trials} trials, seed {seed})")
        tuned = _calibration(tuned_text, config.source, config.name, name, names)
        tuned_train, = scores(cluster, [tuned], train_logs)
        baseline_holdout = tuned_holdout = None
        if holdout_logs:
            baseline_holdout, tuned_holdout = scores(cluster, [base, tuned], holdout_logs)
    return TuneResult(dims, history, best, baseline_train, tuned_train, baseline_holdout, tuned_holdout,
                      tuned_text)

