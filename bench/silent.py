"""The "never silently wrong" rule on both truth cars: for every sideslip estimator and every
verification scenario, the longest stretch of |beta error| > 2 deg with status 0 (before the car
spins; the rule allows 0.5 s), and whether it beats answering beta = 0 (RMSE within 0.7
RMS(beta_ref) or 0.1 deg, over the run or over its unflagged samples). Seed 1, the shipped vehicle
files (some of their settings were chosen on these runs). Writes docs/silent.md:
``python -m bench.silent [--scheduler ADDRESS]``."""

from __future__ import annotations

import numpy as np

from bench import REPO
from bench.document import provenance, write_cluster_report
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.score.metrics import SILENT_DURATION, silent_error_time, worse_than_zero
from vsegen.harness.sim.scenarios import SCORED_SET, Case
from vsegen.model.estimators import DEFINITIONS

CARS = ("c_class", "rwd_saloon")
SEED = 1
OUT = REPO / "docs" / "silent.md"
MODEL_BASED = ("kf2dof", "switching", "fusion", "ekf_rls", "ukf", "aukf")
"""The estimators the "better than zero" rule binds (#44): those whose sideslip rests on a vehicle model."""


def longest_silent(car: str, case: Case) -> dict[str, tuple[float, tuple[float, float] | None]]:
    """Per sideslip estimator on ``case``: its longest silent error (s) and, when it does not beat
    answering beta = 0, its unflagged RMSE and the bound (rad; one cluster job)."""
    config = load_vehicle(REPO / "vehicles" / f"{car}.toml")
    log = case.simulate(config, 1.0 / config.sample_time, SEED)
    result = {}
    for name in DEFINITIONS:
        estimates = run_estimator(config, name, log)
        if "beta" in estimates:
            result[name] = (silent_error_time(log, estimates)[0], worse_than_zero(log, estimates))
    return result


def report(scheduler: str | None) -> list[str]:
    jobs = [(car, case) for car in CARS for case in SCORED_SET]
    with DaskPool(scheduler) as cluster:
        results = cluster.map(longest_silent, jobs)
    names = list(results[0])
    lines = ["# Never silently wrong", "",
             f"{provenance('python -m bench.silent')}. The rule: on any scenario where the car does "
             "not spin, |β error| > 2° for more than 0.5 s must come with a non-zero status. "
             "Below, per estimator, the longest stretch of |β error| > 2° with status 0 (s; "
             "**bold**: beyond 0.5 s), samples after a spin (|β| > 15°) not scored; truth plant "
             "`harness/sim`, sensor-noise seed 1, the shipped vehicle files (some of their settings "
             "were chosen on these runs and the robustness matrix's, docs/estimators.md says which).", "",
             "| car | scenario | " + " | ".join(names) + " |",
             "|---|---|" + "---|" * len(names)]
    for (car, case), row in zip(jobs, results):
        cells = [f"**{row[n][0]:.2f}**" if row[n][0] > SILENT_DURATION else f"{row[n][0]:.2f}" for n in names]
        lines.append(f"| {car} | {case.label} | " + " | ".join(cells) + " |")
    holds = [n for n in names if all(row[n][0] <= SILENT_DURATION for row in results)]
    lines += ["", f"The rule holds on both cars for: {', '.join(holds) or 'none'} "
              "(tested: tests/test_consistency.py).", ""]
    worse = [f"{name} on {car} {case.label} ({np.degrees(fail[0]):.2f}° unflagged, bound {np.degrees(fail[1]):.2f}°)"
             for (car, case), row in zip(jobs, results) for name, (_, fail) in row.items()
             if fail is not None and name in MODEL_BASED]
    particles = sum(fail is not None for row in results for name, (_, fail) in row.items() if name not in MODEL_BASED)
    lines += ["## Better than answering β = 0", "",
              "Every model-based estimate (" + ", ".join(MODEL_BASED) + ") must score a β RMSE within "
              "0.7 × RMS(β_ref), or 0.1°, over the run, or else over its samples with status 0 (the status "
              "covers where it does not): else answering β = 0 would do about as well without saying so. "
              "Runs that break it: " + ("; ".join(worse) or "none") + f". The particle filters (kinematic, "
              f"noisier by design) break it on {particles} of {2 * len(jobs)} runs."]
    return lines


def main(argv: list[str] | None = None) -> None:
    write_cluster_report(__doc__.splitlines()[0], OUT, report, argv)


if __name__ == "__main__":
    main()
