"""`vsegen verify`: the generated C against the NumPy reference, step by step, and the difference
table it shares with `vsegen pil`."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.table import Table

from vsegen.codegen.generate import forms_to_write
from vsegen.harness.cli.common import (
    JSON_OPTION,
    JUNIT_OPTION,
    PARAMS_OPTION,
    REAL_OPTION,
    VEHICLE_OPTION,
    chosen_estimators,
    console,
    display,
    print_table,
    stale_kit,
    user_errors,
    vehicle_config,
)
from vsegen.harness.jobs.progress import RunProgress
from vsegen.harness.project.files import write_text_atomic
from vsegen.harness.project.paths import project
from vsegen.harness.project.results import write_results
from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.verify import report
from vsegen.harness.verify.report import checks
from vsegen.model.params import VehicleConfig


@click.command()
@VEHICLE_OPTION
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--seed", default=1, show_default=True, help="Seed of the simulated sensor noise.")
@REAL_OPTION
@PARAMS_OPTION
@JUNIT_OPTION
@JSON_OPTION
@click.option("--coverage", "coverage_out", is_flag=False, flag_value="", default=None,
              help="Also measure model and code coverage of what is verified and write it to this file "
                   "(given without a file: the project's docs/coverage.md).")
@user_errors
def verify(vehicle: Path | None, estimators: tuple[str, ...], seed: int, real: str | None,
           params: str | None, junit: Path | None, json_out: Path | None, coverage_out: str | None) -> None:
    """Check that the project's generated/ holds what the vehicle file generates, compile that C and
    compare it step by step with the NumPy reference: every form the vehicle file declares ([codegen]
    real/params and forms), or the one --real/--params ask for."""
    from vsegen.harness.verify.equivalence import verify as verify_all

    config = vehicle_config(vehicle)
    names = chosen_estimators(config, estimators)
    forms = _forms(config, names, real, params)
    stale = {form: {name: why for name in mine if (why := stale_kit(config, name, *form, "verify"))}
             for form, mine in forms.items()}
    if any(stale.values()):
        _write_reports(junit, json_out, [report.as_checks(report.Run(config.name, *form, why), [])
                                         for form, why in stale.items() if why])
        sys.exit(1)
    runs = []
    for (form_real, form_params), mine in forms.items():
        label = "verifying" if len(forms) == 1 else f"verifying {form_real}-{form_params}"
        with RunProgress(label, {name: len(VERIFICATION_SET) for name in mine}) as progress:
            results = verify_all(config, tuple(mine), seed=seed, real=form_real, params=form_params,
                                 on_done=lambda result, progress=progress: progress.done(result.estimator, result.ok))
        print_table(difference_table(f"generated C vs NumPy reference, vehicle {config.name}, T = "
                                     f"{config.sample_time} s, {form_real}, {form_params} parameters", results))
        explain_differences(form_real, any(r.flips for r in results), any(r.crossings for r in results))
        runs.append((report.Run(config.name, form_real, form_params), results))
    _write_reports(junit, json_out, [report.as_checks(run, results) for run, results in runs])
    if coverage_out is not None:
        _coverage(config, forms, Path(coverage_out) if coverage_out else project().reports / "coverage.md", seed)
    every = [r for _, results in runs for r in results]
    failed = [r for r in every if not r.ok]
    if failed:
        click.echo(f"vsegen: verify FAILED on {len(failed)} of {len(every)} runs", err=True)
        sys.exit(1)
    console.print(f"verify passed: {len(every)} runs in {len(runs)} form(s), every output within tolerance")


def _coverage(config: VehicleConfig, forms: dict, out: Path, seed: int) -> None:
    """Model and code coverage of every estimator in its verified forms, written to ``out``."""
    from vsegen.harness.project.paths import cache_dir
    from vsegen.harness.target.misra import provenance
    from vsegen.harness.verify import coverage

    names = list(dict.fromkeys(name for mine in forms.values() for name in mine))
    results = []
    with RunProgress("coverage", {name: 1 for name in names}) as progress:
        for name in names:
            mine = [form for form, estimators in forms.items() if name in estimators]
            results.append(coverage.measure(config, name, mine, cache_dir() / "coverage", seed=seed))
            progress.done(name, True)
    write_text_atomic(out, coverage.markdown(results, provenance(project().root, "vsegen verify --coverage", "gcovr")))
    shares = coverage.totals(results)
    console.print(f"wrote {display(out)}: model decisions both ways or justified {shares['model']:.1f} % "
                  f"({shares['not_justified']:.0f} not justified), template statements {shares['statements']:.1f} %, "
                  f"template branches {shares['branches']:.1f} %")


def _forms(config: VehicleConfig, names: list[str], real: str | None, params: str | None) -> dict:
    """{(real, params): estimators} to verify: the form asked for, else every form declared."""
    if real or params:
        return {(real or config.codegen["real"], params or config.codegen["params"]): names}
    forms: dict[tuple[str, str], list[str]] = {}
    for name in names:
        for form_real, form_params, _ in forms_to_write(config, name):
            forms.setdefault((form_real, form_params), []).append(name)
    return forms


def _write_reports(junit: Path | None, json_out: Path | None, checks: list[list]) -> None:
    every = [check for part in checks for check in part]
    write_results(junit, json_out, "vsegen verify", every,
                  {"runs": len({(c.suite, c.figures.get("scenario")) for c in every if "scenario" in c.figures}),
                   "failed_runs": len({(c.suite, c.figures.get("scenario")) for c in every
                                       if not c.ok and "scenario" in c.figures})})


def difference_table(title: str, results, extra_rows=None) -> Table:
    """The verify table of ``results`` (harness.verify.equivalence.CaseResult); ``extra_rows(i)`` gives more
    rows (cells) after the ``i``-th result."""
    table = Table(title=title)
    for column in ("estimator", "scenario", "samples", "signal", "max |diff|", "max rel diff",
                   "tolerance", "result"):
        table.add_column(column, justify="right" if column.startswith(("max", "sam", "tol")) else "left")
    for i, result in enumerate(results):
        for diff in checks(result):
            tolerance = "identical" if diff.integer else f"{diff.tolerance:.0e}"
            table.add_row(result.estimator, result.case, str(result.samples), diff.name,
                          f"{diff.max_abs:.2e}", "-" if diff.integer else f"{diff.max_rel:.2e}",
                          tolerance, "ok" if diff.ok else "FAIL")
        if result.flips:
            table.add_row(result.estimator, result.case, str(result.samples),
                          "resampling flips", str(result.flips), "-", "explained", "ok")
        if result.crossings:
            table.add_row(result.estimator, result.case, str(result.samples),
                          "decision crossings", str(result.crossings), "-", "explained", "ok")
        for row in (extra_rows(i) if extra_rows else ()):
            table.add_row(result.estimator, result.case, str(result.samples), *row)
        table.add_section()
    return table


def explain_differences(real: str, flips: bool, crossings: bool = False) -> None:
    """The notes under a difference table."""
    from vsegen.harness.verify.compare import PEAK_FRACTION, TOLERANCES
    from vsegen.harness.verify.equivalence import FLIP_MARGIN

    tolerance = TOLERANCES[real]
    console.print(f"relative difference = |c - ref| / max(|c|, |ref|, {tolerance.floor:g} x the "
                  f"signal's scale, {PEAK_FRACTION:g} x peak |signal|); tolerance "
                  f"{tolerance.relative:.0e} for {real}, wider where an estimator amplifies its "
                  "reference's rounding (the unscented filters, ekf_rls's stiffness rate, "
                  "arx_dual_kf's random-walk parameters; column 'tolerance'; harness/verify/compare.py)")
    if flips:
        console.print("resampling flips: steps of a float particle filter whose resampling chose "
                      "another particle than the reference because a point lay within float "
                      f"rounding (< {FLIP_MARGIN:g}) of a cumulative weight; each matches the "
                      "reference's step with that point moved across the weight (every step is "
                      "checked from the C's own state)")
    if crossings:
        console.print("decision crossings: steps where the C's state and the reference's lay within "
                      "rounding on two sides of a threshold of the reference's step (proven by "
                      "bisection: its step jumps between them); the comparison goes on from the "
                      "reference's step from the C's state (harness/verify/crossings.py)")
