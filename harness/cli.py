"""The ``vsegen`` command line.

User mistakes (a bad vehicle file, a bad log, an unknown name) end in one line on stderr and exit
status 2; a failed check ends with status 1.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from codegen import generate as codegen
from harness.paths import DEFAULT_VEHICLE, GENERATED
from harness.scenarios import SCENARIOS, VERIFICATION_SET
from harness.vehicles import load_vehicle, shipped_vehicles
from model.estimators import BUILDERS
from model.params import ParameterError, VehicleConfig

console = Console(highlight=False, width=None if sys.stdout.isatty() else 120)


class UserError(click.ClickException):
    """One-line error for the user, exit status 2."""

    exit_code = 2

    def show(self, file=None) -> None:
        click.echo(f"vsegen: error: {self.message}", err=True)


def _load(path: Path) -> VehicleConfig:
    try:
        return load_vehicle(path)
    except ParameterError as exc:
        raise UserError(str(exc)) from None


def _estimators(config: VehicleConfig, names: tuple[str, ...]) -> list[str]:
    for name in names:
        if name not in BUILDERS:
            raise UserError(f"unknown estimator '{name}': expected one of {', '.join(BUILDERS)}")
        if name not in config.estimators:
            raise UserError(f"{config.source}: no [estimator.{name}] table: expected one to use '{name}'")
    return list(names) or [n for n in BUILDERS if n in config.estimators]


def _display(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


@click.group()
@click.version_option(package_name="vsegen")
def main() -> None:
    """vsegen: vehicle state estimators, from CasADi to standalone C, proven equal to NumPy."""


@main.command()
@click.option("--vehicle", "vehicles", multiple=True, type=click.Path(path_type=Path),
              help="Vehicle TOML (repeatable). Default: every file in vehicles/.")
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--out", type=click.Path(path_type=Path), default=GENERATED, show_default=True,
              help="Folder that receives <vehicle>/<estimator>/.")
@click.option("--check", "check_only", is_flag=True,
              help="Do not write: compare with --out and print a unified diff of what would change.")
def generate(vehicles: tuple[Path, ...], estimators: tuple[str, ...], out: Path,
             check_only: bool) -> None:
    """Generate the C of each estimator (or check that --out is up to date)."""
    stale = []
    for path in vehicles or tuple(shipped_vehicles()):
        config = _load(path)
        for name in _estimators(config, estimators):
            folder = out / config.name / name
            files = codegen.render(config, name)
            if check_only:
                diffs = codegen.check(files, folder, _display(folder))
                if diffs:
                    stale.append(_display(folder))
                    for diff in diffs:
                        click.echo(diff, nl=False)
                else:
                    console.print(f"up to date  {_display(folder)}")
            else:
                codegen.write(files, folder)
                console.print(f"generated   {_display(folder)}  ({', '.join(sorted(files))})")
    if stale:
        click.echo(f"vsegen: generated code is stale in {', '.join(stale)}: run `vsegen generate`",
                   err=True)
        sys.exit(1)


@main.command()
@click.option("--vehicle", type=click.Path(path_type=Path), default=DEFAULT_VEHICLE,
              show_default="vehicles/c_class.toml",
              help="Vehicle TOML.")
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--seed", default=1, show_default=True, help="Seed of the simulated sensor noise.")
def verify(vehicle: Path, estimators: tuple[str, ...], seed: int) -> None:
    """Compile the generated C and compare it step by step with the NumPy reference."""
    from harness.compare import FLOOR, RELATIVE_TOLERANCE
    from harness.verify import verify_estimator

    config = _load(vehicle)
    names = _estimators(config, estimators)
    results = []
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task("verifying", total=len(names) * len(VERIFICATION_SET))
        for name in names:
            results += verify_estimator(config, name, seed=seed,
                                        progress=lambda: progress.advance(task))
    table = Table(title=f"generated C vs NumPy reference, vehicle {config.name}, "
                        f"T = {config.sample_time} s, double")
    for column in ("estimator", "scenario", "samples", "signal", "max |diff|", "max rel diff",
                   "tolerance", "result"):
        table.add_column(column, justify="right" if column.startswith(("max", "sam", "tol")) else "left")
    for result in results:
        for diff in (*result.outputs, result.states):
            tolerance = "identical" if diff.integer else f"{diff.tolerance:.0e}"
            table.add_row(result.estimator, result.case, str(result.samples), diff.name,
                          f"{diff.max_abs:.2e}", "-" if diff.integer else f"{diff.max_rel:.2e}",
                          tolerance, "ok" if diff.ok else "FAIL")
        table.add_section()
    console.print(table)
    console.print(f"relative difference = |c - ref| / max(|c|, |ref|, {FLOOR:g}); tolerance "
                  f"{RELATIVE_TOLERANCE['double']:.0e} (harness/compare.py)")
    failed = [r for r in results if not r.ok]
    if failed:
        click.echo(f"vsegen: verify FAILED on {len(failed)} of {len(results)} runs", err=True)
        sys.exit(1)
    console.print(f"verify passed: {len(results)} runs, every output within tolerance")


@main.command(name="list")
def list_() -> None:
    """List the estimators, scenarios and vehicles vsegen knows."""
    console.print("estimators: " + ", ".join(BUILDERS))
    console.print("scenarios:  " + ", ".join(f"{s.name} ({s.description})" for s in SCENARIOS.values()))
    console.print("vehicles:   " + ", ".join(_display(p) for p in shipped_vehicles()))


if __name__ == "__main__":  # pragma: no cover
    main()
