"""What every ``vsegen`` command shares: one-line user errors (exit status 2), the common options,
the vehicle and estimator choice, and reading a user's log."""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from vsegen.harness.logs.table import LogError
from vsegen.harness.project.paths import ProjectError, project
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim.scenarios import ScenarioError
from vsegen.model.estimators import DEFINITIONS, underived_warning
from vsegen.model.params import ParameterError, VehicleConfig
from vsegen.model.schema import PARAMETER_MODES, REALS

console = Console(highlight=False, width=None if sys.stdout.isatty() or os.environ.get("COLUMNS") else 120)
"""stdout: the terminal's width, else $COLUMNS, else 120 columns."""


class UserError(click.ClickException):
    """One-line error for the user, exit status 2."""

    exit_code = 2

    def show(self, file=None) -> None:
        click.echo(f"vsegen: error: {self.message}", err=True)


def user_errors(command):
    """Turn the user-facing errors of a command into one line and exit status 2."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except (ParameterError, LogError, ScenarioError, ProjectError) as exc:
            raise UserError(str(exc)) from None

    return wrapper


REAL_OPTION = click.option("--real", type=click.Choice(REALS), default=None,
                           help="C floating-point type. Default: the vehicle file's [codegen] real.")
PARAMS_OPTION = click.option("--params", type=click.Choice(PARAMETER_MODES), default=None,
                             help="Parameters as constants or a const calibration struct. "
                                  "Default: the vehicle file's [codegen] params.")
def window_options(command):
    """--from and --to: the part of the log (s, in its own time) to use."""
    command = click.option("--to", "stop", type=float, default=None, help="Use the log up to this time (s).")(command)
    return click.option("--from", "start", type=float, default=None, help="Use the log from this time (s).")(command)


CHANNELS_OPTION = click.option("--channels", type=click.Path(path_type=Path), default=None,
                               help="Channel map TOML: logger channel names, units and factors of the log columns.")
UNIT_CHECK_OPTION = click.option("--no-unit-check", "no_unit_check", is_flag=True,
                                 help="Skip the physics check of the log's units (a_y against r v_x, "
                                      "delta against l r / v_x).")
DBC_OPTION = click.option("--dbc", type=click.Path(path_type=Path), default=None,
                           help="The car's DBC: decode a raw CAN log (BLF, ASC, or bus-logging MDF4) with it.")
JUNIT_OPTION = click.option("--junit", type=click.Path(path_type=Path), default=None,
                            help="Also write the results as JUnit XML (a test case per thing checked, figures as "
                                 "properties).")
JSON_OPTION = click.option("--json", "json_out", type=click.Path(path_type=Path), default=None,
                           help="Also write the results as JSON (a record per thing checked).")
VEHICLE_OPTION = click.option("--vehicle", type=click.Path(path_type=Path), default=None,
                              help="Vehicle TOML. Default: the project's only vehicle file, else its "
                                   "vehicles/c_class.toml.")


def vehicle_config(path: Path | None) -> VehicleConfig:
    """The vehicle ``--vehicle`` names, else the project's default one."""
    return load_vehicle(path or project().default_vehicle())


def chosen_estimators(config: VehicleConfig, names: tuple[str, ...]) -> list[str]:
    for name in names:
        if name not in DEFINITIONS:
            raise UserError(f"unknown estimator '{name}': expected one of {', '.join(DEFINITIONS)}")
        if name not in config.estimators:
            raise UserError(f"{config.source}: no [estimator.{name}] table: expected one to use '{name}'")
    return list(names) or [n for n in DEFINITIONS if n in config.estimators]


def read_user_log(path: Path, channels: Path | None, sample_time: float | Callable[[], float],
                  window: tuple[float | None, float | None] = (None, None),
                  unit_check: VehicleConfig | None = None, dbc: Path | None = None):
    """A CSV (plain or compressed) or MDF4 log through the channel map ``channels``, cut to the
    time ``window`` (s), in memory, saying on stderr (a line each) when it was put on a uniform
    grid (MDF4 channels: at ``sample_time``, a number or a function giving it, called only for
    MDF4) and where it has gaps the estimators hold across. With ``unit_check`` (a vehicle) the
    signals' physics is checked for wrong units (``harness.physics.units``)."""
    log = open_user_log(path, channels, sample_time, window, unit_check, dbc).read()
    say_notes(path, log.notes)
    return log


def open_user_log(path: Path, channels: Path | None, sample_time: float | Callable[[], float],
                  window: tuple[float | None, float | None] = (None, None),
                  unit_check: VehicleConfig | None = None, dbc: Path | None = None):
    """A log as :func:`read_user_log` reads it, as a source of chunks (``harness.logs.stream``):
    memory does not grow with its length (a raw CAN log, decoded with ``dbc``, is held decoded).
    The gaps of an MDF4 or CAN log are in the source's notes once it has been read
    (:func:`say_notes`). With ``unit_check``, the units are judged on the log's first ten minutes
    and what the check has to say is said on stderr (``harness.physics.checked_log.open_checked_log``)."""
    from vsegen.harness.physics.checked_log import open_checked_log

    source, notes = open_checked_log(path, channels, sample_time, window, dbc, unit_check)
    for note in notes:
        click.echo(f"vsegen: {path}: {note}", err=True)
    return source


def say_notes(path: Path, notes: dict[str, str]) -> None:
    """Say on stderr, a line each, how a log was put on a uniform grid and where it has gaps."""
    for key in ("resampled", "gaps"):
        if key in notes:
            click.echo(f"vsegen: {path}: {notes[key]}", err=True)


def warn_underived(config: VehicleConfig, name: str) -> None:
    """Say (stderr, one line) when ``name``'s car-specific settings were not derived for this car."""
    warning = underived_warning(config, name)
    if warning:
        click.echo(f"vsegen: {warning}", err=True)


def stale_kit(config: VehicleConfig, name: str, real: str, params: str, command: str,
              missing_ok: bool = False) -> str:
    """'' when the project's generated/ holds exactly what the vehicle file generates for ``name``
    in this form (or, with ``missing_ok``, holds no folder for it), so that the C ``command``
    builds is the C that is checked in; else prints the diff and the command that regenerates it,
    and returns that line."""
    from vsegen.codegen.generate import form_folder, render
    from vsegen.harness.project.files import folder_diffs

    default = (config.codegen["real"], config.codegen["params"])
    folder = project().generated / config.name / form_folder(name, (real, params), default)
    if missing_ok and not folder.is_dir():
        return ""
    diffs = folder_diffs(render(config, name, real, params), folder, display(folder))
    for diff in diffs if folder.is_dir() else ():
        click.echo(diff, nl=False)
    if diffs:
        form = "" if (real, params) == default else f" --real {real} --params {params}"
        what = "differs from" if folder.is_dir() else "is missing: it would hold"
        why = (f"{display(folder)} {what} what {config.source} generates; run "
               f"`vsegen generate --vehicle {config.source} --estimator {name}{form}`")
        click.echo(f"vsegen: {command} FAILED: {why}", err=True)
        return why
    return ""


def print_table(table: Table) -> None:
    """Print ``table`` on stdout without cutting a number: right-aligned (number) columns never wrap;
    when even so the table is wider than the console, it is printed at its own width."""
    for column in table.columns:
        if column.justify == "right":
            column.no_wrap = True
    needed = console.measure(table).minimum
    if needed <= console.width:
        console.print(table)
    else:
        Console(highlight=False, width=needed, file=console.file).print(table)


def display(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)
