"""`vsegen score` and `vsegen plot`: estimates against the log's ground truth."""

from __future__ import annotations

from pathlib import Path

import click
from rich.table import Table

from vsegen.harness.cli.common import (
    CHANNELS_OPTION,
    DBC_OPTION,
    UserError,
    console,
    open_user_log,
    print_table,
    read_user_log,
    say_notes,
    user_errors,
    window_options,
)
from vsegen.harness.outputs.estimates import open_estimates, read_estimates


@click.command()
@click.option("--log", "log_path", type=click.Path(path_type=Path), required=True,
              help="Log with ground truth (CSV, MDF4 or raw CAN with --dbc).")
@click.option("--est", "est_path", type=click.Path(path_type=Path), required=True,
              help="Estimates from `vsegen run` (CSV, .mf4 or .parquet).")
@CHANNELS_OPTION
@DBC_OPTION
@window_options
@user_errors
def score(log_path: Path, est_path: Path, channels: Path | None, dbc: Path | None, start: float | None,
          stop: float | None) -> None:
    """Errors of the estimates against ground truth: max, mean and RMSE (seed 000 Table 3)."""
    from vsegen.harness.score.metrics import score_sources

    log = open_user_log(log_path, channels, lambda: open_estimates(est_path).sample_time, (start, stop), dbc=dbc)
    estimates = open_estimates(est_path)
    with console.status(f"scoring {est_path} ({estimates.samples} samples)"):
        sums = score_sources(log, estimates)
        scores = sums.result()
    say_notes(log_path, log.notes)
    table = Table(title=f"{est_path} against {log_path}")
    for column in ("signal", "samples", "max |e|", "mean |e|", "RMSE"):
        table.add_column(column, justify="left" if column == "signal" else "right")
    for s in scores:
        table.add_row(f"{s.signal} ({s.unit})", str(s.samples), f"{s.max:.3f}", f"{s.mean:.3f}",
                      f"{s.rmse:.3f}")
    print_table(table)
    if sums.first_off_course is not None:
        console.print(f"warning: the run left the course or spun from t = {sums.first_off_course:.2f} s "
                      f"(column off_course); these scores include those samples")


@click.command()
@click.option("--log", "log_path", type=click.Path(path_type=Path), required=True,
              help="Log (CSV, MDF4 or raw CAN with --dbc), with or without ground truth.")
@click.option("--est", "est_paths", type=click.Path(path_type=Path), multiple=True, required=True,
              help="Estimates from `vsegen run` (CSV, .mf4 or .parquet; repeatable).")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="PNG to write.")
@CHANNELS_OPTION
@DBC_OPTION
@window_options
@user_errors
def plot(log_path: Path, est_paths: tuple[Path, ...], out: Path, channels: Path | None, dbc: Path | None,
         start: float | None, stop: float | None) -> None:
    """Plot beta against the reference and |delta beta| over time (seed 000 Fig. 8 style); without a
    reference in the log, the estimates and their status."""
    from vsegen.harness.score.plot import plot as draw

    log = read_user_log(log_path, channels, lambda: read_estimates(est_paths[0]).sample_time, (start, stop),
                        dbc=dbc)
    estimates = {}
    for path in est_paths:
        est = read_estimates(path)
        if len(est) != len(log):
            raise UserError(f"{path}: {len(est)} samples: expected {len(log)} like {log_path}")
        estimates[path.stem] = est
    draw(log, estimates, out, title=log_path.name)
    console.print(f"wrote {out}")
