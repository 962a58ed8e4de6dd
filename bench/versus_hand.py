"""The generated 2-DOF KF step against its hand-written twin (``bench/handwritten/kf2dof_hand.c``):
instructions per step (callgrind, -O2) and their ratio, with the ZOH and the forward-Euler
discretisation (target: generated <= 1.10 x hand-written), and the generated step's Cortex-M4F
float code and stack. ``python -m bench.versus_hand`` writes
this section of docs/benchmarks.md; ``python -m bench`` all of it.
"""

from __future__ import annotations

from pathlib import Path

from bench.measure import LOG_CASE, generated_driver, hand_driver, section_command, switched_off, write_inputs
from vsegen.codegen.generate import render
from vsegen.harness.logs.table import Log
from vsegen.harness.target.toolchains import available, build_for_target, target_for
from vsegen.model import input_monitors
from vsegen.model.estimators import build

SECTION = "## Generated against hand-written (2-DOF KF step, double, -O2)"
TARGET_RATIO = 1.10


def section(vehicle: Path, log: Log, folder: Path) -> list[str]:
    """Markdown lines of the section, measured on ``log``."""
    lines = [SECTION, "",
             "`bench/handwritten/kf2dof_hand.c`: the same estimator written by hand (constants "
             "derived once, 1/vx once, P as three entries, closed-form 2x2 inverse with one "
             "division, no pointer checks); tested equal to the reference. The generated kf2dof "
             "here has the monitors of the shipped file off (residual_window = 0, linear_range "
             "= 0, the input monitors' limits 0), as the hand-written one has none, and its "
             "constant process noise (process_noise_load = 0). "
             f"Log: {LOG_CASE.label}, {len(log)} steps. "
             "Cortex-M4F: arm-none-eabi-gcc -O2, linked to the API (`vsegen size`'s build); the "
             "ZOH's series is unrolled (its terms and squarings: the Makefile's zoh_series note), "
             "the hand-written twin loops over them.", "",
             "| discretisation | generated instr/step | hand-written instr/step | ratio | target "
             "| generated ns | hand-written ns | generated M4F float .text / step stack (B) |",
             "|---|---|---|---|---|---|---|---|"]
    for method in ("zoh", "euler"):
        variant, _ = switched_off(vehicle, "kf2dof", input_monitors.OFF, residual_window=0.0, linear_range=0.0,
                                  process_noise_load=0.0, discretisation=method)
        estimator = build("kf2dof", variant)
        inputs = log.matrix(estimator.inputs.names)
        inputs_file = write_inputs(inputs, folder)
        generated = generated_driver(estimator, render(variant, "kf2dof", "double"), "double")
        hand = hand_driver(variant, estimator.inputs)
        g = generated.instructions_per_step(inputs_file, len(inputs))
        h = hand.instructions_per_step(inputs_file, len(inputs))
        m4f = _m4f_size(variant)
        lines.append(f"| {method} | {g:.1f} | {h:.1f} | {g / h:.3f} | <= {TARGET_RATIO} "
                     f"{'met' if g / h <= TARGET_RATIO else 'MISSED'} | "
                     f"{generated.ns_per_step(inputs_file):.1f} | {hand.ns_per_step(inputs_file):.1f} | "
                     f"{m4f} |")
    return lines


def _m4f_size(config) -> str:
    """The float kf2dof of ``config`` cross-built for the Cortex-M4F (``vsegen size``'s build):
    linked .text and the step's worst-case stack, or '-' without the cross compiler."""
    target = target_for("float")
    if not available(target):
        return "-"
    report = build_for_target(render(config, "kf2dof", "float"), "kf2dof", target)
    return f"{report.text:,} / {report.stack_step}"


def main(argv: list[str] | None = None) -> None:
    section_command(__doc__.splitlines()[0], section, "vsegen-bench-hand-", argv)


if __name__ == "__main__":
    main()
