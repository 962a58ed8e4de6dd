"""What a campaign writes: the Parquet table of its rows, a markdown summary, and a self-contained
HTML report (the summary's tables and PNG plots of the worst logs, embedded; no server needed); and
the comparison with a baseline (another settings file, or an earlier campaign's table)."""

from __future__ import annotations

import base64
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsegen.harness.campaign.row import LATERAL_COLUMNS, SPEED_COLUMNS
from vsegen.harness.logs.table import LogError
from vsegen.harness.project.files import write_atomic, write_text_atomic
from vsegen.harness.score.metrics import SILENT_DURATION

WORSE_RMSE_RATIO = 1.05
WORSE_RMSE_MARGIN = 0.01
"""deg: a log's beta RMSE is worse when it exceeds the baseline's by 5 % plus this."""
WORSE_FLAGGED = 0.01
"""Without a reference: flagged for longer than the baseline by this share of the log (and 1 s)."""


@dataclass(frozen=True)
class Worse:
    """A log where the new settings do worse than the baseline: by which measure, and the values."""

    log: str
    estimator: str
    measure: str
    new: float
    baseline: float


def write_table(rows: Sequence[dict], path: Path) -> None:
    """The rows as a Parquet table (one row per log x estimator x settings), atomically."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist(list(rows))
    write_atomic(path, lambda tmp: pq.write_table(table, tmp))


COMPARED = ("log", "estimator", "duration_s", "time_flagged_s", "beta_rmse_deg", "silent_longest_s")
"""The columns a baseline table must have."""


def read_table(path: Path) -> list[dict]:
    """The rows of an earlier campaign's Parquet table; LogError (one line) when it is not one."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if not Path(path).is_file():
        raise LogError(f"{path}: cannot read the baseline table: no such file")
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException) as exc:
        raise LogError(f"{path}: not a readable Parquet table ({str(exc).splitlines()[0][:100]}): expected the "
                       f"results.parquet of an earlier `vsegen campaign`") from None
    missing = [name for name in COMPARED if name not in table.column_names]
    if missing:
        raise LogError(f"{path}: no column {', '.join(missing)}: expected the results.parquet of an earlier "
                       f"`vsegen campaign`")
    return table.to_pylist()


BASELINE_PREFIX = "baseline:"
"""The settings label of a campaign's --baseline settings file (its rows are not its results)."""


def baseline_settings(table: Sequence[dict], labels: Sequence[str], path: Path) -> dict[str, str]:
    """Which settings of an earlier campaign's ``table`` each new settings label is compared with:
    the one of the same name, else the table's only one; rows of the earlier campaign's own
    baseline do not count. LogError (one line) when that is ambiguous."""
    labels_in_table = {row.get("settings", "") for row in table}
    old = sorted(label for label in labels_in_table if label and not label.startswith(BASELINE_PREFIX)) or [""]
    chosen = {}
    for label in labels:
        if label in old or len(old) == 1:
            chosen[label] = label if label in old else old[0]
        else:
            raise LogError(f"{path}: rows of the settings {', '.join(old)}: expected one of them to be named "
                           f"{label} like the new settings file, or a table of one settings file")
    return chosen


def compare(rows: Sequence[dict], baseline: Sequence[dict], matched: dict[str, str] | None = None) -> list[Worse]:
    """Where ``rows`` do worse than ``baseline``, matched by log, estimator and settings
    (``matched``: new settings label -> the baseline's; None: every row against every baseline row
    of the same log and estimator, the baseline holding one settings file): a beta RMSE above the
    baseline's by more than 5 % + 0.01 deg, a silent stretch beyond 0.5 s and the baseline's, or,
    without a reference, more time flagged."""
    base = {(row["log"], row["estimator"], row.get("settings", "") if matched else ""): row for row in baseline}
    worse = []
    for row in rows:
        old = base.get((row["log"], row["estimator"], matched.get(row["settings"], "") if matched else ""))
        if old is None:
            continue
        new_rmse, old_rmse = row["beta_rmse_deg"], old["beta_rmse_deg"]
        if _finite(new_rmse) and _finite(old_rmse):
            if new_rmse > old_rmse * WORSE_RMSE_RATIO + WORSE_RMSE_MARGIN:
                worse.append(Worse(row["log"], row["estimator"], "beta RMSE (deg)", new_rmse, old_rmse))
            if row["silent_longest_s"] > max(SILENT_DURATION, old["silent_longest_s"]):
                worse.append(Worse(row["log"], row["estimator"], "longest silent stretch (s)",
                                   row["silent_longest_s"], old["silent_longest_s"]))
        elif row["time_flagged_s"] > old["time_flagged_s"] + max(1.0, WORSE_FLAGGED * row["duration_s"]):
            worse.append(Worse(row["log"], row["estimator"], "time flagged (s)", row["time_flagged_s"],
                               old["time_flagged_s"]))
    return worse


def _finite(value) -> bool:
    return value is not None and math.isfinite(value)


@dataclass
class Summary:
    """The tables of a campaign's summary, as rows of cells (the first row the header)."""

    headline: str
    groups: list[list[str]]
    coverage: list[list[str]]
    worst: list[list[str]]
    worse: list[list[str]]
    failed: list[list[str]]
    worst_rows: list[dict]
    silent: list[list[str]]
    """Runs silently wrong (|beta error| > 2 deg with status 0) for longer than SILENT_DURATION: bugs."""


def summarise(result, estimators: Sequence[str], labels: Sequence[str], worse: Sequence[Worse] | None,
              baseline: str | None, worst_count: int = 10) -> Summary:
    """The summary of a :class:`~vsegen.harness.campaign.run.CampaignResult`."""
    rows = result.rows
    logs = sorted({row["log"] for row in rows})
    first = [row for row in rows if row["settings"] == labels[0] and row["estimator"] == estimators[0]]
    hours = sum(row["duration_s"] for row in first) / 3600
    km = sum(row["distance_km"] for row in first)
    runs = result.computed + result.cached
    headline = (f"{len(logs)} logs ({hours:.2f} h, {km:.1f} km) x {len(estimators)} estimator(s) x {len(labels)} "
                f"settings file(s): {runs} runs, {result.computed} computed, {result.cached} from the cache"
                + (f"; {len(result.failed)} log(s) failed" if result.failed else ""))
    groups = [["settings", "estimator", "logs", "hours", "flagged %", "beta RMSE (deg)", "worst log (beta RMSE)",
               "longest silent (s)", "logs with input faults"]]
    for label in labels:
        for name in estimators:
            mine = [row for row in rows if row["settings"] == label and row["estimator"] == name]
            if not mine:
                continue
            duration = sum(row["duration_s"] for row in mine)
            scored = [row for row in mine if _finite(row["beta_rmse_deg"])]
            weight = sum(row["duration_s"] for row in scored)
            rmse = math.sqrt(sum(row["beta_rmse_deg"] ** 2 * row["duration_s"] for row in scored) / weight) \
                if weight else math.nan
            worst = max(scored, key=lambda row: row["beta_rmse_deg"], default=None)
            silent = max((row["silent_longest_s"] for row in scored), default=math.nan)
            groups.append([label, name, str(len(mine)), f"{duration / 3600:.2f}",
                           f"{100 * sum(row['time_flagged_s'] for row in mine) / duration:.1f}", _number(rmse),
                           f"{Path(worst['log']).name} ({worst['beta_rmse_deg']:.3f})" if worst else "-",
                           _number(silent, 2), str(sum(1 for row in mine if row["input_faults"]))])
    coverage = [["speed band", "hours", "|a_y| band", "hours"]]
    speed = [sum(row[c] for row in first) / 3600 for c in SPEED_COLUMNS]
    lateral = [sum(row[c] for row in first) / 3600 for c in LATERAL_COLUMNS]
    for i in range(max(len(speed), len(lateral))):
        coverage.append([_band(SPEED_COLUMNS, i), f"{speed[i]:.3f}" if i < len(speed) else "",
                         _band(LATERAL_COLUMNS, i), f"{lateral[i]:.3f}" if i < len(lateral) else ""])
    worst_rows = sorted(rows, key=_badness, reverse=True)[:worst_count]
    worst_table = [["log", "settings", "estimator", "beta RMSE (deg)", "beta max (deg)", "flagged %",
                    "longest silent (s)", "input faults"]]
    for row in worst_rows:
        worst_table.append([Path(row["log"]).name, row["settings"], row["estimator"], _number(row["beta_rmse_deg"]),
                            _number(row["beta_max_deg"]), f"{100 * row['time_flagged_s'] / row['duration_s']:.1f}",
                            _number(row["silent_longest_s"], 2), row["input_faults"] or "-"])
    worse_table = [["log", "estimator", "measure", "new", f"baseline ({baseline})"]] + [
        [Path(w.log).name, w.estimator, w.measure, f"{w.new:.3f}", f"{w.baseline:.3f}"] for w in (worse or [])]
    failed = [["log", "reason"]] + [[Path(log).name, reason] for log, reason in result.failed]
    silent = [["log", "settings", "estimator", "longest silent (s)", "beta RMSE (deg)"]] + [
        [Path(row["log"]).name, row["settings"], row["estimator"], _number(row["silent_longest_s"], 2),
         _number(row["beta_rmse_deg"])]
        for row in sorted(rows, key=lambda row: -row["silent_longest_s"]) if silently_wrong(row)]
    return Summary(headline, groups, coverage, worst_table, worse_table if baseline else [], failed, worst_rows,
                   silent)


def silently_wrong(row: dict) -> bool:
    """A run's estimate was wrong with status 0 for longer than SILENT_DURATION (a bug)."""
    return _finite(row["silent_longest_s"]) and row["silent_longest_s"] > SILENT_DURATION


def _badness(row: dict) -> tuple[float, float]:
    """Logs with a reference by beta RMSE first, then by the share of time flagged."""
    rmse = row["beta_rmse_deg"]
    return (rmse if _finite(rmse) else -1.0, row["time_flagged_s"] / max(row["duration_s"], 1e-9))


def _band(columns: list[str], i: int) -> str:
    if i >= len(columns):
        return ""
    low, high, unit = columns[i].split("_")[2:5]
    unit = {"kmh": "km/h", "ms2": "m/s^2"}[unit]
    return f"{low}-{high} {unit}" if high != "up" else f"above {low} {unit}"


def _number(value: float, digits: int = 3) -> str:
    return f"{value:.{digits}f}" if _finite(value) else "-"


def markdown(summary: Summary) -> str:
    """The summary as markdown."""
    parts = ["# Campaign", "", summary.headline, "", "## Per settings and estimator", "", _md(summary.groups),
             "", "## Coverage (the logs' time in each band)", "", _md(summary.coverage), "",
             "## Worst logs", "", _md(summary.worst)]
    if len(summary.silent) > 1:
        parts += ["", f"## Silently wrong (a bug): |beta error| > 2 deg with status 0 for more than "
                      f"{SILENT_DURATION:g} s", "", _md(summary.silent)]
    if summary.worse:
        parts += ["", "## Where the new settings are worse than the baseline", "",
                  _md(summary.worse) if len(summary.worse) > 1 else "No log is worse."]
    if len(summary.failed) > 1:
        parts += ["", "## Logs that failed", "", _md(summary.failed)]
    return "\n".join(parts) + "\n"


def _md(table: list[list[str]]) -> str:
    cells = [[cell.replace("|", "\\|") for cell in row] for row in table]
    lines = ["| " + " | ".join(cells[0]) + " |", "|" + "---|" * len(cells[0])]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in cells[1:]])


def html(summary: Summary, plots: Sequence[tuple[str, bytes]]) -> str:
    """The summary as one HTML page, with ``plots`` ((caption, PNG bytes)) embedded."""
    from jinja2 import Environment, PackageLoader, select_autoescape

    env = Environment(loader=PackageLoader("vsegen.harness.campaign", "."), autoescape=select_autoescape(["j2"]))
    return env.get_template("report.html.j2").render(
        summary=summary, plots=[(caption, base64.b64encode(png).decode()) for caption, png in plots],
        silent_duration=f"{SILENT_DURATION:g}")


def worst_plots(summary: Summary, estimates_of, count: int) -> list[tuple[str, bytes]]:
    """PNG plots of the ``count`` worst runs: beta against the reference (where the log has one)
    and the status over time; ``estimates_of(row)`` gives (log, estimates) of a row's run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plots = []
    for row in summary.worst_rows[:count]:
        log, estimates = estimates_of(row)
        figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 4.5), sharex=True, height_ratios=(3, 1))
        top.plot(log["t"], np.degrees(estimates["beta"]), label=f"{row['estimator']} ({row['settings']})")
        if "beta_ref" in log:
            top.plot(log["t"], np.degrees(log["beta_ref"]), "k--", linewidth=0.8, label="reference")
        top.set_ylabel("beta (deg)")
        top.legend(loc="upper right")
        bottom.step(log["t"], estimates["status"] != 0, where="post")
        bottom.set_ylabel("flagged")
        bottom.set_xlabel("t (s)")
        figure.tight_layout()
        buffer = io.BytesIO()
        figure.savefig(buffer, format="png", dpi=80)
        plt.close(figure)
        caption = f"{Path(row['log']).name}: {row['estimator']} with {row['settings']}"
        plots.append((caption, buffer.getvalue()))
    return plots


def write_reports(summary: Summary, plots: Sequence[tuple[str, bytes]], folder: Path) -> None:
    """summary.md and report.html in ``folder``."""
    write_text_atomic(folder / "summary.md", markdown(summary))
    write_text_atomic(folder / "report.html", html(summary, plots))
