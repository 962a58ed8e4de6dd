"""The ``vsegen`` command line.

User mistakes (a bad vehicle file, a bad log, an unknown name) end in one line on stderr and exit
status 2; a failed check ends with status 1.
"""

from __future__ import annotations

import functools
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from vsegen.codegen import generate as codegen
from vsegen.harness.files import write_text_atomic
from vsegen.harness.logs import TRUTH, LogError, read_estimates, read_log, write_log
from vsegen.harness.paths import ProjectError, project, shipped_vehicle_names
from vsegen.harness.progress import RunProgress
from vsegen.harness.scenarios import SCENARIOS, VERIFICATION_SET, Case, ScenarioError, parse_option
from vsegen.harness.vehicles import load_vehicle
from vsegen.model.estimators import DEFINITIONS, underived_warning
from vsegen.model.params import ParameterError, VehicleConfig

console = Console(highlight=False, width=None if sys.stdout.isatty() else 120)


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


REAL_OPTION = click.option("--real", type=click.Choice(["double", "float"]), default=None,
                           help="C floating-point type. Default: the vehicle file's [codegen] real.")
PARAMS_OPTION = click.option("--params", type=click.Choice(["baked", "calibratable"]), default=None,
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
VEHICLE_OPTION = click.option("--vehicle", type=click.Path(path_type=Path), default=None,
                              help="Vehicle TOML. Default: the project's only vehicle file, else its "
                                   "vehicles/c_class.toml.")


def _vehicle(path: Path | None) -> VehicleConfig:
    """The vehicle ``--vehicle`` names, else the project's default one."""
    return load_vehicle(path or project().default_vehicle())


def _estimators(config: VehicleConfig, names: tuple[str, ...]) -> list[str]:
    for name in names:
        if name not in DEFINITIONS:
            raise UserError(f"unknown estimator '{name}': expected one of {', '.join(DEFINITIONS)}")
        if name not in config.estimators:
            raise UserError(f"{config.source}: no [estimator.{name}] table: expected one to use '{name}'")
    return list(names) or [n for n in DEFINITIONS if n in config.estimators]


def _forms(config: VehicleConfig, name: str, out: Path, real: str | None,
           params: str | None) -> list[tuple[str, str, str]]:
    """(real, params, folder name) to generate: the one asked for, or the vehicle file's default
    and, in the repository's generated/, the reviewed forms (codegen.REVIEWED_FORMS)."""
    chosen = (real or config.codegen["real"], params or config.codegen["params"])
    if real or params or out.resolve() != project().generated:
        return [(*chosen, name)]
    return codegen.forms_to_write(name, chosen)


def _stray_folders(out: Path, expected: set[Path]) -> list[Path]:
    """Folders ``out/<vehicle>/<form>`` that no generation produced (e.g. of a removed estimator
    or vehicle file)."""
    if not out.is_dir():
        return []
    return sorted(folder for vehicle in out.iterdir() if vehicle.is_dir()
                  for folder in vehicle.iterdir() if folder.is_dir() and folder.resolve() not in expected)


def _up_to_date(files: dict[str, str], folder: Path) -> bool:
    """Whether ``folder`` holds exactly ``files``; prints the diffs if not."""
    diffs = codegen.check(files, folder, _display(folder))
    for diff in diffs:
        click.echo(diff, nl=False)
    if not diffs:
        console.print(f"up to date  {_display(folder)}")
    return not diffs


def _read_log(path: Path, channels: Path | None, sample_time: float | Callable[[], float],
              window: tuple[float | None, float | None] = (None, None),
              unit_check: VehicleConfig | None = None):
    """A CSV (plain or compressed) or MDF4 log through the channel map ``channels``, cut to the
    time ``window`` (s), saying on stderr (a line each) when it was put on a uniform grid (MDF4
    channels: at ``sample_time``, a number or a function giving it, called only for MDF4) and where
    it has gaps the estimators hold across. With ``unit_check`` (a vehicle) the signals' physics is
    checked for wrong units (``harness.unit_sanity``)."""
    from vsegen.harness.channels import read_channel_map
    from vsegen.harness.mdf import SUFFIXES, read_mdf
    from vsegen.harness.unit_sanity import check_units

    mapping = read_channel_map(channels)
    if path.suffix.lower() in SUFFIXES:
        log = read_mdf(path, mapping, sample_time() if callable(sample_time) else sample_time)
    else:
        log = read_log(path, channels={c.channel: (c.name, c.scale) for c in mapping.columns.values()})
    for key in ("resampled", "gaps"):
        if key in log.notes:
            click.echo(f"vsegen: {path}: {log.notes[key]}", err=True)
    log = log.window(*window)
    if unit_check is not None:
        check_units(log, unit_check.vehicle["wheelbase"])
    return log


def _warn_underived(config: VehicleConfig, name: str) -> None:
    """Say (stderr, one line) when ``name``'s car-specific settings were not derived for this car."""
    warning = underived_warning(config, name)
    if warning:
        click.echo(f"vsegen: {warning}", err=True)


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
              help="Vehicle TOML (repeatable). Default: every file in the project's vehicles/.")
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Folder that receives <vehicle>/<estimator>/. Default: the project's generated/.")
@click.option("--check", "check_only", is_flag=True,
              help="Do not write: compare with --out and print a unified diff of what would change.")
@REAL_OPTION
@PARAMS_OPTION
@user_errors
def generate(vehicles: tuple[Path, ...], estimators: tuple[str, ...], out: Path | None,
             check_only: bool, real: str | None, params: str | None) -> None:
    """Generate the C of each estimator (or check that --out is up to date)."""
    stale, expected = [], set()
    out = out or project().generated
    for path in vehicles or project().required_vehicle_files():
        config = load_vehicle(path)
        for name in _estimators(config, estimators):
            _warn_underived(config, name)
            for form_real, form_params, folder_name in _forms(config, name, out, real, params):
                folder = out / config.name / folder_name
                expected.add(folder.resolve())
                files = codegen.render(config, name, form_real, form_params)
                if check_only and not _up_to_date(files, folder):
                    stale.append(_display(folder))
                elif not check_only:
                    codegen.write(files, folder)
                    console.print(f"generated   {_display(folder)}  ({', '.join(sorted(files))})")
    if check_only and not vehicles and not estimators:   # the whole tree: no folder left over
        for folder in _stray_folders(out, expected):
            click.echo(f"vsegen: {_display(folder)}: no vehicle file or estimator generates this folder "
                       f"(remove it)", err=True)
            stale.append(_display(folder))
    if stale:
        click.echo(f"vsegen: generated code is stale in {', '.join(stale)}: run `vsegen generate`",
                   err=True)
        sys.exit(1)


@main.command()
@VEHICLE_OPTION
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--seed", default=1, show_default=True, help="Seed of the simulated sensor noise.")
@REAL_OPTION
@PARAMS_OPTION
@user_errors
def verify(vehicle: Path | None, estimators: tuple[str, ...], seed: int, real: str | None,
           params: str | None) -> None:
    """Compile the generated C and compare it step by step with the NumPy reference."""
    from vsegen.harness.verify import verify as verify_all

    config = _vehicle(vehicle)
    real = real or config.codegen["real"]
    params = params or config.codegen["params"]
    names = _estimators(config, estimators)
    with RunProgress("verifying", {name: len(VERIFICATION_SET) for name in names}) as progress:
        results = verify_all(config, names, seed=seed, real=real, params=params,
                             on_done=lambda result: progress.done(result.estimator, result.ok))
    table = _difference_table(f"generated C vs NumPy reference, vehicle {config.name}, "
                              f"T = {config.sample_time} s, {real}, {params} parameters", results)
    console.print(table)
    _explain_differences(real, any(r.flips for r in results))
    failed = [r for r in results if not r.ok]
    if failed:
        click.echo(f"vsegen: verify FAILED on {len(failed)} of {len(results)} runs", err=True)
        sys.exit(1)
    console.print(f"verify passed: {len(results)} runs, every output within tolerance")


@main.command(name="pil")
@VEHICLE_OPTION
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--target", "targets", multiple=True, type=click.Choice(["m4f", "m7"]),
              help="Cortex-M4F (float, QEMU mps2-an386) or Cortex-M7 (double, mps2-an500); repeatable. "
                   "Default: both.")
@PARAMS_OPTION
@click.option("--seed", default=1, show_default=True, help="Seed of the simulated sensor noise.")
@user_errors
def pil_command(vehicle: Path | None, estimators: tuple[str, ...], targets: tuple[str, ...], params: str | None,
                seed: int) -> None:
    """Processor-in-the-loop: run the generated C on an emulated Cortex-M (QEMU) over the
    verification scenarios; compare with the reference and with the host build of the same
    precision; report instructions per step, CPU load and stack."""
    from vsegen.harness import pil

    missing = pil.available()
    if missing:
        raise UserError(missing)
    config = _vehicle(vehicle)
    params = params or config.codegen["params"]
    names = _estimators(config, estimators)
    failed, costs = 0, Table(title=f"cost on the target, vehicle {config.name}, {1.0 / config.sample_time:g} Hz "
                                   f"(instructions from QEMU -icount; load = instructions x rate / clock, "
                                   f"taking one instruction as one cycle)")
    for column in ("estimator", "target", "real", "instructions/step", "worst scenario", "CPU load",
                   "stack init / step", "static stack"):
        costs.add_column(column, justify="left" if column in ("estimator", "target", "real") else "right")
    for board_name in targets or tuple(pil.BOARDS):
        board = pil.BOARDS[board_name]
        with RunProgress(f"PIL on {board.machine}", {name: len(VERIFICATION_SET) for name in names}) as progress:
            results = pil.pil(config, names, board_name, params, seed=seed,
                              on_done=lambda r: progress.done(r.reference.estimator, r.ok))

        def host_rows(i: int, results=results) -> list[tuple[str, ...]]:
            host = results[i].host
            rows = [("vs host build", "0.00e+00", "0.00e+00", "identical", "ok") if host.identical else
                    ("vs host build (step)", f"{host.steps.max_abs:.2e}", f"{host.steps.max_rel:.2e}",
                     f"{host.steps.tolerance:.0e}", "ok" if host.steps.ok else "FAIL")]
            if host.resampling:
                rows.append(("resampling vs host", str(host.resampling), "-", "explained", "ok"))
            return rows

        console.print(_difference_table(
            f"{board.target.name} under QEMU {board.machine} vs NumPy reference and host build, vehicle "
            f"{config.name}, {board.real}, {params} parameters", [r.reference for r in results], host_rows))
        _explain_differences(board.real, any(r.reference.flips for r in results))
        failed += sum(not r.ok for r in results)
        for name in names:
            c = pil.cost(config, name, board, params, results)
            costs.add_row(name, board.target.name, board.real, f"{c.instructions_mean:,.0f}",
                          f"{c.instructions_max:,.0f}", f"{100 * c.load:.2f} % of {board.clock_hz / 1e6:g} MHz",
                          f"{c.stack_init} / {c.stack_step}", f"{c.static_stack_init} / {c.static_stack_step}")
    console.print("vs host build: identical, or each target step from its own state against the host build's "
                  "step from that state (newlib's libm may round atan2, exp, log, sin, cos to the neighbouring "
                  "number of glibc's; both builds are ISO C99 without FMA contraction)")
    console.print(costs)
    console.print("stack: painted (bytes below main's stack pointer that init / step wrote, library calls "
                  "included); static: gcc -fstack-usage along the worst call path (library frames not known)")
    if failed:
        click.echo(f"vsegen: PIL FAILED on {failed} runs", err=True)
        sys.exit(1)
    console.print("PIL passed: every run within the verify tolerances of the reference and equal to the host build "
                  "(or within them, step by step)")


def _difference_table(title: str, results, extra_rows=None) -> Table:
    """The verify table of ``results`` (harness.verify.CaseResult); ``extra_rows(i)`` gives more
    rows (cells) after the ``i``-th result."""
    table = Table(title=title)
    for column in ("estimator", "scenario", "samples", "signal", "max |diff|", "max rel diff",
                   "tolerance", "result"):
        table.add_column(column, justify="right" if column.startswith(("max", "sam", "tol")) else "left")
    for i, result in enumerate(results):
        stepwise = () if result.stepwise is result.states else (result.stepwise,)
        for diff in (*result.outputs, result.states, *stepwise):
            tolerance = "identical" if diff.integer else f"{diff.tolerance:.0e}"
            table.add_row(result.estimator, result.case, str(result.samples), diff.name,
                          f"{diff.max_abs:.2e}", "-" if diff.integer else f"{diff.max_rel:.2e}",
                          tolerance, "ok" if diff.ok else "FAIL")
        if result.flips:
            table.add_row(result.estimator, result.case, str(result.samples),
                          "resampling flips", str(result.flips), "-", "explained", "ok")
        for row in (extra_rows(i) if extra_rows else ()):
            table.add_row(result.estimator, result.case, str(result.samples), *row)
        table.add_section()
    return table


def _explain_differences(real: str, flips: bool) -> None:
    """The notes under a difference table."""
    from vsegen.harness.compare import PEAK_FRACTION, TOLERANCES
    from vsegen.harness.verify import FLIP_MARGIN

    tolerance = TOLERANCES[real]
    console.print(f"relative difference = |c - ref| / max(|c|, |ref|, {tolerance.floor:g} x the "
                  f"signal's scale, {PEAK_FRACTION:g} x peak |signal|); tolerance "
                  f"{tolerance.relative:.0e} for {real}, wider where an estimator amplifies its "
                  "reference's rounding (the unscented filters, ekf_rls's stiffness rate, "
                  "arx_dual_kf's random-walk parameters; column 'tolerance'; harness/compare.py)")
    if flips:
        console.print("resampling flips: steps of a float particle filter whose resampling chose "
                      "another particle than the reference because a point lay within float "
                      f"rounding (< {FLIP_MARGIN:g}) of a cumulative weight; each matches the "
                      "reference's step with that point moved across the weight (every step is "
                      "checked from the C's own state)")


@main.command()
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
    """Simulate SCENARIO on the truth plant and write its log (design.md format)."""
    if scenario not in SCENARIOS:
        raise UserError(f"unknown scenario '{scenario}': expected one of {', '.join(SCENARIOS)}")
    if not rate > 0:
        raise UserError(f"--rate {rate}: expected a rate in Hz > 0")
    config = _vehicle(vehicle)
    case = Case.of(scenario, **dict(parse_option(scenario, o) for o in options))
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task(f"simulating {case.label} at {rate:g} Hz", total=1.0)
        log = case.simulate(config, rate, seed,
                            progress=lambda done: progress.update(task, completed=done))
    if no_truth:
        log.columns = {k: v for k, v in log.columns.items() if k not in TRUTH}
    write_log(log, out)
    report = ", ".join(f"{k}: {v}" for k, v in log.notes.items())
    console.print(f"wrote {out} ({len(log)} samples, {log['t'][-1]:.2f} s): {report}")


@main.command()
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
    logs = [_read_log(path, channels, config.sample_time, unit_check=checked) for path in log_paths]
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


@main.command()
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
    from vsegen.harness.cluster import ClusterError
    from vsegen.harness.plot import tuning_plot
    from vsegen.harness.tuning import DEGREES, TuneError, scored_output
    from vsegen.harness.tuning import tune as tune_settings

    config = load_vehicle(vehicle)
    _estimators(config, (estimator,))
    if trials < 1 or batch < 1:
        raise UserError(f"--trials {trials} --batch {batch}: expected both >= 1")
    checked = None if no_unit_check else config
    train = [_read_log(path, channels, config.sample_time, unit_check=checked) for path in log_paths]
    holdout = [_read_log(path, channels, config.sample_time, unit_check=checked) for path in holdout_paths]
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


@main.command()
@click.option("--log", "log_path", type=click.Path(path_type=Path), required=True,
              help="Input log: CSV (plain, .gz, .bz2, .xz) or MDF4 (.mf4, .mdf).")
@click.option("--estimator", required=True, help="Estimator name.")
@VEHICLE_OPTION
@click.option("--backend", type=click.Choice(["c", "reference"]), default="c", show_default=True,
              help="Generated C (compiled for the log's sample time, cached) or the NumPy reference.")
@click.option("--out", type=click.Path(path_type=Path), required=True,
              help="Estimates to write: CSV, or MDF4 when the name ends in .mf4.")
@CHANNELS_OPTION
@UNIT_CHECK_OPTION
@window_options
@user_errors
def run(log_path: Path, estimator: str, vehicle: Path | None, backend: str, out: Path, channels: Path | None,
        no_unit_check: bool, start: float | None, stop: float | None) -> None:
    """Run an estimator over a log and write its estimates (t, beta, vy, r, status, ...)."""
    from vsegen.harness.run import run_estimator

    config = _vehicle(vehicle)
    _estimators(config, (estimator,))
    _warn_underived(config, estimator)
    log = _read_log(log_path, channels, config.sample_time, (start, stop), None if no_unit_check else config)
    if abs(log.sample_time - config.sample_time) > 1e-9 * config.sample_time:
        click.echo(f"vsegen: {log_path}: sample time {log.sample_time:.6g} s differs from [estimator] sample_time = "
                   f"{config.sample_time:g} s in {vehicle}: the estimator runs at the log's rate (rate-dependent "
                   f"settings keep their meaning in time); generate for that rate to flash the same code", err=True)
    with console.status(f"running {estimator} ({backend}) on {len(log)} samples"):
        estimates = run_estimator(config, estimator, log, backend)
    if out.suffix.lower() == ".mf4":
        from vsegen.harness.mdf import write_mdf

        write_mdf(estimates, out)
    else:
        write_log(estimates, out)
    flagged = int(np.count_nonzero(estimates["status"]))
    console.print(f"wrote {out} ({len(estimates)} samples, T = {log.sample_time:.6g} s, "
                  f"{flagged} with status != 0)")


@main.command()
@click.option("--log", "log_path", type=click.Path(path_type=Path), required=True,
              help="Log CSV with ground truth.")
@click.option("--est", "est_path", type=click.Path(path_type=Path), required=True,
              help="Estimates CSV from `vsegen run`.")
@CHANNELS_OPTION
@window_options
@user_errors
def score(log_path: Path, est_path: Path, channels: Path | None, start: float | None, stop: float | None) -> None:
    """Errors of the estimates against ground truth: max, mean and RMSE (seed 000 Table 3)."""
    from vsegen.harness.score import score as compute

    log = _read_log(log_path, channels, lambda: read_estimates(est_path).sample_time, (start, stop))
    scores = compute(log, read_estimates(est_path))
    table = Table(title=f"{est_path} against {log_path}")
    for column in ("signal", "samples", "max |e|", "mean |e|", "RMSE"):
        table.add_column(column, justify="left" if column == "signal" else "right")
    for s in scores:
        table.add_row(f"{s.signal} ({s.unit})", str(s.samples), f"{s.max:.3f}", f"{s.mean:.3f}",
                      f"{s.rmse:.3f}")
    console.print(table)
    if "off_course" in log and np.any(log["off_course"] > 0):
        first = log["t"][np.argmax(log["off_course"] > 0)]
        console.print(f"warning: the run left the course or spun from t = {first:.2f} s "
                      f"(column off_course); these scores include those samples")


@main.command()
@click.option("--log", "log_path", type=click.Path(path_type=Path), required=True,
              help="Log CSV with ground truth.")
@click.option("--est", "est_paths", type=click.Path(path_type=Path), multiple=True, required=True,
              help="Estimates CSV (repeatable).")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="PNG to write.")
@CHANNELS_OPTION
@window_options
@user_errors
def plot(log_path: Path, est_paths: tuple[Path, ...], out: Path, channels: Path | None, start: float | None,
         stop: float | None) -> None:
    """Plot beta against the reference and |delta beta| over time (seed 000 Fig. 8 style); without a
    reference in the log, the estimates and their status."""
    from vsegen.harness.plot import plot as draw

    log = _read_log(log_path, channels, lambda: read_estimates(est_paths[0]).sample_time, (start, stop))
    estimates = {}
    for path in est_paths:
        est = read_estimates(path)
        if len(est) != len(log):
            raise UserError(f"{path}: {len(est)} samples: expected {len(log)} like {log_path}")
        estimates[path.stem] = est
    draw(log, estimates, out, title=log_path.name)
    console.print(f"wrote {out}")


@main.command()
@VEHICLE_OPTION
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@user_errors
def size(vehicle: Path | None, estimators: tuple[str, ...]) -> None:
    """Cross-build every estimator for Cortex-M4F (float) and Cortex-M7 (double); print the
    resource budget: .text/.data/.bss and worst-case stack (bytes)."""
    from vsegen.harness.targets import TARGETS, TargetError, available, build_for_target

    config = _vehicle(vehicle)
    table = Table(title=f"resource budget, vehicle {config.name} (arm-none-eabi-gcc -O2, linked "
                        f"with --gc-sections to the public API; .text includes .rodata)")
    for column in ("estimator", "target", "real", "params", ".text", ".data", ".bss",
                   "stack init", "stack step", "library calls (not counted)"):
        table.add_column(column, justify="left" if column in ("estimator", "target", "real", "params")
                         or column.startswith("library") else "right")
    failures = []
    for name in _estimators(config, estimators):
        for target in TARGETS:
            if not available(target):
                raise UserError(f"{target.compiler} not found: expected the Debian package "
                                f"gcc-arm-none-eabi (run scripts/setup.sh)")
            for mode in ("baked", "calibratable"):
                try:
                    r = build_for_target(codegen.render(config, name, target.real, mode), name, target)
                except TargetError as exc:
                    failures.append(f"{name} on {target.name} ({mode}): {exc}")
                    continue
                table.add_row(name, r.target, r.real, mode, str(r.text), str(r.data), str(r.bss),
                              str(r.stack_init), str(r.stack_step), ", ".join(r.library_calls))
    console.print(table)
    if failures:
        for failure in failures:
            click.echo(f"vsegen: {failure}", err=True)
        sys.exit(1)


@main.command()
@click.option("--update-baseline", is_flag=True, help="Write the current counts as the new baseline.")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Deviation report to write. Default: the project's docs/misra.md.")
@user_errors
def misra(update_baseline: bool, out: Path | None) -> None:
    """Run cppcheck's MISRA C:2012 addon on every distinct generated estimator of the shipped
    vehicles (each estimator and set of options once); write the deviation report; fail if a
    rule's count grew past the baseline."""
    from vsegen.harness import misra as checks
    from vsegen.harness.files import write_text_atomic

    if update_baseline and not checks.in_source_checkout():
        raise UserError(f"--update-baseline: {checks.BASELINE} is vsegen's own baseline: expected a vsegen "
                        f"source checkout, not an installed vsegen")

    sections, total = [], Counter()
    configs = [load_vehicle(path) for path in project().required_vehicle_files()]
    out = out or project().reports / "misra.md"
    estimators = checks.distinct_code([(config, name) for config in configs for name in _estimators(config, ())])
    for (config, name), forms in zip(estimators, checks.all_findings(estimators)):
        for form, counts in forms:
            sections.append((f"{config.name}/{name} ({form})", counts))
            total.update(counts)
    per_rule = checks.by_rule(total)
    write_text_atomic(out, checks.report(sections))
    if update_baseline:
        checks.write_baseline(per_rule)
    rules = ", ".join(f"{rule.removeprefix('misra-c2012-')}: {count}" for rule, count in per_rule.items())
    console.print(f"wrote {out}: {sum(per_rule.values())} findings in {len(per_rule)} rules ({rules})")
    problems = checks.regressions(per_rule, checks.load_baseline())
    if problems:
        for problem in problems:
            click.echo(f"vsegen: MISRA regression: {problem}", err=True)
        sys.exit(1)


@main.command()
@click.option("--elf", "elf_path", type=click.Path(path_type=Path), required=True,
              help="The linked firmware (ELF with its symbol table).")
@click.option("--a2l", "a2l_path", type=click.Path(path_type=Path), required=True,
              help="The A2L file of a calibratable kit (generated/<vehicle>/<estimator>/vse_<name>.a2l).")
@click.option("--state", default=None, help="The firmware's state variable. Default: the kit example's.")
@click.option("--output", default=None, help="The firmware's output variable. Default: the kit example's.")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="A2L file to write, addresses filled.")
@user_errors
def a2l(elf_path: Path, a2l_path: Path, state: str | None, output: str | None, out: Path) -> None:
    """Fill the addresses of a generated A2L file from the linked firmware, for INCA / CANape."""
    from vsegen.harness.a2l_link import A2LError, elf_symbols, link
    from vsegen.harness.files import read_user_text

    try:
        text = read_user_text(a2l_path, A2LError, "A2L file")
        linked = link(text, str(a2l_path), elf_symbols(elf_path), str(elf_path), state, output)
    except A2LError as exc:
        raise UserError(str(exc)) from None
    write_text_atomic(out, linked)
    console.print(f"wrote {_display(out)}: {linked.count('/begin CHARACTERISTIC')} characteristics, "
                  f"{linked.count('/begin MEASUREMENT')} measurements, addresses from {_display(elf_path)}")


@main.command()
@click.argument("folder", type=click.Path(path_type=Path))
@click.option("--like", default="c_class", show_default=True,
              help="Shipped vehicle whose values the starter vehicle file begins with.")
@user_errors
def init(folder: Path, like: str) -> None:
    """Start a project in FOLDER for your own car: vehicles/car.toml (commented, to edit),
    channels.toml (a channel-map example) and a README with the next commands."""
    from vsegen.harness.starter import StarterError, init_project

    try:
        written = init_project(folder, like)
    except StarterError as exc:
        raise UserError(str(exc)) from None
    for path in written:
        console.print(f"wrote {_display(path)}")
    console.print(f"next: cd {_display(folder)} && vsegen generate")


@main.command(name="list")
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
        console.print("vehicles:   " + ", ".join(_display(p) for p in files))
    else:
        console.print(f"vehicles:   none in this project ({_display(project().vehicles)}); shipped with vsegen: "
                      f"{', '.join(shipped_vehicle_names())} (`vsegen init DIR` starts a project)")


if __name__ == "__main__":  # pragma: no cover
    main()
