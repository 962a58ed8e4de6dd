"""`vsegen simulate`: a scenario on the truth plant, written as a log."""

from __future__ import annotations

from pathlib import Path

import click
from rich.progress import Progress

from vsegen.harness.cli.common import (
    VEHICLE_OPTION,
    UserError,
    console,
    user_errors,
    vehicle_config,
)
from vsegen.harness.logs.table import write_log
from vsegen.harness.sim.scenarios import SCENARIOS, Case, parse_option


@click.command()
@click.argument("scenario")
@VEHICLE_OPTION
@click.option("--set", "options", multiple=True, metavar="KEY=VALUE",
              help="Scenario option (repeatable), e.g. --set speed_kmh=120 --set mu=0.5.")
@click.option("--seed", default=1, show_default=True, help="Seed of the sensor noise.")
@click.option("--rate", default=100.0, show_default=True, help="Log rate in Hz.")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="Log CSV to write.")
@click.option("--no-truth", is_flag=True, help="Leave out the ground-truth columns (a logger's view).")
@user_errors
def simulate(scenario: str, vehicle: Path | None, options: tuple[str, ...], seed: int, rate: float,
             out: Path, no_truth: bool) -> None:
    """Simulate SCENARIO on the truth plant and write its log (the format of docs/conventions.md)."""
    if scenario not in SCENARIOS:
        raise UserError(f"unknown scenario '{scenario}': expected one of {', '.join(SCENARIOS)}")
    if not rate > 0:
        raise UserError(f"--rate {rate}: expected a rate in Hz > 0")
    config = vehicle_config(vehicle)
    case = Case.of(scenario, **dict(parse_option(scenario, o) for o in options))
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task(f"simulating {case.label} at {rate:g} Hz", total=1.0)
        log = case.simulate(config, rate, seed,
                            progress=lambda done: progress.update(task, completed=done))
    if no_truth:
        log = log.without_truth()
    write_log(log, out)
    report = ", ".join(f"{k}: {v}" for k, v in log.notes.items())
    console.print(f"wrote {out} ({len(log)} samples, {log['t'][-1]:.2f} s): {report}")
