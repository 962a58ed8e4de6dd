"""Seed 000's Table 3, reproduced: the continuous DLC (120 km/h, mu 0.85 -> 0.5 -> 0.35, 30 s,
Table 2 noise, biases compensated) over N seeds; |delta beta| max / mean / RMSE in degrees,
mean ± standard deviation over the seeds, for the kinematic scheme alone, the KF alone, the
switching estimator and the fusion comparison method; then the outlier and the residual-bias
scenarios. The kinematic-only and KF-only rows are the switching estimator with its threshold
forced to 0 and to the largest acceleration a vehicle file allows (1000 m/s^2, never reached; same
pre-processing); the "literal a_y" rows switch off the roll compensation of the accelerometer
(roll_gradient = 0), as the paper does."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from bench import REPO
from bench.document import provenance
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.score.metrics import score
from vsegen.harness.sim.scenarios import Case
from vsegen.model.params import parse_vehicle
from vsegen.model.schema import PHYSICAL_MAXIMUM

PAPER = {"switching": (0.274, 0.059, 0.086), "fusion": (0.462, 0.076, 0.124)}
"""Seed 000 Table 3 (deg): this paper's switching method and the comparison method [14]."""
CASES = (("continuous DLC (Table 3)", Case.of("continuous_dlc")),
         ("continuous DLC, gyro outliers", Case.of("continuous_dlc", outliers=True)),
         ("continuous DLC, residual bias", Case.of("continuous_dlc", bias=True)))


PAPER_KF = {"tyre_model": "linear", "process_noise": [0.25, 0.01], "process_noise_load": 0.0}
"""The paper's KF: linear tyres and the noise docs/methods.md §3 gives the paper's schemes (the paper
gives none), a constant Q_c = diag(0.5^2, 0.1^2) s (the shipped files give switching and fusion
saturating tyres with a friction estimate, switching half this v_y noise, and let fusion's smaller
Q_c grow with a_y)."""
PAPER_SWITCHING = {"offset_memory": 0.0, "kinematic_max_dwell": 0.0, **PAPER_KF}
"""The paper's switching estimator: no learned kinematic offset, no bound on the kinematic dwell
(the shipped files switch both on for roads with bank and sensors with offsets,
docs/robustness.md), the linear KF of :data:`PAPER_KF`."""
PAPER_FUSION = {"integral_gain": 0.5, "offset_memory": 0.0, **PAPER_KF}
"""The paper's comparison method as docs/methods.md reconstructs it: a linear KF with the constant
noise of :data:`PAPER_KF`, k_c = 0.5 1/s, no learned kinematic offset (the shipped files give it the
saturating KF that estimates the friction, k_c = 5 1/s and the learned offset, docs/robustness.md)."""

SHIPPED_SWITCHING = ("switching (shipped: saturating KF estimating the friction, learned offset, "
                     "bounded kinematic dwell)")
SHIPPED_FUSION = ("fusion (shipped: saturating KF estimating the friction, its noise growing with a_y, k_c 5 1/s, "
                  "learned offset)")


def _paper_fusion(vehicle_text: str, source: str, name: str):
    """The vehicle with its fusion estimator as the paper's comparison method (:data:`PAPER_FUSION`)."""
    return parse_vehicle(with_settings(vehicle_text, "estimator.fusion", **PAPER_FUSION), source, name)


def methods(vehicle_text: str, source: str, name: str):
    """(label, vehicle configuration, estimator) of each compared method."""
    def switching(**values):
        return parse_vehicle(with_settings(vehicle_text, "estimator.switching", **PAPER_SWITCHING,
                                           **values), source, name)

    paper_fusion = _paper_fusion(vehicle_text, source, name)

    base = parse_vehicle(vehicle_text, source, name)
    literal = parse_vehicle(with_settings(  # the plant keeps its roll; the estimators ignore it
        with_settings(vehicle_text, "estimator.switching", roll_gradient=0.0, **PAPER_SWITCHING),
        "estimator.fusion", roll_gradient=0.0, **PAPER_FUSION), source, name)
    return (("kinematic only", switching(threshold=1e-9), "switching"),
            ("KF only", switching(threshold=PHYSICAL_MAXIMUM["m/s^2"]), "switching"),
            ("switching (the paper)", switching(), "switching"),
            (SHIPPED_SWITCHING, base, "switching"),
            ("fusion (comparison, the paper's stand-in)", paper_fusion, "fusion"),
            (SHIPPED_FUSION, base, "fusion"),
            ("switching, literal a_y (no roll compensation)", literal, "switching"),
            ("fusion, literal a_y", literal, "fusion"))


BEYOND_CASES = (("HIL-like, μ 0.85", Case.of("hil_sine", mu=0.85)),
                ("HIL-like, μ 0.35", Case.of("hil_sine", mu=0.35)),
                ("continuous DLC", Case.of("continuous_dlc")),
                ("DLC 80 km/h, μ 1.0", Case.of("dlc", speed_kmh=80.0, mu=1.0)),
                ("DLC 120 km/h, μ 1.0 (touches cones)", Case.of("dlc", speed_kmh=120.0, mu=1.0)),
                ("DLC 120 km/h, μ 0.5 (the car spins)", Case.of("dlc", speed_kmh=120.0, mu=0.5)))
BEYOND = (("hysteresis 0.1 m/s²", {"hysteresis": 0.1}),
          ("hysteresis 0.2 m/s²", {"hysteresis": 0.2}),
          ("adaptive threshold (5 s, 0.8 M, ≤ 2.5 m/s²)", {"adaptive_memory": 5.0}),
          ("adaptive threshold + hysteresis 0.2", {"adaptive_memory": 5.0, "hysteresis": 0.2}))
"""Options beyond the paper (switching keys set on top of the vehicle file's literal defaults)."""


def _one_seed(config, estimator: str, case: Case, seed: int) -> tuple[float, float, float]:
    """(max, mean, RMSE) of |delta beta| in degrees of one seed (one cluster job)."""
    log = case.simulate(config, 1.0 / config.sample_time, seed)
    beta = score(log, run_estimator(config, estimator, log))[0]
    return beta.max, beta.mean, beta.rmse


def _statistics(config, estimator: str, case: Case, seeds: int,
                cluster: DaskPool | None = None) -> np.ndarray:
    """(max, mean, RMSE) of |delta beta| in degrees for seeds 1..N, one row per seed; spread over
    ``cluster`` when given."""
    jobs = [(config, estimator, case, seed) for seed in range(1, seeds + 1)]
    return np.array(cluster.map(_one_seed, jobs) if cluster else [_one_seed(*job) for job in jobs])


def _cells(values: np.ndarray) -> list[str]:
    return [f"{m:.3f} ± {s:.3f}" for m, s in zip(values.mean(axis=0), values.std(axis=0))]


def beyond_paper_table(vehicle_text: str, source: str, name: str, seeds: int) -> list[str]:
    """Beyond the paper: the switching estimator with hysteresis on the threshold (A7) and with
    the threshold adapted to the peak lateral acceleration the road has recently carried (A10),
    against the literal single fixed threshold, on the HIL-like scenario (seed 000 §4.3: pedal
    held, growing sine steering) at μ 0.85 and 0.35, the continuous DLC and single DLCs up to the
    limit."""
    def variant(keys: dict[str, float]):
        return parse_vehicle(with_settings(vehicle_text, "estimator.switching", **PAPER_SWITCHING,
                                           **keys), source, name)

    base, paper = parse_vehicle(vehicle_text, source, name), variant({})
    lines = []
    for title, case in BEYOND_CASES:
        lines += [f"### {title}, {seeds} seeds", "",
                  "| method | β max (°) | β mean (°) | β RMSE (°) | max vs literal |",
                  "|---|---|---|---|---|"]
        literal = _statistics(paper, "switching", case, seeds)
        rows = [("switching (literal, paper)", literal),
                ("fusion (comparison, the paper's stand-in)",
                 _statistics(_paper_fusion(vehicle_text, source, name), "fusion", case, seeds)),
                ("fusion (shipped)", _statistics(base, "fusion", case, seeds))]
        rows += [(f"switching, {label}", _statistics(variant(keys), "switching", case, seeds))
                 for label, keys in BEYOND]
        rows.append((SHIPPED_SWITCHING, _statistics(base, "switching", case, seeds)))
        for label, values in rows:
            change = values[:, 0].mean() / literal[:, 0].mean() - 1
            lines.append(f"| {label} | {' | '.join(_cells(values))} | {change:+.1%} |")
        lines.append("")
    return lines


def table(vehicle_text: str, source: str, name: str, seeds: int,
          scheduler: str | None = None) -> list[str]:
    """The Table 3 reproduction (and its outlier and bias variants) as markdown lines, the runs
    spread over the cluster of ``scheduler`` (harness.jobs.pool)."""
    lines = []
    with DaskPool(scheduler) as cluster:
        for title, case in CASES:
            lines += _case_table(vehicle_text, source, name, seeds, title, case, cluster)
    return lines


def _case_table(vehicle_text, source, name, seeds, title, case, cluster) -> list[str]:
    lines = [f"### {title}, {seeds} seeds", "",
             "| method | β max (°) | β mean (°) | β RMSE (°) | paper max / mean / RMSE (°) |",
             "|---|---|---|---|---|"]
    for label, config, estimator in methods(vehicle_text, source, name):
        cells = _cells(_statistics(config, estimator, case, seeds, cluster))
        key = ("switching" if label == "switching (the paper)"
               else "fusion" if label.startswith("fusion (comparison") else "")
        paper = " / ".join(f"{v:.3f}" for v in PAPER[key]) if key and title.endswith("(Table 3)") else "-"
        lines.append(f"| {label} | {' | '.join(cells)} | {paper} |")
    lines.append("")
    return lines


def main(argv: list[str] | None = None) -> None:
    """``python -m bench.table3 --vehicle FILE --seeds N``: the Table 3 section for one car, written
    to docs/table3_<car>.md (docs/accuracy.md has the default car's, from bench.accuracy)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicle", type=Path, required=True)
    parser.add_argument("--seeds", type=int, default=50)
    parser.add_argument("--scheduler", default=None)
    args = parser.parse_args(argv)
    text = args.vehicle.read_text()
    name = args.vehicle.stem
    lines = [f"# Seed 000 Table 3 on {name}", "",
             f"{provenance(f'python -m bench.table3 --vehicle vehicles/{args.vehicle.name} --seeds {args.seeds}')}: "
             f"truth plant `harness/sim`, the vehicle file's settings (not tuned on "
             f"these runs; car-specific ones from `vsegen identify`), seeds 1..{args.seeds}, mean ± "
             "standard deviation over the seeds.", "",
             *table(text, str(args.vehicle), name, args.seeds, args.scheduler)]
    out = REPO / "docs" / f"table3_{name}.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
