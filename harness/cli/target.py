"""The target stage: `vsegen pil` (the C on an emulated Cortex-M), `vsegen size` (resource budget),
`vsegen misra` (MISRA C:2012 deviations) and `vsegen a2l` (addresses from the linked firmware)."""

from __future__ import annotations

import sys
from collections import Counter
from dataclasses import replace
from pathlib import Path

import click
from rich.table import Table

from vsegen.codegen import generate as codegen
from vsegen.harness.cli.common import (
    JSON_OPTION,
    JUNIT_OPTION,
    PARAMS_OPTION,
    VEHICLE_OPTION,
    UserError,
    chosen_estimators,
    console,
    display,
    print_table,
    read_user_log,
    user_errors,
    vehicle_config,
)
from vsegen.harness.cli.verify import difference_table, explain_differences
from vsegen.harness.jobs.progress import RunProgress
from vsegen.harness.project.files import write_text_atomic
from vsegen.harness.project.paths import project
from vsegen.harness.project.results import Check, write_results
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.target.emulator import BOARDS
from vsegen.harness.verify import report as verify_report


@click.command(name="pil")
@VEHICLE_OPTION
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--target", "targets", multiple=True, type=click.Choice(tuple(BOARDS)),
              help="Cortex-M4F (float, QEMU mps2-an386) or Cortex-M7 (double, mps2-an500); repeatable. "
                   "Default: both.")
@PARAMS_OPTION
@click.option("--seed", default=1, show_default=True, help="Seed of the simulated sensor noise.")
@click.option("--log", "log_path", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Replay this recorded log (CSV or MDF4, at the vehicle file's sample time) instead of the "
                   "verification scenarios.")
@click.option("--channels", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Channel map of --log (see docs/integration.md).")
@JUNIT_OPTION
@JSON_OPTION
@user_errors
def pil_command(vehicle: Path | None, estimators: tuple[str, ...], targets: tuple[str, ...], params: str | None,
                seed: int, log_path: Path | None, channels: Path | None, junit: Path | None,
                json_out: Path | None) -> None:
    """Processor-in-the-loop: run the generated C on an emulated Cortex-M (QEMU) over the
    verification scenarios (or a recorded --log); compare with the reference and with the host build
    of the same precision; report instructions per step, CPU load and stack."""
    from vsegen.harness.target import emulator as pil

    missing = pil.available()
    if missing:
        raise UserError(missing)
    config = vehicle_config(vehicle)
    params = params or config.codegen["params"]
    names = chosen_estimators(config, estimators)
    log = _recorded_log(log_path, channels, config) if log_path else None
    checks: list[Check] = []
    failed, costs = 0, Table(title=f"cost on the target, vehicle {config.name}, {1.0 / config.sample_time:g} Hz "
                                   f"(instructions from QEMU -icount; load = instructions x rate / clock, "
                                   f"taking one instruction as one cycle)")
    for column in ("estimator", "target", "real", "instructions/step", "worst scenario", "CPU load",
                   "stack init / step", "static stack"):
        costs.add_column(column, justify="left" if column in ("estimator", "target", "real") else "right")
    for board_name in targets or tuple(pil.BOARDS):
        board = pil.BOARDS[board_name]
        with RunProgress(f"PIL on {board.machine}", {name: 1 if log else len(VERIFICATION_SET)
                                                     for name in names}) as progress:
            if log:
                results = [pil.pil_log(config, name, log, log_path.name, board_name, params) for name in names]
                for result in results:
                    progress.done(result.reference.estimator, result.ok)
            else:
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

        console.print(difference_table(
            f"{board.target.name} under QEMU {board.machine} vs NumPy reference and host build, vehicle "
            f"{config.name}, {board.real}, {params} parameters", [r.reference for r in results], host_rows))
        explain_differences(board.real, any(r.reference.flips for r in results),
                            any(r.reference.crossings for r in results))
        failed += sum(not r.ok for r in results)
        checks += _pil_checks(config.name, board_name, board.real, params, results)
        for name in names:
            c = pil.cost(config, name, board, params, results)
            checks.append(Check(f"{config.name}.{name}.{board.real}-{params}@{board_name}", "cost on the target",
                                {"instructions_per_step": c.instructions_mean, "instructions_worst_scenario":
                                 c.instructions_max, "cpu_load": c.load, "clock_hz": board.clock_hz,
                                 "stack_init": c.stack_init, "stack_step": c.stack_step,
                                 "static_stack_init": c.static_stack_init, "static_stack_step": c.static_stack_step}))
            costs.add_row(name, board.target.name, board.real, f"{c.instructions_mean:,.0f}",
                          f"{c.instructions_max:,.0f}", f"{100 * c.load:.2f} % of {board.clock_hz / 1e6:g} MHz",
                          f"{c.stack_init} / {c.stack_step}", f"{c.static_stack_init} / {c.static_stack_step}")
    console.print("vs host build: identical, or each target step from its own state against the host build's "
                  "step from that state (newlib's libm may round atan2, exp, log, sin, cos to the neighbouring "
                  "number of glibc's; both builds are ISO C99 without FMA contraction)")
    print_table(costs)
    write_results(junit, json_out, f"vsegen pil {config.name} {params}", checks)
    console.print("stack: painted (bytes below main's stack pointer that init / step wrote, library calls "
                  "included); static: gcc -fstack-usage along the worst call path (library frames not known)")
    if failed:
        click.echo(f"vsegen: PIL FAILED on {failed} runs", err=True)
        sys.exit(1)
    console.print("PIL passed: every run within the verify tolerances of the reference and equal to the host build "
                  "(or within them, step by step)")


def _pil_checks(vehicle: str, board_name: str, real: str, params: str, runs) -> list[Check]:
    """verify's checks of each run on the board (suite ``<vehicle>.<estimator>.<form>@<board>``)
    and its comparison with the host build."""
    checks = [replace(c, suite=f"{c.suite}@{board_name}")
              for c in verify_report.as_checks(verify_report.Run(vehicle, real, params), [r.reference for r in runs])]
    for run in runs:
        host = run.host
        step = host.steps
        figures = {"identical": host.identical, "resampling_explained": host.resampling}
        if not host.identical:
            figures |= {"max_abs": step.max_abs, "max_rel": step.max_rel, "tolerance": step.tolerance}
        checks.append(Check(f"{vehicle}.{run.reference.estimator}.{real}-{params}@{board_name}",
                            f"{run.reference.case}: vs host build", figures,
                            None if host.identical or step.ok else
                            f"target step vs host step: max relative difference {step.max_rel:.3e} above "
                            f"{step.tolerance:.0e}", "tolerance"))
    return checks


def _recorded_log(log_path: Path, channels: Path | None, config):
    """The log to replay on the target, refused in one line unless it is at the generated rate."""
    log = read_user_log(log_path, channels, config.sample_time, unit_check=config)
    if abs(log.sample_time - config.sample_time) > 1e-9 * config.sample_time:
        raise UserError(f"{log_path}: sample time {log.sample_time:.6g} s: expected the vehicle file's "
                        f"[estimator] sample_time = {config.sample_time:g} s, the rate the flashed code runs at "
                        f"(generate for the log's rate, or resample the log)")
    return log


@click.command()
@VEHICLE_OPTION
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@JUNIT_OPTION
@JSON_OPTION
@user_errors
def size(vehicle: Path | None, estimators: tuple[str, ...], junit: Path | None, json_out: Path | None) -> None:
    """Cross-build every estimator for Cortex-M4F (float) and Cortex-M7 (double); print the
    resource budget: .text/.data/.bss and worst-case stack (bytes)."""
    from vsegen.harness.target.toolchains import TARGETS, TargetError, available, build_for_target

    config = vehicle_config(vehicle)
    table = Table(title=f"resource budget, vehicle {config.name} (arm-none-eabi-gcc -O2, linked "
                        f"with --gc-sections to the public API; .text includes .rodata)")
    for column in ("estimator", "target", "real", "params", ".text", ".data", ".bss",
                   "stack init", "stack step", "library calls (not counted)"):
        table.add_column(column, justify="left" if column in ("estimator", "target", "real", "params")
                         or column.startswith("library") else "right")
    failures, checks = [], []
    for name in chosen_estimators(config, estimators):
        for target in TARGETS:
            if not available(target):
                raise UserError(f"{target.compiler} not found: expected the Debian package "
                                f"gcc-arm-none-eabi (run scripts/setup.sh)")
            for mode in ("baked", "calibratable"):
                suite = f"{config.name}.{name}.{target.real}-{mode}"
                try:
                    r = build_for_target(codegen.render(config, name, target.real, mode), name, target)
                except TargetError as exc:
                    failures.append(f"{name} on {target.name} ({mode}): {exc}")
                    checks.append(Check(suite, f"cross-build for {target.name}", {}, str(exc), "build"))
                    continue
                table.add_row(name, r.target, r.real, mode, str(r.text), str(r.data), str(r.bss),
                              str(r.stack_init), str(r.stack_step), ", ".join(r.library_calls))
                checks.append(Check(suite, f"cross-build for {target.name}",
                                    {"text_bytes": r.text, "data_bytes": r.data, "bss_bytes": r.bss,
                                     "stack_init_bytes": r.stack_init, "stack_step_bytes": r.stack_step,
                                     "library_calls": ", ".join(r.library_calls)}))
    print_table(table)
    write_results(junit, json_out, f"vsegen size {config.name}", checks)
    if failures:
        for failure in failures:
            click.echo(f"vsegen: {failure}", err=True)
        sys.exit(1)


@click.command()
@click.option("--update-baseline", is_flag=True, help="Write the current counts as the new baseline.")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Deviation report to write. Default: the project's docs/misra.md.")
@JUNIT_OPTION
@JSON_OPTION
@user_errors
def misra(update_baseline: bool, out: Path | None, junit: Path | None, json_out: Path | None) -> None:
    """Run cppcheck's MISRA C:2012 addon on every distinct generated estimator of the shipped
    vehicles (each estimator and set of options once); write the deviation report; fail if a
    rule's count grew past the baseline."""
    from vsegen.harness.target import misra as checks

    if update_baseline and not checks.in_source_checkout():
        raise UserError(f"--update-baseline: {checks.BASELINE} is vsegen's own baseline: expected a vsegen "
                        f"source checkout, not an installed vsegen")

    sections, total = [], Counter()
    configs = [load_vehicle(path) for path in project().required_vehicle_files()]
    out = out or project().reports / "misra.md"
    estimators = checks.distinct_code([(config, name) for config in configs for name in chosen_estimators(config, ())])
    results = checks.all_findings(estimators, fresh=update_baseline)
    for (config, name), forms in zip(estimators, results):
        for form, counts, _ in forms:
            sections.append((f"{config.name}/{name} ({form})", counts))
            total.update(counts)
    per_rule = checks.by_rule(total)
    write_text_atomic(out, checks.report(sections, checks.provenance(project().root)))
    if update_baseline:
        checks.write_baseline(per_rule)
        checks.write_record(results)
    rules = ", ".join(f"{rule.removeprefix('misra-c2012-')}: {count}" for rule, count in per_rule.items())
    console.print(f"wrote {out}: {sum(per_rule.values())} findings in {len(per_rule)} rules ({rules})")
    baseline = checks.load_baseline()
    problems = checks.regressions(per_rule, baseline)
    write_results(junit, json_out, "vsegen misra", _misra_checks(sections, per_rule, baseline, problems))
    if problems:
        for problem in problems:
            click.echo(f"vsegen: MISRA regression: {problem}", err=True)
        sys.exit(1)


def _misra_checks(sections, per_rule: dict, baseline: dict, problems: list[str]) -> list[Check]:
    """A check per rule (its findings against the baseline; a failure where it grew) and one per
    kit (its findings by rule)."""
    rules = sorted({*per_rule, *baseline})
    by_rule = [Check("rules", rule, {"findings": per_rule.get(rule, 0), "baseline": baseline.get(rule, 0)},
                     next((p for p in problems if p.startswith(f"{rule}:")), None), "regression") for rule in rules]
    from vsegen.harness.target.misra import by_rule as rule_totals

    kits = [Check("kits", kit, {"findings": sum(counts.values()),
                                **{rule.removeprefix("misra-c2012-"): n for rule, n in rule_totals(counts).items()}})
            for kit, counts in sections]
    return by_rule + kits


@click.command()
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
    from vsegen.harness.project.files import read_user_text
    from vsegen.harness.target.a2l_link import A2LError, elf_symbols, link

    try:
        text = read_user_text(a2l_path, A2LError, "A2L file")
        linked = link(text, str(a2l_path), elf_symbols(elf_path), str(elf_path), state, output)
    except A2LError as exc:
        raise UserError(str(exc)) from None
    write_text_atomic(out, linked)
    console.print(f"wrote {display(out)}: {linked.count('/begin CHARACTERISTIC')} characteristics, "
                  f"{linked.count('/begin MEASUREMENT')} measurements, addresses from {display(elf_path)}")
