"""`vsegen init` (a starter project for the user's own car), `vsegen list` and `vsegen docs` (the
reference pages generated from the code)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from vsegen.harness.cli.common import (
    UserError,
    console,
    display,
    user_errors,
)
from vsegen.harness.project.files import file_diff, write_text_atomic
from vsegen.harness.project.paths import project, shipped_vehicle_names
from vsegen.harness.sim import disturbances
from vsegen.harness.sim.scenarios import SCENARIOS
from vsegen.harness.starter import reference_docs
from vsegen.model.estimators import DEFINITIONS


@click.command()
@click.argument("folder", type=click.Path(path_type=Path))
@click.option("--like", default="c_class", show_default=True,
              help="Shipped vehicle whose values the starter vehicle file begins with.")
@user_errors
def init(folder: Path, like: str) -> None:
    """Start a project in FOLDER for your own car: vehicles/car.toml (commented, to edit),
    channels.toml (a channel-map example) and a README with the next commands."""
    from vsegen.harness.starter.files import StarterError, init_project

    try:
        written = init_project(folder, like)
    except StarterError as exc:
        raise UserError(str(exc)) from None
    for path in written:
        console.print(f"wrote {display(path)}")
    console.print(f"next: cd {display(folder)} && vsegen generate")


@click.command(name="list")
def list_() -> None:
    """List the estimators, scenarios and vehicles vsegen knows."""
    console.print("estimators: " + ", ".join(DEFINITIONS))
    console.print("scenarios:")
    for s in SCENARIOS.values():
        options = " ".join(f"{k}={v}" for k, v in s.defaults.items() if k not in disturbances.OPTIONS)
        console.print(f"  {s.name}: {s.description}" + (f"  [options: {options}]" if options else ""),
                      markup=False)  # the brackets are text, not rich markup
    console.print("disturbances, options of every scenario (--set KEY=VALUE; neutral value, unit):")
    console.print("  " + "; ".join(f"{k}={v} ({disturbances.UNITS[k]})" for k, v in disturbances.OPTIONS.items()),
                  markup=False)
    files = project().vehicle_files()
    if files:
        console.print("vehicles:   " + ", ".join(display(p) for p in files))
    else:
        console.print(f"vehicles:   none in this project ({display(project().vehicles)}); shipped with vsegen: "
                      f"{', '.join(shipped_vehicle_names())} (`vsegen init DIR` starts a project)")


@click.command()
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Folder to write the pages into. Default: the project's docs/.")
@click.option("--check", "check_only", is_flag=True,
              help="Do not write: compare with --out and print a unified diff of what would change.")
@user_errors
def docs(out: Path | None, check_only: bool) -> None:
    """Write the reference pages: conventions.md (units, signs, the log format, channel maps),
    vehicle-file.md (every key, unit, default, check and meaning) and signals.md (log columns,
    status bits), the last two generated from the code."""
    out = out or project().reports
    pages = reference_docs.pages()
    if check_only:
        stale = [diff for name, text in pages.items() if (diff := file_diff(out / name, text, display(out / name)))]
        for diff in stale:
            click.echo(diff, nl=False)
        if stale:
            click.echo(f"vsegen: reference pages are stale in {display(out)}: run `vsegen docs`", err=True)
            sys.exit(1)
        console.print(f"up to date  {', '.join(display(out / name) for name in pages)}")
        return
    for name, text in pages.items():
        write_text_atomic(out / name, text)
        console.print(f"wrote {display(out / name)}")
