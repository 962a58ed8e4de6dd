"""`vsegen run`: an estimator over a log, read, run and written chunk by chunk (memory does not grow
with the log), its estimates written as CSV, MDF4 or Parquet."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from vsegen.harness.cli.common import (
    CHANNELS_OPTION,
    DBC_OPTION,
    PARAMS_OPTION,
    REAL_OPTION,
    UNIT_CHECK_OPTION,
    VEHICLE_OPTION,
    UserError,
    chosen_estimators,
    console,
    open_user_log,
    say_notes,
    user_errors,
    vehicle_config,
    warn_underived,
    window_options,
)
from vsegen.harness.host.run_log import BACKENDS
from vsegen.harness.outputs.estimates import EstimatesWriter


@click.command()
@click.option("--log", "log_path", type=click.Path(path_type=Path), required=True,
              help="Input log: CSV (plain, .gz, .bz2, .xz), MDF4 (.mf4, .mdf), or raw CAN (.blf, .asc, "
                   "bus-logging .mf4) with --dbc.")
@click.option("--estimator", required=True, help="Estimator name.")
@VEHICLE_OPTION
@click.option("--backend", type=click.Choice(BACKENDS), default="c", show_default=True,
              help="Generated C (compiled for the log's sample time, cached) or the NumPy reference.")
@click.option("--out", type=click.Path(path_type=Path), required=True,
              help="Estimates to write: CSV, MDF4 when the name ends in .mf4, Parquet in .parquet.")
@REAL_OPTION
@PARAMS_OPTION
@CHANNELS_OPTION
@DBC_OPTION
@UNIT_CHECK_OPTION
@window_options
@user_errors
def run(log_path: Path, estimator: str, vehicle: Path | None, backend: str, out: Path, real: str | None,
        params: str | None, channels: Path | None, dbc: Path | None, no_unit_check: bool, start: float | None,
        stop: float | None) -> None:
    """Run an estimator over a log and write its estimates (t, beta, vy, r, status, ...). With the C
    backend, --real and --params choose the form that will be flashed (default: the vehicle file's
    [codegen])."""
    from vsegen.harness.host.run_log import EstimatorStream, inputs_of

    config = vehicle_config(vehicle)
    chosen_estimators(config, (estimator,))
    warn_underived(config, estimator)
    log = open_user_log(log_path, channels, config.sample_time, (start, stop), None if no_unit_check else config, dbc)
    if abs(log.sample_time - config.sample_time) > 1e-9 * config.sample_time:
        click.echo(f"vsegen: {log_path}: sample time {log.sample_time:.6g} s differs from [estimator] sample_time = "
                   f"{config.sample_time:g} s in {vehicle}: the estimator runs at the log's rate (rate-dependent "
                   f"settings keep their meaning in time); generate for that rate to flash the same code", err=True)
    if backend == "reference" and (real or params):
        raise UserError("--real/--params choose a form of the generated C: expected --backend c")
    form = f"{real or config.codegen['real']}, {params or config.codegen['params']}" if backend == "c" else backend
    flagged = 0
    with console.status(f"running {estimator} ({form}) on {log.samples} samples"):
        chunks = log.prefetched(names=inputs_of(config, estimator))   # parsing starts while the estimator is built
        stream = EstimatorStream(config, estimator, log.sample_time, backend, real, params)
        units = {s.name: s.unit for s in stream.estimator.outputs.signals}
        with EstimatesWriter(out, units) as writer:
            for chunk in chunks:
                estimates = stream(chunk)
                writer.write(estimates)
                flagged += int(np.count_nonzero(estimates["status"]))
    say_notes(log_path, log.notes)
    for note in stream.notes:
        click.echo(f"vsegen: {log_path}: {note}", err=True)
    console.print(f"wrote {out} ({log.samples} samples, T = {log.sample_time:.6g} s, {form}, "
                  f"{flagged} with status != 0)")
