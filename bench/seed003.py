"""Seed 003 reproduction and cost: the improved particle filter (pf_improved) against its baseline,
the adaptive PF of the paper's ref. [17] (pf_adaptive).

* :func:`table`: 50 Monte-Carlo runs (D8: seeds 1..50 for the sensor noise and for the filters'
  own stream) of the DLC at 120 km/h and the sine steer at 80 km/h for 10 s (§3 assumption: 30°
  hand-wheel, 0.5 Hz, from t = 1 s); MAE, max |e| and RMSE of v_x and v_y, mean over the runs,
  and the improved filter's change beside the paper's percentages (§4). Run once as the spec
  reads (z = [a_x, a_y, r], the literal (13)) and once with option D2 (the logged v_x in z).
* :func:`costs`: instructions per step and per particle (callgrind, -O2) and Cortex-M4F memory
  for N = 100, 200, 500, with the ziggurat and with Box-Muller normals (``python -m bench.seed003``
  writes this section of docs/benchmarks.md; ``python -m bench`` all of it).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from bench import BENCHMARKS, DEFAULT_VEHICLE
from bench.document import provenance, write_section
from bench.measure import generated_driver, write_inputs
from vsegen.codegen.generate import render
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.target.toolchains import available, build_for_target, target_for
from vsegen.model.estimators import build, pf
from vsegen.model.params import VehicleConfig, parse_vehicle

FILTERS = (pf.ADAPTIVE, pf.IMPROVED)
STEERING_WHEEL_RATIO = 16.0
"""Hand-wheel to road-wheel angle for the spec's 30° hand-wheel sine (a typical C-class ratio)."""
CASES = (("DLC 120 km/h", Case.of("dlc", speed_kmh=120.0)),
         ("sine steer 80 km/h, 10 s", Case.of("sine_steer", speed_kmh=80.0,
                                               amplitude=round(np.deg2rad(30.0) / STEERING_WHEEL_RATIO, 5),
                                               frequency=0.5, duration=10.0)))
PAPER = {"DLC 120 km/h": {"vx": (-40.25, -49.23, -25.63), "vy": (-55.71, -54.23, -57.25)},
         "sine steer 80 km/h, 10 s": {"vx": (-47.00, -41.98, -43.85),
                                      "vy": (-41.21, -37.43, -52.85)}}
"""§4: change of MAE, max |e| and RMSE of the improved PF against the adaptive PF, %."""
OBSERVATIONS = (("z = [a_x, a_y, r] as the spec reads (13)", "inertial"),
                ("option D2: z also holds the logged v_x", "wheel_speed"))
COUNTS = (100, 200, 500)
COSTS_CASE = Case.of("dlc", speed_kmh=120.0)
"""The log the cost per particle count is measured on (the reproduction's DLC)."""


def seeded(text: str, source: str, name: str, seed: int, **settings) -> VehicleConfig:
    """The vehicle with both filters' stream seeded with ``seed`` and ``settings`` applied."""
    for table in FILTERS:
        text = with_settings(text, f"estimator.{table}", seed=seed, **settings)
    return parse_vehicle(text, source, name)


def errors(config: VehicleConfig, case: Case, seed: int) -> dict[str, np.ndarray]:
    """Per filter, rows v_x, v_y and columns MAE, max |e|, RMSE (m/s) of one run."""
    log = case.simulate(config, 1.0 / config.sample_time, seed)
    result = {}
    for name in FILTERS:
        est = run_estimator(config, name, log)
        e = [est["vx"] - log["vx_ref"], est["vy"] - log["vy_ref"]]
        result[name] = np.array([[np.mean(np.abs(x)), np.max(np.abs(x)), np.sqrt(np.mean(x * x))]
                                 for x in e])
    return result


def table(text: str, source: str, name: str, runs: int = 50) -> list[str]:
    """Markdown: per observation model, case and speed, the mean of each metric over ``runs``
    Monte-Carlo runs for both filters, the change, the paper's change and the runs improved."""
    lines = ["| z | run | signal | metric | adaptive PF | improved PF | change | paper | "
             "runs improved |", "|---|---|---|---|---|---|---|---|---|"]
    for label, observation in OBSERVATIONS:
        for case_label, case in CASES:
            per_run = [errors(seeded(text, source, name, seed, observation=observation), case, seed)
                       for seed in range(1, runs + 1)]
            base = np.mean([r[pf.ADAPTIVE] for r in per_run], axis=0)
            improved = np.mean([r[pf.IMPROVED] for r in per_run], axis=0)
            for i, signal in enumerate(("vx", "vy")):
                for j, metric in enumerate(("MAE", "max", "RMSE")):
                    wins = sum(r[pf.IMPROVED][i, j] < r[pf.ADAPTIVE][i, j] for r in per_run)
                    change = 100 * (improved[i, j] - base[i, j]) / base[i, j]
                    lines.append(f"| {label} | {case_label} | {signal} (m/s) | {metric} | "
                                 f"{base[i, j]:.4f} | {improved[i, j]:.4f} | {change:+.1f} % | "
                                 f"{PAPER[case_label][signal][j]:+.2f} % | {wins} of {runs} |")
    return lines


def float_against_double(text: str, source: str, name: str, runs: int = 50) -> list[str]:
    """Markdown: MAE of v_x and v_y of the float and the double C over ``runs`` runs of the DLC
    (D5: float builds are compared statistically; their resampling parts from the double's), with
    the standard error of the mean of the paired per-run differences."""
    case = CASES[0][1]
    lines = ["| filter | signal | double C MAE (m/s) | float C MAE (m/s) | difference | "
             "± 2 standard errors |", "|---|---|---|---|---|---|"]
    for filter_name in FILTERS:
        mae = {"double": [], "float": []}
        for seed in range(1, runs + 1):
            config = seeded(text, source, name, seed)
            log = case.simulate(config, 1.0 / config.sample_time, seed)
            for real in mae:
                est = run_estimator(config, filter_name, log, real=real)
                mae[real].append([np.mean(np.abs(est["vx"] - log["vx_ref"])),
                                  np.mean(np.abs(est["vy"] - log["vy_ref"]))])
        double, single = np.array(mae["double"]), np.array(mae["float"])
        error = 2 * np.std(single - double, axis=0, ddof=1) / np.sqrt(runs)
        for i, signal in enumerate(("vx", "vy")):
            base = double[:, i].mean()
            lines.append(f"| {filter_name} | {signal} | {base:.4f} | {single[:, i].mean():.4f} | "
                         f"{100 * (single[:, i].mean() - base) / base:+.1f} % | "
                         f"{100 * error[i] / base:.1f} % |")
    return lines


SECTION = "## Particle filters by particle count (seed 003)"
SAMPLERS = ("ziggurat", "box_muller")


def cost_section(text: str, source: str, name: str, inputs_case: Case = COSTS_CASE) -> list[str]:
    """The benchmark document's particle-filter section: :func:`costs` with its legend."""
    config = parse_vehicle(text, source, name)
    estimator = build(pf.IMPROVED, config)
    structure = estimator.structure
    fixed = len(estimator.states) - structure.count * len(structure.particle)
    return [SECTION, "",
            f"{provenance('python -m bench.seed003')} (also written by `python -m bench`): {inputs_case.label}, "
            "host instructions per step (callgrind, -O2) and per particle (per step / N); the "
            "Cortex-M4F float build's code, the caller-owned state (4 B per entry: "
            f"{len(structure.particle)} per particle and {fixed} more), the step's worst-case stack and "
            "their sum with static data as RAM. `normals`: the ziggurat (default) or the spec's "
            "Box-Muller (D5, the sampler before the ziggurat).", "",
            *costs(text, source, name, inputs_case)]


def costs(text: str, source: str, name: str, inputs_case: Case = COSTS_CASE) -> list[str]:
    """Markdown: per filter, particle count and normal sampler, instructions per step and per
    particle (double and float, host -O2) and the Cortex-M4F float build's code, state and stack;
    then the per-particle cost of Box-Muller over the ziggurat's."""
    m4f = target_for("float")
    lines = ["| filter | N | normals | instructions/step double | instructions/step float | "
             "per particle double | per particle float | M4F .text (B) | M4F state (B) | "
             "M4F stack step (B) | M4F RAM (B) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    per_particle: dict[tuple[str, int, str], list[float]] = {}
    folder = Path(tempfile.mkdtemp(prefix="vsegen-bench-pf-"))
    for filter_name in FILTERS:
        for count in COUNTS:
            for sampler in SAMPLERS:
                config = parse_vehicle(with_settings(text, f"estimator.{filter_name}", particles=count,
                                                     normals=sampler), source, name)
                estimator = build(filter_name, config)
                log = inputs_case.simulate(config, 1.0 / config.sample_time)
                inputs = log.matrix(estimator.inputs.names)
                inputs_file = write_inputs(inputs, folder)
                per_step = [generated_driver(estimator, render(config, filter_name, real), real)
                            .instructions_per_step(inputs_file, len(inputs))
                            for real in ("double", "float")]
                per_particle[filter_name, count, sampler] = [i / count for i in per_step]
                state_bytes = 4 * len(estimator.states)
                if available(m4f):
                    target = build_for_target(render(config, filter_name, "float"), filter_name, m4f)
                    memory = (f"{target.text} | {state_bytes} | {target.stack_step} | "
                              f"{state_bytes + target.stack_step + target.data + target.bss}")
                else:
                    memory = f"- | {state_bytes} | - | -"
                lines.append(f"| {filter_name} | {count} | {sampler} | {per_step[0]:,.0f} | "
                             f"{per_step[1]:,.0f} | {per_step[0] / count:,.0f} | "
                             f"{per_step[1] / count:,.0f} | {memory} |")
    lines += ["", "Box-Muller's instructions per particle over the ziggurat's:", "",
              "| filter | N | double | float |", "|---|---|---|---|"]
    for filter_name in FILTERS:
        for count in COUNTS:
            zig, box = per_particle[filter_name, count, "ziggurat"], per_particle[filter_name, count, "box_muller"]
            lines.append(f"| {filter_name} | {count} | {box[0] / zig[0]:.2f}x | {box[1] / zig[1]:.2f}x |")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="The particle filters' cost section of docs/benchmarks.md.")
    parser.add_argument("--vehicle", type=Path, default=DEFAULT_VEHICLE)
    parser.add_argument("--out", type=Path, default=BENCHMARKS)
    args = parser.parse_args(argv)
    config = load_vehicle(args.vehicle)
    body = cost_section(args.vehicle.read_text(), str(args.vehicle), config.name)
    write_section(args.out, body)


if __name__ == "__main__":
    main()
