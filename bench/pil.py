"""python -m bench.pil: every estimator of a vehicle file under processor-in-the-loop on both
emulated targets (Cortex-M4F float on QEMU mps2-an386, Cortex-M7 double on mps2-an500; baked
parameters; the verification scenarios, seed 1). Writes the "Processor in the loop" section of
docs/benchmarks.md (instructions per step, CPU load at the sample rate, painted and static stack,
agreement with the host build and the reference) and prints it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bench import BENCHMARKS, DEFAULT_VEHICLE
from bench.document import provenance, write_section
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.target import emulator as pil

SECTION = "## Processor in the loop (QEMU)"


def host_agreement(results: list[pil.PilResult]) -> str:
    """How the target runs compare with the host build of the same precision."""
    identical = sum(r.host.identical for r in results)
    if identical == len(results):
        return "bit-identical"
    worst = max(r.host.steps.max_rel for r in results if not r.host.identical)
    flips = sum(r.host.resampling for r in results)
    return (f"{identical}/{len(results)} bit-identical; steps within {worst:.1e}"
            + (f"; {flips} resampling choices differ" if flips else ""))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicle", type=Path, default=DEFAULT_VEHICLE)
    parser.add_argument("--out", type=Path, default=BENCHMARKS)
    args = parser.parse_args(argv)
    missing = pil.available()
    if missing:
        raise SystemExit(f"bench.pil: {missing}")
    config = load_vehicle(args.vehicle)
    names = tuple(config.estimators)
    rate = 1.0 / config.sample_time
    body = [SECTION, "",
            f"{provenance('python -m bench.pil')}: vehicle {config.name}, {rate:g} Hz, baked parameters, every "
            "estimator on every verification scenario (seed 1), built with arm-none-eabi-gcc -O2 -std=c99 "
            "-ffp-contract=off and run under QEMU with `-icount shift=0` (one instruction = 1 ns of guest time; "
            "SysTick ticks inside `step`, converted with a loop of known length). Load = instructions per step "
            "x rate / clock, taking one instruction as one cycle: an estimate (no flash wait states, caches or "
            "FPU latencies). Stack: painted (what init / step wrote below main's stack pointer, library calls "
            "included) and static (gcc -fstack-usage, worst call path, library frames unknown).", "",
            "| estimator | target | real | instructions/step | worst scenario | CPU load | stack init / step "
            "(painted) | static | vs host build | vs reference |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for board in pil.BOARDS.values():
        results = pil.pil(config, names, board.name, "baked")
        for name in names:
            runs = [r for r in results if r.reference.estimator == name]
            c = pil.cost(config, name, board, "baked", results)
            verdict = "ok" if all(r.reference.ok for r in runs) else "FAILED"
            body.append(f"| {name} | {board.target.name} ({board.machine}) | {board.real} | "
                        f"{c.instructions_mean:,.0f} | {c.instructions_max:,.0f} | "
                        f"{100 * c.load:.2f} % of {board.clock_hz / 1e6:g} MHz | {c.stack_init} / {c.stack_step} | "
                        f"{c.static_stack_init} / {c.static_stack_step} | {host_agreement(runs)} | "
                        f"{verdict} ({len(runs)} scenarios) |")
    write_section(args.out, body)


if __name__ == "__main__":
    main()
