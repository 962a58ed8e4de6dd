"""`vsegen init` (a starter project for the user's own car) and `vsegen list`."""

from __future__ import annotations

from pathlib import Path

import click

from vsegen.harness.cli.common import (
    UserError,
    console,
    display,
    user_errors,
)
from vsegen.harness.project.paths import project, shipped_vehicle_names
from vsegen.harness.sim.scenarios import SCENARIOS
from vsegen.model.estimators import DEFINITIONS


@click.command()
@click.argument("folder", type=click.Path(path_type=Path))
@click.option("--like", default="c_class", show_default=True,
              help="Shipped vehicle whose values the starter vehicle file begins with.")
@user_errors
def init(folder: Path, like: str) -> None:
    """Start a project in FOLDER for your own car: vehicles/car.toml (commented, to edit),
    channels.toml (a channel-map example) and a README with the next commands."""
    from vsegen.harness.project.starter import StarterError, init_project

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
        options = " ".join(f"{k}={v}" for k, v in s.defaults.items())
        console.print(f"  {s.name}: {s.description}" + (f"  [options: {options}]" if options else ""),
                      markup=False)  # the brackets are text, not rich markup
    files = project().vehicle_files()
    if files:
        console.print("vehicles:   " + ", ".join(display(p) for p in files))
    else:
        console.print(f"vehicles:   none in this project ({display(project().vehicles)}); shipped with vsegen: "
                      f"{', '.join(shipped_vehicle_names())} (`vsegen init DIR` starts a project)")
