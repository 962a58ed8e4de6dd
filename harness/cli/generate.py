"""`vsegen generate`: the C of each estimator into the project's generated/ (or check it is up to date)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from vsegen.codegen import generate as codegen
from vsegen.harness.cli.common import (
    JSON_OPTION,
    JUNIT_OPTION,
    PARAMS_OPTION,
    REAL_OPTION,
    chosen_estimators,
    console,
    display,
    user_errors,
    warn_underived,
)
from vsegen.harness.project.files import folder_diffs, write_folder, write_text_atomic
from vsegen.harness.project.paths import project
from vsegen.harness.project.results import Check, write_results
from vsegen.harness.project.vehicles import load_vehicle, with_form
from vsegen.model.params import VehicleConfig


def _forms(config: VehicleConfig, name: str, real: str | None, params: str | None) -> list[tuple[str, str, str]]:
    """(real, params, folder name) to generate: the one asked for, else every form the vehicle file
    declares (its [codegen] default and ``forms``). A form other than the default goes to
    ``<estimator>-<real>-<params>/``, so two forms generated into one place never replace each other."""
    default = (config.codegen["real"], config.codegen["params"])
    if real or params:
        chosen = (real or default[0], params or default[1])
        return [(*chosen, codegen.form_folder(name, chosen, default))]
    return codegen.forms_to_write(config, name)


def _declare(path: Path, config: VehicleConfig, name: str, real: str, params: str) -> None:
    """Record a form generated into the project's generated/ in the vehicle file's [codegen] forms,
    so that plain generate, generate --check and verify keep it."""
    if (real, params) == (config.codegen["real"], config.codegen["params"]) or \
            (name, real, params) in config.codegen["forms"]:
        return
    write_text_atomic(Path(path), with_form(Path(path).read_text(), name, real, params))
    console.print(f"declared    {name}:{real}-{params} in {display(Path(path))} [codegen] forms "
                  f"(generate, generate --check and verify keep it)", markup=False)


def _stray_folders(out: Path, expected: set[Path]) -> list[Path]:
    """Folders ``out/<vehicle>/<form>`` that no generation produced (e.g. of a removed estimator
    or vehicle file)."""
    if not out.is_dir():
        return []
    return sorted(folder for vehicle in out.iterdir() if vehicle.is_dir()
                  for folder in vehicle.iterdir() if folder.is_dir() and folder.resolve() not in expected)


def _up_to_date(files: dict[str, str], folder: Path) -> list[str]:
    """The diffs between ``folder`` and ``files`` (printed; none: up to date)."""
    diffs = folder_diffs(files, folder, display(folder))
    for diff in diffs:
        click.echo(diff, nl=False)
    if not diffs:
        console.print(f"up to date  {display(folder)}")
    return diffs


def _stray_fix(folder: Path) -> str:
    """How to mend a stray folder: remove it, or declare its form if it is one."""
    parts = folder.name.split("-")
    if len(parts) == 3:
        name, real, params = parts
        return (f"remove it, or keep the form: `vsegen generate --vehicle vehicles/{folder.parent.name}.toml "
                f"--estimator {name} --real {real} --params {params}` (declares it in [codegen] forms)")
    return "remove it"


@click.command()
@click.option("--vehicle", "vehicles", multiple=True, type=click.Path(path_type=Path),
              help="Vehicle TOML (repeatable). Default: every file in the project's vehicles/.")
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Folder that receives <vehicle>/<estimator>/. Default: the project's generated/.")
@click.option("--check", "check_only", is_flag=True,
              help="Do not write: compare with --out and print a unified diff of what would change.")
@REAL_OPTION
@PARAMS_OPTION
@JUNIT_OPTION
@JSON_OPTION
@user_errors
def generate(vehicles: tuple[Path, ...], estimators: tuple[str, ...], out: Path | None,
             check_only: bool, real: str | None, params: str | None, junit: Path | None,
             json_out: Path | None) -> None:
    """Generate the C of each estimator in every form its vehicle file declares ([codegen] real, params
    and forms), or the one --real/--params ask for (declared in [codegen] forms when written to the
    project's generated/); with --check, compare instead of writing."""
    stale, expected, checks = [], set(), []
    out = out or project().generated
    for path in vehicles or project().required_vehicle_files():
        config = load_vehicle(path)
        for name in chosen_estimators(config, estimators):
            warn_underived(config, name)
            forms = _forms(config, name, real, params)
            if not check_only and (real or params) and out.resolve() == project().generated.resolve():
                _declare(path, config, name, *forms[0][:2])
            for form_real, form_params, folder_name in forms:
                folder = out / config.name / folder_name
                expected.add(folder.resolve())
                files = codegen.render(config, name, form_real, form_params)
                diffs = _up_to_date(files, folder) if check_only else []
                if diffs:
                    stale.append(display(folder))
                elif not check_only:
                    write_folder(files, folder)
                    console.print(f"generated   {display(folder)}  ({', '.join(sorted(files))})")
                form = "" if folder_name == name else f" --real {form_real} --params {form_params}"
                checks.append(Check(f"{config.name}.{name}.{form_real}-{form_params}", display(folder),
                                    {"vehicle": config.name, "estimator": name, "real": form_real,
                                     "params": form_params, "files": len(files), "files_differing": len(diffs)},
                                    f"{len(diffs)} file(s) differ from what {config.source} generates; run "
                                    f"`vsegen generate --vehicle {config.source} --estimator {name}{form}`"
                                    if diffs else None, "stale generated code"))
    if check_only and not (vehicles or estimators or real or params):   # the whole tree: no folder left over
        for folder in _stray_folders(out, expected):
            click.echo(f"vsegen: {display(folder)}: no vehicle file or estimator generates this folder: "
                       f"{_stray_fix(folder)}", err=True)
            stale.append(display(folder))
            checks.append(Check("stray folders", display(folder), {},
                                f"no vehicle file or estimator generates this folder: {_stray_fix(folder)}",
                                "stray folder"))
    write_results(junit, json_out, f"vsegen generate{' --check' if check_only else ''}", checks)
    if stale:
        click.echo(f"vsegen: generated code is stale in {', '.join(stale)}: run `vsegen generate`",
                   err=True)
        sys.exit(1)
