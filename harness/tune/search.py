"""``vsegen tune``: an estimator's numeric settings searched against logs with ground truth, so that
the result generalises or is refused.

Each candidate is scored by running the **generated C** (the calibratable double build, compiled
once per worker with a writable calibration, :func:`harness.host.build.load_tuning_estimator`) over
every training log; a log's score compares its sideslip angle with ``beta_ref`` (or its yaw rate
with ``r_ref`` for a yaw-rate estimator). The search is Optuna's TPE sampler with a fixed seed,
asking a fixed batch of candidates at a time, so the candidates and their scores are the same
whether the runs went serially, to a local cluster or to a remote scheduler
(:mod:`harness.jobs.pool`). Around it:

* only the settings whose regime the training logs cover are searched (:mod:`.coverage`), and a
  sensor noise ``identify`` measured for this car only within MEASURED_SPAN of its value;
* candidates are ranked by :mod:`.objective` (silent candidates rejected, mean and worst log, a
  prior towards the base settings);
* leave-one-log-out cross-validation of the whole choice: for each training log, the candidate
  the other logs would have chosen, scored on the log left out;
* do no harm: the result lists where the chosen settings are worse than the base by more than
  HARM_MARGIN (a training log, the cross-validated score, the hold-out) or silently wrong on the
  hold-out; the command then writes nothing unless told to.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from vsegen.harness.host.build import load_tuning_estimator
from vsegen.harness.host.run_log import config_at, estimator_inputs
from vsegen.harness.jobs.memo import Memo
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.logs.table import Log
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.score.metrics import longest_silent_stretch
from vsegen.harness.tune import objective as rule
from vsegen.harness.tune.coverage import Coverage, coverage, frozen_settings
from vsegen.model.calibration import calibration_values
from vsegen.model.estimator import Tunable
from vsegen.model.estimators import DEFINITIONS, build
from vsegen.model.params import ParameterError, VehicleConfig, parse_vehicle
from vsegen.model.schema import rounded, shown

OBJECTIVES = ("rmse", "max", "mean")
"""Per log: RMSE, largest |error| or mean |error| (combined over the logs by :mod:`.objective`)."""
SPIN_SIDESLIP = np.radians(15.0)
"""A log is scored up to the first sample where |beta_ref| exceeds this (the car spins: beyond
what a sideslip estimator is specified for, and a few seconds of it would decide the search)."""
DEGREES = 180.0 / np.pi
HARM_MARGIN = 0.05
"""Worse than the base by more than this share is harm."""
MEASURED_SPAN = 4.0
"""A sensor-noise setting ``identify`` measured for this car (a ``Definition.derived`` setting of
``*_noise`` quantities, in a file whose ``derived_for`` is its [vehicle]'s fingerprint) is searched
only within this factor of its value (2x in sigma for a variance): a Kalman filter's R may absorb
some model error, it may not replace a measurement (a dry-track tune had moved the a_y noise 60x)."""


class TuneError(ValueError):
    """The tuning request cannot be met (e.g. no ground truth); the message is one line."""


@dataclass(frozen=True)
class Scored:
    """One log prepared for scoring: the estimator's inputs, the truth of the scored output (NaN
    from a spin on), its time stamps and the output and status indices (status None: not a
    sideslip estimator, no silent-error rule)."""

    name: str
    inputs: np.ndarray
    truth: np.ndarray
    t: np.ndarray
    output: int
    status: int | None
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
        prepared.append(Scored(str(log.source).rsplit("/", 1)[-1], inputs, reference,
                               np.asarray(log["t"], dtype=float), estimator.outputs.index(output),
                               estimator.outputs.index("status") if output == "beta" else None,
                               log.sample_time))
    return prepared


def measured_settings(config: VehicleConfig, name: str) -> tuple[str, ...]:
    """The settings of ``name`` that hold sensor noises ``identify`` measured for this car."""
    if config.derived_for != config.vehicle_fingerprint():
        return ()
    return tuple(key for key, rule in DEFINITIONS[name].derived.items()
                 if all(quantity.endswith("_noise") for quantity in rule.quantities))


def dimensions(config: VehicleConfig, name: str, frozen: Sequence[str] = ()) -> list[Dimension]:
    """Every number ``tune`` searches for ``name``: its tunable settings (but ``frozen``), list
    entries and matrix diagonals one by one; a measured noise within MEASURED_SPAN of its value."""
    settings = config.settings(name)
    measured = measured_settings(config, name)
    dims = []
    for key, tunable in DEFINITIONS[name].tunable.items():
        if not tunable.applies(settings) or key in frozen:
            continue
        value = settings[key]
        if isinstance(value, tuple):
            dims += [Dimension(key, i, tunable) for i in range(len(value))]
        else:
            dims.append(Dimension(key, None, tunable))
    base = base_point(config, name, dims)
    return [replace(d, range=replace(d.range, low=max(d.range.low, base[d.label] / MEASURED_SPAN),
                                     high=min(d.range.high, base[d.label] * MEASURED_SPAN)))
            if d.key in measured else d for d in dims]


def base_point(config: VehicleConfig, name: str, dims: Sequence[Dimension]) -> dict[str, float]:
    """The base file's value of every searched number, by label."""
    settings = config.settings(name)

    def value(dim: Dimension) -> float:
        entry = settings[dim.key]
        if dim.index is None:
            return float(entry)
        row = entry[dim.index]
        return float(row[dim.index] if isinstance(row, tuple) else row)

    return {dim.label: value(dim) for dim in dims}


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
             objective: str) -> tuple[float, float]:
    """(score in rad or rad/s, longest silent stretch in s) of one candidate calibration on one log
    (a job for the cluster)."""
    config = config_at(config, log.sample_time)
    key = (config.fingerprint(), name, config.sample_time)
    estimator = BUILDS.get(key, lambda: load_tuning_estimator(config, name))
    estimator.set_calibration(calibration)
    outputs, _ = estimator.run(log.inputs)
    error = outputs[:, log.output] - log.truth
    stretch = 0.0
    if log.status is not None:
        stretch, _ = longest_silent_stretch(log.t, error, outputs[:, log.status], ~np.isfinite(log.truth))
    error = error[np.isfinite(log.truth)]
    if objective == "rmse":
        return float(np.sqrt(np.mean(error**2))), stretch
    if objective == "max":
        return float(np.max(np.abs(error))), stretch
    return float(np.mean(np.abs(error))), stretch


def objective_value(config: VehicleConfig, name: str, logs: Sequence[Log], objective: str = "rmse") -> float:
    """The mean over ``logs`` of ``config``'s own settings' score (in process)."""
    calibration = calibration_values(config, name, build(name, config, "calibratable").parameters.names)
    return float(np.mean([evaluate(config, name, calibration, log, objective)[0]
                          for log in prepare(config, name, logs)]))


@dataclass
class Trial:
    """One candidate: its searched numbers, per-log scores and silent stretches on the training
    logs, and its rank value (:func:`objective.ranked`; inf when rejected or invalid)."""

    point: dict[str, float]
    scores: list[float]
    stretches: list[float]
    distance: float
    """From the base point (:func:`objective.distance`)."""
    rank: float

    @property
    def score(self) -> float:
        """The combined score without the prior (what the search plot shows)."""
        return rule.combined(self.scores) if not rule.silent(self.stretches) else rule.REJECTED


@dataclass
class TuneResult:
    """The search's trials, the chosen point, its scores against the base's, and where it harms."""

    coverage: Coverage
    frozen: dict[str, str]
    dimensions: list[Dimension]
    trials: list[Trial]
    base: Trial
    best: Trial
    train_names: list[str]
    cross_validated: tuple[float, float]
    """Leave-one-log-out mean score: (base, the choice)."""
    holdout: tuple[float, float] | None
    """Mean hold-out score: (base, chosen)."""
    holdout_silent: tuple[float, float] | None
    """Longest silent stretch on the hold-out (s): (base, chosen)."""
    harm: list[str]
    text: str
    """The tuned vehicle file (its header comments say how it was tuned)."""

    @property
    def unchanged(self) -> bool:
        """No candidate beat the base settings: the choice is the base itself."""
        return self.best is self.base


def _calibration(text: str, source: str, vehicle_name: str, name: str,
                 names: tuple[str, ...]) -> tuple[float, ...] | None:
    """The calibration vector (entries ``names``) of a candidate file, or None if its settings
    break a rule."""
    try:
        config = parse_vehicle(text, source, vehicle_name)
    except ParameterError:
        return None
    return calibration_values(config, name, names)


class _Runs:
    """Scores candidates on logs through the pool, counting the runs for the progress callback."""

    def __init__(self, pool: DaskPool, config: VehicleConfig, name: str, objective: str,
                 on_progress: Callable[[int, int], None] | None, total: int) -> None:
        self.pool, self.config, self.name, self.objective = pool, config, name, objective
        self.on_progress, self.total, self.done = on_progress, total, 0

    def __call__(self, calibrations: list[tuple[float, ...] | None],
                 logs: list[Scored]) -> list[tuple[list[float], list[float]] | None]:
        """Per calibration (None: an invalid file), its (scores, silent stretches) per log."""
        jobs = [(self.config, self.name, c, log, self.objective) for c in calibrations if c is not None
                for log in logs]
        flat = iter(self.pool.map(evaluate, jobs, self._progress))
        results = []
        for c in calibrations:
            pairs = [next(flat) for _ in logs] if c is not None else None
            results.append(None if pairs is None else ([s for s, _ in pairs], [x for _, x in pairs]))
        return results

    def _progress(self, *_) -> None:
        self.done += 1
        if self.on_progress:
            self.on_progress(self.done, self.total)


def tune(text: str, config: VehicleConfig, name: str, train: Sequence[Log], holdout: Sequence[Log],
         trials: int, objective: str = "rmse", seed: int = 1, batch: int = 8, scheduler: str | None = None,
         on_progress: Callable[[int, int], None] | None = None, free: Sequence[str] = ()) -> TuneResult:
    """Search ``name``'s tunable settings of the vehicle file ``text`` (validated as ``config``);
    ``free`` names settings to search even where the logs do not cover their regime."""
    if objective not in OBJECTIVES:
        raise TuneError(f"--objective {objective}: expected one of {', '.join(OBJECTIVES)}")
    tunable = DEFINITIONS[name].tunable
    if not tunable:
        raise TuneError(f"estimator {name} declares no tunable settings")
    unknown = [key for key in free if key not in tunable]
    if unknown:
        raise TuneError(f"--free {unknown[0]}: not a tunable setting of {name}: expected one of {', '.join(tunable)}")
    cover = coverage(train, config)
    settings = config.settings(name)
    frozen = frozen_settings({key: t.regime for key, t in tunable.items() if t.applies(settings)}, cover, free)
    train_logs, holdout_logs = prepare(config, name, train), prepare(config, name, holdout)
    dims = dimensions(config, name, tuple(frozen))
    names = build(name, config, "calibratable").parameters.names
    total = trials * len(train_logs) + 2 * (len(train_logs) + len(holdout_logs))
    with DaskPool(scheduler) as pool:
        runs = _Runs(pool, config, name, objective, on_progress, total)
        history, base = _search(text, config, name, dims, names, runs, train_logs, trials, seed, batch)
        best = min(history, key=lambda t: t.rank) if history else base
        if not best.rank < base.rank:           # nothing beat the settings we started from
            best = base
        comment = f"tuned by vsegen tune ({objective} over {len(train_logs)} log(s), {trials} trials, seed {seed})"
        chosen_text = settings_text(text, name, config, {k: rounded(v) for k, v in best.point.items()}, comment)
        chosen = _calibration(chosen_text, config.source, config.name, name, names)
        chosen_scores, chosen_stretches = runs([chosen], train_logs)[0]
        best = Trial(best.point, chosen_scores, chosen_stretches, best.distance, best.rank)   # as written
        holdout_runs = runs([_calibration(text, config.source, config.name, name, names), chosen],
                            holdout_logs) if holdout_logs else None
    result = TuneResult(cover, frozen, dims, history, base, best, [log.name for log in train_logs],
                        cross_validated([base, *history], base), None, None, [], chosen_text)
    if holdout_runs:
        (base_h, base_hs), (chosen_h, chosen_hs) = holdout_runs
        result.holdout = (float(np.mean(base_h)), float(np.mean(chosen_h)))
        result.holdout_silent = (max(base_hs), max(chosen_hs))
    result.harm = harm(result)
    result.text = header(result, name, objective) + chosen_text
    return result


def _search(text: str, config: VehicleConfig, name: str, dims: list[Dimension], names: tuple[str, ...],
            runs: _Runs, logs: list[Scored], trials: int, seed: int, batch: int) -> tuple[list[Trial], Trial]:
    """The TPE search: (its trials in order, the base's trial)."""
    import optuna

    base_values = base_point(config, name, dims)
    scales = {d.label: (d.range.low, d.range.high, d.range.log) for d in dims}
    (base_scores, base_stretches), = runs([calibration_values(config, name, names)], logs)
    base_combined = rule.combined(base_scores)
    base = Trial({}, base_scores, base_stretches, 0.0, rule.ranked(base_scores, base_stretches, 0.0, base_combined))
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, n_startup_trials=min(10, trials))
    study = optuna.create_study(direction="minimize", sampler=sampler)
    history: list[Trial] = []
    while len(history) < trials and dims:
        asked = [study.ask() for _ in range(min(batch, trials - len(history)))]
        points = [{d.label: t.suggest_float(d.label, d.range.low, d.range.high, log=d.range.log) for d in dims}
                  for t in asked]
        calibrations = [_calibration(settings_text(text, name, config, p), config.source, config.name, name, names)
                        for p in points]
        for trial, point, scored in zip(asked, points, runs(calibrations, logs)):
            if scored is None:
                history.append(Trial(point, [], [], 0.0, rule.REJECTED))
                study.tell(trial, state=optuna.trial.TrialState.FAIL)
                continue
            distance = rule.distance(point, base_values, scales)
            rank = rule.ranked(*scored, distance, base_combined)
            history.append(Trial(point, *scored, distance, rank))
            if np.isfinite(rank):
                study.tell(trial, rank)
            else:
                study.tell(trial, state=optuna.trial.TrialState.FAIL)
    return history, base


def cross_validated(candidates: Sequence[Trial], base: Trial) -> tuple[float, float]:
    """Leave-one-log-out: for each training log, the candidate (the base among them) the other logs
    rank best, scored on the log left out; (the base's mean, the choice's mean) over the logs.
    With one log there is nothing to leave out: (the base's score, the best's score)."""
    usable = [c for c in candidates if c.scores]
    logs = len(base.scores)
    if logs < 2:
        return base.scores[0], min(usable, key=lambda c: c.rank).scores[0]
    left_out = []
    for k in range(logs):
        rest = [i for i in range(logs) if i != k]
        base_rest = rule.combined([base.scores[i] for i in rest])
        choice = min(usable, key=lambda c, rest=rest, base_rest=base_rest: rule.ranked(
            [c.scores[i] for i in rest], [c.stretches[i] for i in rest], c.distance, base_rest))
        left_out.append(choice.scores[k])
    return float(np.mean(base.scores)), float(np.mean(left_out))


def harm(result: TuneResult) -> list[str]:
    """Where the chosen settings do harm (one line each; empty: none): worse than the base by more
    than HARM_MARGIN on a training log, in the cross-validated score or on the hold-out, or silently
    wrong on the hold-out where the base was not. When nothing beat the base, the choice is the base
    and harms nothing (its cross-validated score may still be worse: it rates the search, whose
    folds may choose other candidates, not the settings written)."""
    if result.unchanged:
        return []
    found = []
    for log, base, chosen in zip(result.train_names, result.base.scores, result.best.scores):
        if chosen > (1 + HARM_MARGIN) * base:
            found.append(f"training log {log}: {chosen * DEGREES:.4f} against {base * DEGREES:.4f} for the base")
    base_cv, chosen_cv = result.cross_validated
    if chosen_cv > (1 + HARM_MARGIN) * base_cv:
        found.append(f"cross-validated (leave one log out): {chosen_cv * DEGREES:.4f} against "
                     f"{base_cv * DEGREES:.4f} for the base")
    if result.holdout is not None:
        base_h, chosen_h = result.holdout
        if chosen_h > (1 + HARM_MARGIN) * base_h:
            found.append(f"hold-out: {chosen_h * DEGREES:.4f} against {base_h * DEGREES:.4f} for the base")
        base_s, chosen_s = result.holdout_silent
        if rule.silent([chosen_s]) and not rule.silent([base_s]):
            found.append(f"hold-out: silently wrong for {chosen_s:.2f} s (the base: {base_s:.2f} s)")
    return found


def header(result: TuneResult, name: str, objective: str) -> str:
    """The tuned file's header comments: coverage, settings kept, cross-validated and hold-out scores."""
    base_cv, chosen_cv = result.cross_validated
    lines = [f"# vsegen tune {name}: training coverage: {result.coverage.describe()}",
             *(f"# kept at its base value: {key} ({why})" for key, why in result.frozen.items()),
             f"# cross-validated {objective} (leave one log out), base -> tuned: {base_cv * DEGREES:.4f} -> "
             f"{chosen_cv * DEGREES:.4f} (deg, or deg/s for a yaw rate)"]
    if result.holdout is not None:
        lines.append(f"# hold-out {objective}, base -> tuned: {result.holdout[0] * DEGREES:.4f} -> "
                     f"{result.holdout[1] * DEGREES:.4f}")
    return "\n".join(lines) + "\n"
