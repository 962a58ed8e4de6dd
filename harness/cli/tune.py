"""`vsegen tune`: an estimator's numeric settings from logs with ground truth."""

from __future__ import annotations

from pathlib import Path

import click
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from vsegen.harness.cli.common import (
    CHANNELS_OPTION,
    UNIT_CHECK_OPTION,
    UserError,
    chosen_estimators,
    console,
    read_user_log,
    user_errors,
)
from vsegen.harness.project.files import write_text_atomic
from vsegen.harness.project.vehicles import load_vehicle


@click.command()
@click.option("--estimator", required=True, help="Estimator name.")
@click.option("--log", "log_paths", multiple=True, required=True, type=click.Path(path_type=Path),
              help="Training log CSV with ground truth (beta_ref, or r_ref for a yaw-rate estimator); repeatable.")
@click.option("--vehicle", type=click.Path(path_type=Path), required=True, help="Vehicle TOML to start from.")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="Tuned vehicle TOML to write.")
@click.option("--holdout", "holdout_paths", multiple=True, type=click.Path(path_type=Path),
              help="Hold-out log CSV, scored but never searched on (repeatable).")
@click.option("--trials", default=40, show_default=True, help="Candidates to evaluate.")
@click.option("--objective", type=click.Choice(["rmse", "max", "mean"]), default="rmse", show_default=True,
              help="Per-log error statistic, averaged over the logs.")
@click.option("--seed", default=1, show_default=True, help="Seed of the search.")
@click.option("--batch", default=8, show_default=True,
              help="Candidates asked at a time (part of the result: keep it to reproduce a run).")
@click.option("--scheduler", default=None,
              help="'local' (default; a Dask LocalCluster on this machine), 'serial', or a Dask scheduler "
                   "address such as tcp://host:8786 (also $VSEGEN_SCHEDULER).")
@click.option("--plot", "plot_path", type=click.Path(path_type=Path), default=None,
              help="PNG of the search (default: next to --out).")
@CHANNELS_OPTION
@UNIT_CHECK_OPTION
@user_errors
def tune(estimator: str, log_paths: tuple[Path, ...], vehicle: Path, out: Path, holdout_paths: tuple[Path, ...],
         trials: int, objective: str, seed: int, batch: int, scheduler: str | None, plot_path: Path | None,
         channels: Path | None, no_unit_check: bool) -> None:
    """Tune an estimator's numeric settings on logs with ground truth, running its generated C."""
    from vsegen.harness.jobs.pool import ClusterError
    from vsegen.harness.score.plot import tuning_plot
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
                                   lambda done, total: progress.update(task, completed=done, total=total))
        except (TuneError, ClusterError) as exc:
            raise UserError(str(exc)) from None
    write_text_atomic(out, result.text)
    output, _ = scored_output(config, estimator)
    unit = "deg" if output == "beta" else "deg/s"
    table = Table(title=f"{estimator}: {objective} of {output} ({unit}), {trials} trials")
    for column in ("", "training", "hold-out"):
        table.add_column(column, justify="right")
    for label, train_value, holdout_value in (("before", result.baseline_train, result.baseline_holdout),
                                               ("after", result.tuned_train, result.tuned_holdout)):
        table.add_row(label, f"{train_value * DEGREES:.4f}",
                      "-" if holdout_value is None else f"{holdout_value * DEGREES:.4f}")
    console.print(table)
    for dim in result.dimensions:
        if dim.label in result.best.point:
            console.print(f"  {dim.label} = {result.best.point[dim.label]:.4g}")
    plot_path = plot_path or out.with_suffix(".png")
    tuning_plot([s * DEGREES for s in (t.score for t in result.trials)], result.baseline_train * DEGREES,
                result.tuned_train * DEGREES,
                None if result.baseline_holdout is None else result.baseline_holdout * DEGREES,
                None if result.tuned_holdout is None else result.tuned_holdout * DEGREES, unit, plot_path,
                f"vsegen tune {estimator} ({config.name})")
    console.print(f"wrote {out} and {plot_path}")
