"""`vsegen campaign`: every log of a test campaign through estimators and settings files, on a
Dask cluster, cached; a Parquet table, a markdown summary and an HTML report."""

from __future__ import annotations

import hashlib
from pathlib import Path

import click

from vsegen.harness.cli.common import (
    CHANNELS_OPTION,
    DBC_OPTION,
    JSON_OPTION,
    JUNIT_OPTION,
    UserError,
    chosen_estimators,
    console,
    user_errors,
)
from vsegen.harness.project.results import Check, write_results

DEFAULT_ESTIMATORS = ("switching",)
PLOTS = 3
"""Worst runs plotted in the HTML report."""


@click.command()
@click.argument("logs", nargs=-1, required=True)
@click.option("--estimator", "estimators", multiple=True,
              help="Estimator (repeatable). Default: switching, the primary estimator.")
@click.option("--vehicle", "vehicles", type=click.Path(path_type=Path), multiple=True,
              help="Vehicle/settings file (repeatable: each is run and reported). Default: the project's vehicle.")
@click.option("--baseline", type=click.Path(path_type=Path), default=None,
              help="A settings file to compare with (run too), or an earlier campaign's results.parquet "
                   "(another release): the report lists the logs where the new one is worse.")
@CHANNELS_OPTION
@DBC_OPTION
@click.option("--scheduler", default=None,
              help="'local' (default: a Dask LocalCluster, a worker per core), 'serial', or the address of a "
                   "Dask scheduler, e.g. tcp://host:8786 (its workers must see the logs at the same paths).")
@click.option("--out", type=click.Path(path_type=Path), default=Path("campaign"), show_default=True,
              help="Folder for results.parquet, summary.md and report.html.")
@JUNIT_OPTION
@JSON_OPTION
@user_errors
def campaign(logs: tuple[str, ...], estimators: tuple[str, ...], vehicles: tuple[Path, ...], baseline: Path | None,
             channels: Path | None, dbc: Path | None, scheduler: str | None, out: Path, junit: Path | None,
             json_out: Path | None) -> None:
    """Run LOGS (files, folders searched for logs, or glob patterns) through every estimator with
    every settings file. Each run's row is cached by (log content, generated C, settings): a second
    campaign computes only what changed. Logs that cannot be read are listed with their reason and
    the campaign goes on; the exit status is then 1, as it is when a run is silently wrong
    (|beta error| > 2 deg with status 0 for more than 0.5 s: a bug, listed in the reports)."""
    from vsegen.harness.campaign import report
    from vsegen.harness.campaign.run import find_logs, run_campaign
    from vsegen.harness.jobs.pool import ClusterError, DaskPool
    from vsegen.harness.jobs.progress import RunProgress

    found = find_logs(logs)
    settings = [_settings(path) for path in (vehicles or (None,))]
    compare_table = baseline is not None and baseline.suffix.lower() == ".parquet"
    old_table = report.read_table(baseline) if compare_table else None   # its mistakes before any run
    if baseline is not None and not compare_table:
        settings.append(_settings(baseline, f"{report.BASELINE_PREFIX}{baseline.stem}"))
    if len({s.label for s in settings}) != len(settings):
        raise UserError(f"settings files {', '.join(s.label for s in settings)}: expected different file names")
    matched = report.baseline_settings(old_table, [s.label for s in settings], baseline) if compare_table else None
    names = list(estimators or DEFAULT_ESTIMATORS)
    for s in settings:
        chosen_estimators(s.config, tuple(names))
    try:
        with DaskPool(scheduler) as pool, RunProgress("campaign", {"logs": len(found)}) as progress:
            result = run_campaign(found, names, settings, channels, dbc, pool,
                                  on_log=lambda log, ok: progress.done("logs", ok))
    except ClusterError as exc:
        raise UserError(str(exc)) from None
    here = f"{Path.cwd()}/"
    result.failed = [(log, reason.replace(here, "")) for log, reason in result.failed]   # as the user named them
    new = [row for row in result.rows if not row["settings"].startswith(report.BASELINE_PREFIX)]
    worse = None
    if baseline is not None:
        old = old_table if compare_table else [row for row in result.rows if row["settings"] == settings[-1].label]
        worse = report.compare(new, old, matched)
    labels = [s.label for s in settings]
    summary = report.summarise(result, names, labels, worse, str(baseline) if baseline else None)
    out.mkdir(parents=True, exist_ok=True)
    report.write_table(result.rows, out / "results.parquet")
    configs = {s.label: s.config for s in settings}
    plots = report.worst_plots(summary, lambda row: _estimates(row, configs, channels, dbc), PLOTS)
    report.write_reports(summary, plots, out)
    console.print(summary.headline)
    console.print(f"wrote {out / 'results.parquet'}, {out / 'summary.md'}, {out / 'report.html'}")
    if worse:
        console.print(f"{len(worse)} case(s) where the new settings are worse than {baseline}: "
                      f"see {out / 'summary.md'}")
    for _, reason in result.failed:
        click.echo(f"vsegen: failed: {reason}", err=True)
    silent = [row for row in new if report.silently_wrong(row)]
    write_results(junit, json_out, f"vsegen campaign {out}", _checks(result, worse or []),
                  {"headline": summary.headline})
    for row in silent:
        click.echo(f"vsegen: silently wrong: {row['estimator']} ({row['settings']}) on {row['log']}: "
                   f"|beta error| > 2 deg with status 0 for {row['silent_longest_s']:.2f} s", err=True)
    if result.failed or silent:
        raise SystemExit(1)


def _checks(result, worse) -> list[Check]:
    """A check per run (log x estimator x settings; a failure when silently wrong, its figures and
    where it is worse than the baseline) and one per log that failed."""
    from vsegen.harness.campaign import report

    worse_by_run = {}
    for w in worse:
        worse_by_run.setdefault((w.log, w.estimator), []).append(f"{w.measure}: {w.new:.3f} against {w.baseline:.3f}")
    checks = [Check(f"{row['settings']}.{row['estimator']}", row["log"],
                    {"estimator": row["estimator"], "settings": row["settings"], "duration_s": row["duration_s"],
                     "time_flagged_s": row["time_flagged_s"], "beta_rmse_deg": row["beta_rmse_deg"],
                     "beta_max_deg": row["beta_max_deg"], "silent_longest_s": row["silent_longest_s"],
                     "input_faults": row["input_faults"],
                     "worse_than_baseline": "; ".join(worse_by_run.get((row["log"], row["estimator"]), [])) or None},
                    f"silently wrong for {row['silent_longest_s']:.2f} s (|beta error| > 2 deg with status 0)"
                    if report.silently_wrong(row) else None, "silently wrong")
              for row in result.rows if not row["settings"].startswith(report.BASELINE_PREFIX)]
    return checks + [Check("failed logs", log, {}, reason, "log failed") for log, reason in result.failed]


def _settings(path: Path | None, label: str | None = None):
    from vsegen.harness.campaign.run import Settings
    from vsegen.harness.cli.common import vehicle_config
    from vsegen.harness.project.paths import project

    path = path or project().default_vehicle()
    config = vehicle_config(path)
    return Settings(label or Path(path).stem, config, hashlib.sha256(Path(path).read_bytes()).hexdigest())


def _estimates(row: dict, configs: dict, channels: Path | None, dbc: Path | None):
    """(log, estimates) of a campaign row, run again for its plot."""
    from vsegen.harness.host.run_log import EstimatorStream
    from vsegen.harness.logs.sources import open_log

    config = configs[row["settings"]]
    log = open_log(Path(row["log"]), channels, config.sample_time, dbc=dbc).read()
    return log, EstimatorStream(config, row["estimator"], log.sample_time)(log)
