"""python -m bench: the benchmark suite. Writes docs/benchmarks.md and prints it.

Per estimator and precision: instructions per step (callgrind, the step function inclusive),
median ns per step, host .text; the hand-written baseline of the 2-DOF KF step and the ratio of
generated to hand-written instructions (target <= 1.10, with the default ZOH discretisation and
with forward Euler, where the discretisation weighs less); the NumPy reference and a CasADi
Function called from Python per step for contrast; the Cortex-M4F size and stack; a longer fuzz run
of every generated step under AddressSanitizer and UBSan. Timing is noisy on shared machines;
instruction counts are repeatable.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import BENCHMARKS, DEFAULT_VEHICLE, campaign, feedback, options_cost, pil, seed003, versus_hand
from bench.document import provenance, section_of, with_section
from bench.measure import CC, FLAGS, LOG_CASE, generated_driver, write_inputs
from vsegen.codegen.generate import render
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.reference import REFERENCES
from vsegen.harness.target.toolchains import available, build_for_target, target_for
from vsegen.harness.verify.fuzz import fuzz_estimator
from vsegen.model.estimator import Particles
from vsegen.model.estimators import build


def _machine() -> str:
    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    compiler = subprocess.run([CC, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    return f"{model}, {platform.system()} {platform.machine()}; {compiler}; flags {' '.join(FLAGS)}"


def _python_step_us(step, state, inputs: np.ndarray, samples: int = 300) -> float:
    times = []
    for row in inputs[:samples]:
        start = time.perf_counter()
        state = step(state, row)
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e6


KEPT_SECTIONS = (feedback.SECTION, pil.SECTION, campaign.STREAMING_SECTION, campaign.CAMPAIGN_SECTION)
"""The sections of docs/benchmarks.md that other commands write: kept when the suite rewrites the rest."""


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="vsegen benchmark suite")
    parser.add_argument("--vehicle", type=Path, default=DEFAULT_VEHICLE)
    parser.add_argument("--fuzz-steps", type=int, default=10_000_000)
    parser.add_argument("--out", type=Path, default=BENCHMARKS)
    args = parser.parse_args(argv)
    config = load_vehicle(args.vehicle)
    log = LOG_CASE.simulate(config, 1.0 / config.sample_time)
    folder = Path(tempfile.mkdtemp(prefix="vsegen-bench-"))
    lines = [f"# Benchmarks (vehicle {config.name})", "",
             f"{provenance(f'python -m bench --fuzz-steps {args.fuzz_steps}')}. Machine: {_machine()}. "
             f"Log: {LOG_CASE.label}, "
             f"{len(log)} steps. Instructions: `valgrind --tool=callgrind`, inclusive cost of the "
             "step function per step (repeatable); ns: median over 51 passes (noisy on shared "
             "machines).", ""]

    lines += ["## Generated C", "",
              "| estimator | real | instructions/step | ns/step | host .text (B) | M4F .text (B) "
              "| M4F stack step (B) |",
              "|---|---|---|---|---|---|---|"]
    for name in config.estimators:
        estimator = build(name, config)
        inputs = log.matrix(estimator.inputs.names)
        inputs_file = write_inputs(inputs, folder)
        for real in ("double", "float"):
            driver = generated_driver(estimator, render(config, name, real), real)
            m4f = target_for("float")
            target = (build_for_target(render(config, name, "float"), name, m4f)
                      if real == "float" and available(m4f) else None)
            lines.append(f"| {name} | {real} | {driver.instructions_per_step(inputs_file, len(inputs)):.1f} | "
                         f"{driver.ns_per_step(inputs_file):.1f} | {driver.text_bytes} | "
                         f"{target.text if target else '-'} | {target.stack_step if target else '-'} |")

    lines += ["", *options_cost.section(args.vehicle, log, folder), ""]
    lines += ["", *versus_hand.section(args.vehicle, log, folder), ""]

    if any(isinstance(build(name, config).structure, Particles) for name in config.estimators):
        lines += ["", *seed003.cost_section(args.vehicle.read_text(), str(args.vehicle), config.name)]

    lines += ["", "## Python, per step (for contrast)", "",
              "| estimator | NumPy reference (µs) | CasADi Function from Python (µs) |",
              "|---|---|---|"]
    for name in config.estimators:
        estimator = build(name, config)
        reference = REFERENCES[name]
        inputs = log.matrix(estimator.inputs.names)
        ref_us = _python_step_us(lambda s, u, reference=reference: reference.step(config, s, u)[0],
                                 reference.init(config, inputs[0]), inputs)
        if estimator.step is None:      # a particle filter has no composed CasADi step
            lines.append(f"| {name} | {ref_us:.1f} | - |")
            continue
        cas_us = _python_step_us(lambda s, u, estimator=estimator: estimator.step(s, u)[0],
                                 np.array(estimator.init(inputs[0])).ravel(), inputs)
        lines.append(f"| {name} | {ref_us:.1f} | {cas_us:.1f} |")

    lines += ["", f"## Fuzzing ({args.fuzz_steps:,} steps per estimator and precision, ASan + UBSan)", "",
              "| estimator | form | steps | rejected inputs | result |", "|---|---|---|---|---|"]
    forms = [(name, real, "baked") for name in config.estimators for real in ("double", "float")]
    forms += [(name, real, params) for name, real, params in config.codegen["forms"] if params == "calibratable"]
    for name, real, params in forms:
        report = fuzz_estimator(config, name, real, steps=args.fuzz_steps, seed=2, params=params)
        form = real if params == "baked" else f"{real}, calibration fuzzed too"
        lines.append(f"| {name} | {form} | {report.steps:,} | {report.rejected:,} | "
                     f"{'clean' if report.ok else 'FAILED: ' + report.message} |")
    lines.append("")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    text = "\n".join(lines)
    previous = args.out.read_text() if args.out.exists() else ""
    for heading in KEPT_SECTIONS:
        kept = section_of(previous, heading)
        text = with_section(text, kept) if kept else text
    args.out.write_text(text)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
