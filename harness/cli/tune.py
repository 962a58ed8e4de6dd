"""`vsegen tune`: an estimator's numeric settings from logs with ground truth."""

from __future__ import annotations

import sys
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from vsegen.harness.cli.common import (
    CHANNELS_OPTION,
    UNIT_CHECK_OPTION,
    UserError,
    chosen_estimators,
    console,
    print_table,
    read_user_log,
    user_errors,
)
from vsegen.harness.project.files import write_text_atomic
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.tune.search import OBJECTIVES


@click.command()
@click.option("--estimator", required=True, help="Estimator name.")
@click.option("--log", "log_paths", multiple=True, required=True, type=click.Path(path_type=Path),
              help="Training log CSV with ground truth (beta_ref, or r_ref for a yaw-rate estimator); repeatable.")
@click.option("--vehicle", type=click.Path(path_type=Path), required=True, help="Vehicle TOML to start from.")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="Tuned vehicle TOML to write.")
@click.option("--holdout", "holdout_paths", multiple=True, type=click.Path(path_type=Path),
              help="Hold-out log CSV, scored but never searched on (repeatable).")
@click.option("--trials", default=40, show_default=True, help="Candidates to evaluate.")
@click.option("--objective", type=click.Choice(OBJECTIVES), default="rmse", show_default=True,
              help="Per-log error statistic, averaged over the logs.")
@click.option("--seed", default=1, show_default=True, help="Seed of the search.")
@click.option("--batch", default=8, show_default=True,
              help="Candidates asked at a time (part of the result: keep it to reproduce a run).")
@click.option("--scheduler", default=None,
              help="'local' (default; a Dask LocalCluster on this machine), 'serial', or a Dask scheduler "
                   "address such as tcp://host:8786 (also $VSEGEN_SCHEDULER).")
@click.option("--plot", "plot_path", type=click.Path(path_type=Path), default=None,
              help="PNG of the search (default: next to --out).")
@click.option("--free", "freed", multiple=True, metavar="SETTING",
              help="Search this setting even where the training logs do not cover its regime (repeatable).")
@click.option("--accept-worse", is_flag=True,
              help="Write the tuned file even where it is worse than the base (else: nothing written, exit 3).")
@CHANNELS_OPTION
@UNIT_CHECK_OPTION
@user_errors
def tune(estimator: str, log_paths: tuple[Path, ...], vehicle: Path, out: Path, holdout_paths: tuple[Path, ...],
         trials: int, objective: str, seed: int, batch: int, scheduler: str | None, plot_path: Path | None,
         freed: tuple[str, ...], accept_worse: bool, channels: Path | None, no_unit_check: bool) -> None:
    """Tune an estimator's numeric settings on logs with ground truth, running its generated C.
    Settings whose regime the logs do not cover keep their values; a result worse than the base
    on a training log, cross-validated or on the hold-out is not written (exit 3)."""
    from vsegen.harness.jobs.pool import ClusterError
    from vsegen.harness.score.plot import tuning_plot
    from vsegen.harness.tune.objective import combined
    from vsegen.harness.tune.search import DEGREES, TuneError, scored_output
    from vsegen.harness.tune.search import tune as tune_settings

    config = load_vehicle(vehicle)
    chosen_estimators(config, (estimator,))
    if trials < 1 or batch < 1:
        raise UserError(f"--trials {trials} --batch {batch}: expected both >= 1")
    checked = None if no_unit_check else config
    train = [read_user_log(path, channels, config.sample_time, unit_check=checked) for path in log_paths]
    holdout = [read_user_log(path, channels, config.sample_time, unit_check=checked) for path in holdout_paths]
    with Progress(console=Console(stderr=True), transient=True) as progress:
        task = progress.add_task(f"tuning {estimator}", total=None)
        try:
            result = tune_settings(vehicle.read_text(), config, estimator, train, holdout, trials, objective,
                                   seed, batch, scheduler,
                                   lambda done, total: progress.update(task, completed=done, total=total), freed)
        except (TuneError, ClusterError) as exc:
            raise UserError(str(exc)) from None
    output, _ = scored_output(config, estimator)
    unit = "deg" if output == "beta" else "deg/s"
    console.print(f"training coverage: {result.coverage.describe()}")
    for key, why in result.frozen.items():
        console.print(f"kept at its base value: {key} ({why}; --free {key} to search it anyway)")
    print_table(_scores_table(result, estimator, objective, output, unit, trials))
    console.print("cross-validated: for each training log, the candidate the other logs rank best, scored on "
                  "the log left out (it rates the search; equal to the training mean when every fold "
                  "chooses the same candidate)")
    if result.unchanged:
        console.print(f"no candidate beat the base settings on the training logs: {out} keeps every value "
                      f"of {vehicle}")
    for dim in result.dimensions:
        if dim.label in result.best.point:
            console.print(f"  {dim.label} = {result.best.point[dim.label]:.4g}")
    plot_path = plot_path or out.with_suffix(".png")
    holdout = result.holdout or (None, None)
    tuning_plot([t.score * DEGREES for t in result.trials], combined(result.base.scores) * DEGREES,
                combined(result.best.scores) * DEGREES, None if holdout[0] is None else holdout[0] * DEGREES,
                None if holdout[1] is None else holdout[1] * DEGREES, unit, plot_path,
                f"vsegen tune {estimator} ({config.name})")
    if result.harm and not accept_worse:
        click.echo(f"vsegen: tune: the tuned settings are worse than the base ({'; '.join(result.harm)}): "
                   f"nothing written to {out} (--accept-worse writes them anyway)", err=True)
        sys.exit(3)
    if result.harm:
        click.echo(f"vsegen: tune: warning: written although worse than the base ({'; '.join(result.harm)})",
                   err=True)
    write_text_atomic(out, result.text)
    console.print(f"wrote {out} and {plot_path}")


def _scores_table(result, estimator: str, objective: str, output: str, unit: str, trials: int) -> Table:
    """Before and after: training (mean and worst log), cross-validated, hold-out."""
    from vsegen.harness.tune.search import DEGREES

    table = Table(title=f"{estimator}: {objective} of {output} ({unit}), {trials} trials")
    for column in ("", "training mean", "training worst", "cross-validated", "hold-out"):
        table.add_column(column, justify="right")
    for index, (label, trial) in enumerate((("before", result.base), ("after", result.best))):
        holdout = "-" if result.holdout is None else f"{result.holdout[index] * DEGREES:.4f}"
        table.add_row(label, f"{np.mean(trial.scores) * DEGREES:.4f}", f"{np.max(trial.scores) * DEGREES:.4f}",
                      f"{result.cross_validated[index] * DEGREES:.4f}", holdout)
    return table
