"""`vsegen identify`: a car's parameters and car-specific settings from driving logs."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from vsegen.harness.cli.common import (
    CHANNELS_OPTION,
    UNIT_CHECK_OPTION,
    console,
    read_user_log,
    user_errors,
)
from vsegen.harness.project.files import write_text_atomic
from vsegen.harness.project.vehicles import load_vehicle


@click.command()
@click.option("--log", "log_paths", multiple=True, required=True, type=click.Path(path_type=Path),
              help="Driving log CSV (repeatable); ground truth is not needed, beta_ref is used if present.")
@click.option("--vehicle", type=click.Path(path_type=Path), required=True,
              help="Base vehicle TOML: mass, geometry and I_z are taken from it, everything else is a start.")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="Vehicle TOML to write.")
@click.option("--report", "report_path", type=click.Path(path_type=Path), default=None,
              help="Markdown report to write (estimates, intervals, refusals).")
@CHANNELS_OPTION
@UNIT_CHECK_OPTION
@user_errors
def identify(log_paths: tuple[Path, ...], vehicle: Path, out: Path, report_path: Path | None,
             channels: Path | None, no_unit_check: bool) -> None:
    """Identify the car's parameters and car-specific settings from driving logs."""
    from vsegen.harness.identify import identify as identify_logs
    from vsegen.harness.identify.vehicle_file import identified_vehicle_file, report

    config = load_vehicle(vehicle)
    checked = None if no_unit_check else config
    logs = [read_user_log(path, channels, config.sample_time, unit_check=checked) for path in log_paths]
    ident = identify_logs(logs, config)
    if not ident.estimates:
        for refusal in ident.refusals:
            click.echo(f"vsegen: not identified: {refusal.name}: {refusal.why}", err=True)
        sys.exit(2)
    text = identified_vehicle_file(vehicle.read_text(), config, ident)
    write_text_atomic(out, text)
    names = [path.name for path in log_paths]
    if report_path is not None:
        write_text_atomic(report_path, report(ident, config, names, out.name))
    for estimate in ident.estimates.values():
        console.print(f"identified      {estimate.name} = {estimate.describe()}")
    for refusal in ident.refusals:
        console.print(f"not identified  {refusal.name}: {refusal.why}")
    console.print(f"wrote {out}" + (f" and {report_path}" if report_path else ""))
