"""Accuracy of every estimator on the common scenario set, against the truth plant.

    python -m bench.accuracy [--vehicle FILE] [--seeds N] [--out FILE]
        [--scheduler local|serial|ADDRESS] [--common-only]

(--out: docs/accuracy.md for the default vehicle, docs/accuracy_<vehicle>.md for another.)

Prints and writes a Markdown table: per scenario whether the run stayed in the cones / spun, and per
estimator the beta max / mean / RMSE in degrees (seed 000 Table 3 format; with --seeds N > 1,
mean ± standard deviation over seeds 1..N), plus vy and r RMSE. Also draws a seed-000-Fig.-8-style
plot of each estimator on every scenario (seed 1) into docs/figures/. The paper reproductions
(seeds 000, 001, 002, 004) follow the common table (not with --common-only, e.g. for another car).
The common table's runs (scenario x seed, every estimator) go to a Dask cluster
(``harness.jobs.pool``: a local cluster by default, or --scheduler); the numbers do not depend on it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import Progress

from bench import DEFAULT_VEHICLE, REPO, seed001, seed002, seed003, table3, transfer, tuning, yaw_rate
from bench.document import provenance
from vsegen.harness.campaign.job import scenario_job
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.score.plot import plot
from vsegen.harness.sim.scenarios import Case
from vsegen.model.estimators import build

SCORING_SET: tuple[Case, ...] = (
    *(Case.of("dlc", speed_kmh=v, mu=mu) for v in (80.0, 120.0) for mu in (1.0, 0.85, 0.5, 0.35)),
    Case.of("dlc", speed_kmh=120.0, outliers=True),
    Case.of("continuous_dlc"),
    Case.of("continuous_dlc", bias=True),
    Case.of("step_steer"),
    Case.of("step_steer", mu=0.5),
    Case.of("sine_steer"),
    Case.of("fishhook"),
)


def _cell(values: list[float] | None) -> str:
    """mean (± std over seeds) of a statistic, '-' for a signal the estimator does not give."""
    if not values:
        return "-"
    return f"{np.mean(values):.3f}" if len(values) == 1 else f"{np.mean(values):.3f} ± {np.std(values):.3f}"


FIG8 = ("switching_continuous_dlc", Case.of("continuous_dlc"), ("switching",))
"""Seed 000 Fig. 8: the switching estimator on the continuous DLC (file stem, case, estimators)."""


def _figure(config, case: Case, names: list[str], stem: str | None = None) -> str:
    """Plot ``names`` on ``case`` (seed 1) into docs/figures/<stem>.png (the case's label by
    default); returns the Markdown line embedding it."""
    log = case.simulate(config, 1.0 / config.sample_time, 1)
    slug = stem or case.label.replace("(", "_").replace(")", "").replace(",", "_").replace("=", "")
    figure = REPO / "docs" / "figures" / f"{slug}.png"
    plot(log, {name: run_estimator(config, name, log) for name in names}, figure,
         title=f"{case.label}, vehicle {config.name}, seed 1")
    return f"![{case.label}](figures/{figure.name})"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicle", type=Path, default=DEFAULT_VEHICLE)
    parser.add_argument("--seeds", type=int, default=1, help="sensor-noise seeds 1..N")
    parser.add_argument("--table3-seeds", type=int, default=50,
                        help="seeds of the seed-000 Table 3 reproduction")
    parser.add_argument("--beyond-seeds", type=int, default=10,
                        help="seeds of the comparison of options beyond the paper")
    parser.add_argument("--pf-runs", type=int, default=50,
                        help="Monte-Carlo runs of the seed-003 reproduction")
    parser.add_argument("--out", type=Path, default=None,
                        help="default: docs/accuracy.md for the default vehicle, else docs/accuracy_<vehicle>.md")
    parser.add_argument("--scheduler", default=None,
                        help="'local' (default), 'serial' or a Dask scheduler address (also $VSEGEN_SCHEDULER)")
    parser.add_argument("--common-only", action="store_true",
                        help="only the common table (no paper reproductions, figures or tuning section)")
    args = parser.parse_args(argv)
    config = load_vehicle(args.vehicle)
    if args.out is None:
        same = args.vehicle.resolve() == DEFAULT_VEHICLE.resolve()
        args.out = REPO / "docs" / ("accuracy.md" if same else f"accuracy_{config.name}.md")
    names = [n for n in config.estimators if "beta" in build(n, config).outputs.names]  # sideslip
    rows = ["| scenario | stayed in cones | spun | estimator | β max (°) | β mean (°) | β RMSE (°) "
            "| v_y RMSE (m/s) | r RMSE (°/s) |", "|---|---|---|---|---|---|---|---|---|"]
    figures = [_figure(config, FIG8[1], list(FIG8[2]), FIG8[0])] if not args.common_only else []
    jobs = [(config, case, seed, tuple(names)) for case in SCORING_SET for seed in range(1, args.seeds + 1)]
    with Progress(console=Console(stderr=True)) as progress, DaskPool(args.scheduler) as cluster:
        task = progress.add_task(f"scoring {len(jobs)} runs x {len(names)} estimators", total=len(jobs))
        results = cluster.map(scenario_job, jobs, lambda *_: progress.advance(task))
    for index, case in enumerate(SCORING_SET):
        runs = results[index * args.seeds:(index + 1) * args.seeds]
        notes = runs[0][0]
        if not args.common_only:
            figures.append(_figure(config, case, names))
        cones = notes.get("stayed in cones", "-").split(" (")[0]
        spun = notes.get("spun", "-").split(" (")[0]
        for name in names:
            st: dict[str, list[float]] = {}
            for _, scores in runs:
                for s in scores[name]:
                    for key, value in ((f"{s.signal}_max", s.max), (f"{s.signal}_mean", s.mean),
                                       (f"{s.signal}_rmse", s.rmse)):
                        st.setdefault(key, []).append(value)
            rows.append(f"| {case.label} | {cones} | {spun} | {name} | {_cell(st['beta_max'])} | "
                        f"{_cell(st['beta_mean'])} | {_cell(st['beta_rmse'])} | "
                        f"{_cell(st.get('vy_rmse'))} | {_cell(st.get('r_rmse'))} |")
    header = [
        f"# Accuracy on the common scenarios (vehicle {config.name})",
        "",
        f"{provenance(_command(args))}: truth plant "
        "`harness/sim` (two-track, Magic Formula tyres), sensor noise of seed 000 Table 2 "
        "(biases only in the `bias=True` rows), estimates from the generated C with the vehicle "
        "file's settings (a few of them, docs/estimators.md says which, were chosen on seed-1 runs of "
        "these scenarios and of the robustness matrix). Errors "
        "e = estimate − truth over every sample, including held samples and runs that left the "
        "course (see the columns).",
        "",
        *rows,
        "",
    ]
    if args.common_only:
        _write(args.out, "\n".join(header))
        return
    text = "\n".join([
        *header,
        "## New car: identify, then tune (both truth cars)",
        "",
        *tuning.table(args.scheduler),
        "",
        "## Transfer between the two cars (every sideslip estimator)",
        "",
        *transfer.table(args.scheduler),
        "",
        "## Seed 000 Table 3 reproduced",
        "",
        *table3.table(args.vehicle.read_text(), str(args.vehicle), config.name, args.table3_seeds),
        "## Beyond the paper: hysteresis (A7) and an adaptive threshold (A10) for switching",
        "",
        *table3.beyond_paper_table(args.vehicle.read_text(), str(args.vehicle), config.name,
                                   args.beyond_seeds),
        "## Seed 004: yaw rate of the ARX dual Kalman filter",
        "",
        *yaw_rate.table(args.vehicle.read_text(), str(args.vehicle), config.name, args.beyond_seeds),
        yaw_rate.parameter_plot(args.vehicle.read_text(), str(args.vehicle), config.name,
                                REPO / "docs" / "figures" / "arx_parameters.png"),
        "",
        "## Seed 001 reproduction (1 kHz logs)",
        "",
        *seed001.table(args.vehicle.read_text(), str(args.vehicle), config.name, args.beyond_seeds),
        "",
        seed001.stiffness_plot(args.vehicle.read_text(), str(args.vehicle), config.name,
                               REPO / "docs" / "figures" / "ekf_rls_stiffness.png"),
        "",
        "## Seed 002 reproduction: UKF and adaptive UKF on the paper's EV",
        "",
        f"Vehicle `vehicles/ev_seed002.toml` (Table 1), 96 km/h, μ 0.8, the paper's P_0 = 0, "
        f"Q and R; mean over seeds 1..{args.beyond_seeds}. The paper reports no numbers, only "
        "that the AUKF beats the UKF.",
        "",
        *seed002.table(args.beyond_seeds),
        "",
        *seed002.figures(),
        "",
        "## Seed 003 reproduction: improved particle filter against the adaptive PF",
        "",
        f"{args.pf_runs} Monte-Carlo runs per case (D8: seeds 1..{args.pf_runs} for the sensor "
        "noise and the filters' stream; the truth trajectory is the same), N = "
        f"{config.settings('pf_improved')['particles']}, estimates from the generated C. "
        "The paper gives only the change of the improved PF against the adaptive PF (§4).",
        "",
        *seed003.table(args.vehicle.read_text(), str(args.vehicle), config.name, args.pf_runs),
        "",
        "Float against double C (D5: a float build's resampling parts from the double's after a "
        f"few steps, so they are compared statistically), DLC 120 km/h, {args.pf_runs} runs:",
        "",
        *seed003.float_against_double(args.vehicle.read_text(), str(args.vehicle), config.name,
                                      args.pf_runs),
        "",
        "## Plots (seed 1)",
        "",
        *figures,
        "",
    ])
    _write(args.out, text)


def _command(args: argparse.Namespace) -> str:
    """The command line that writes this report again."""
    parts = ["python -m bench.accuracy", f"--vehicle {_shown_path(args.vehicle)}", f"--seeds {args.seeds}"]
    if args.common_only:
        return " ".join([*parts, "--common-only"])
    return " ".join([*parts, f"--table3-seeds {args.table3_seeds}", f"--beyond-seeds {args.beyond_seeds}",
                     f"--pf-runs {args.pf_runs}"])


def _shown_path(path: Path) -> str:
    return str(path.resolve().relative_to(REPO)) if path.resolve().is_relative_to(REPO) else str(path)


def _write(out: Path, text: str) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
