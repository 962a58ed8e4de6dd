"""`vsegen verify`: the generated C against the NumPy reference, step by step, and the difference
table it shares with `vsegen pil`."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.table import Table

from vsegen.harness.cli.common import (
    JSON_OPTION,
    JUNIT_OPTION,
    PARAMS_OPTION,
    REAL_OPTION,
    VEHICLE_OPTION,
    chosen_estimators,
    console,
    print_table,
    stale_kit,
    user_errors,
    vehicle_config,
)
from vsegen.harness.jobs.progress import RunProgress
from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.verify import report
from vsegen.harness.verify.report import checks


@click.command()
@VEHICLE_OPTION
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator name (repeatable). Default: every estimator the vehicle file configures.")
@click.option("--seed", default=1, show_default=True, help="Seed of the simulated sensor noise.")
@REAL_OPTION
@PARAMS_OPTION
@JUNIT_OPTION
@JSON_OPTION
@user_errors
def verify(vehicle: Path | None, estimators: tuple[str, ...], seed: int, real: str | None,
           params: str | None, junit: Path | None, json_out: Path | None) -> None:
    """Check that the project's generated/ holds what the vehicle file generates, compile that C and
    compare it step by step with the NumPy reference."""
    from vsegen.harness.verify.equivalence import verify as verify_all

    config = vehicle_config(vehicle)
    real = real or config.codegen["real"]
    params = params or config.codegen["params"]
    names = chosen_estimators(config, estimators)
    stale = {name: why for name in names if (why := stale_kit(config, name, real, params, 'verify'))}
    if stale:
        _write_reports(junit, json_out, report.Run(config.name, real, params, stale), [])
        sys.exit(1)
    with RunProgress("verifying", {name: len(VERIFICATION_SET) for name in names}) as progress:
        results = verify_all(config, names, seed=seed, real=real, params=params,
                             on_done=lambda result: progress.done(result.estimator, result.ok))
    table = difference_table(f"generated C vs NumPy reference, vehicle {config.name}, "
                              f"T = {config.sample_time} s, {real}, {params} parameters", results)
    print_table(table)
    explain_differences(real, any(r.flips for r in results), any(r.crossings for r in results))
    _write_reports(junit, json_out, report.Run(config.name, real, params), results)
    failed = [r for r in results if not r.ok]
    if failed:
        click.echo(f"vsegen: verify FAILED on {len(failed)} of {len(results)} runs", err=True)
        sys.exit(1)
    console.print(f"verify passed: {len(results)} runs, every output within tolerance")


def _write_reports(junit: Path | None, json_out: Path | None, run: report.Run, results) -> None:
    for path, text in ((junit, report.as_junit), (json_out, report.as_json)):
        if path is not None:
            path.write_text(text(run, results))


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
