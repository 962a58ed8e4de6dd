"""python -m bench.options_cost: what the real-road options of the shipped vehicle file cost
(docs/robustness.md): instructions per step of each sideslip estimator that has them, as shipped
and with them off, in the section "What the real-road options cost" of docs/benchmarks.md (also
written by ``python -m bench``).

The options: the input monitors (frozen-signal monitor and cross-checks, model.input_monitors),
the learned kinematic offset (model.estimators.kinematic_offset), switching's bounded kinematic
dwell and fusion's disagreement check; each is one setting away from the papers' estimator. Also
what the saturating tyre model costs in each estimator with a 2-DOF Kalman filter.
"""

from __future__ import annotations

from pathlib import Path

from bench.document import provenance
from bench.measure import LOG_CASE, generated_driver, section_command, switched_off, write_inputs
from vsegen.codegen.generate import render
from vsegen.harness.logs.table import Log
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.model import input_monitors
from vsegen.model.estimators import build

SECTION = "## What the real-road options cost"
OPTIONS_OFF = {**input_monitors.OFF, "offset_memory": 0.0, "kinematic_max_dwell": 0.0, "disagreement_limit": 0.0,
               "process_noise_load": 0.0}
"""Every real-road option at its off value (an estimator has some of them)."""


def section(vehicle: Path, log: Log, folder: Path) -> list[str]:
    """Markdown lines of the section, measured on ``log``."""
    config = load_vehicle(vehicle)
    lines = [SECTION, "",
             f"{provenance('python -m bench.options_cost')} (also written by `python -m bench`): "
             "instructions per step (callgrind, double, -O2) of each estimator with real-road options, "
             f"as shipped and with those options off (their settings 0). Log: {LOG_CASE.label}, "
             f"{len(log)} steps.", "",
             "| estimator | options on in the shipped file | shipped | options off | cost |",
             "|---|---|---|---|---|"]
    for name in config.estimators:
        variant, on = switched_off(vehicle, name, OPTIONS_OFF)
        if not on:
            continue
        shipped, off = (instructions_per_step(name, which, log, folder) for which in (config, variant))
        lines.append(f"| {name} | {', '.join(on)} | {shipped:.1f} | {off:.1f} | "
                     f"+{shipped - off:.0f} ({100 * (shipped / off - 1):.1f} %) |")
    return lines + ["", *_tyre_model_rows(config, log, folder)]


def instructions_per_step(name: str, config, log: Log, folder: Path) -> float:
    """Instructions per step (callgrind, double, -O2) of ``name``'s generated C for ``config`` on ``log``."""
    estimator = build(name, config)
    inputs = log.matrix(estimator.inputs.names)
    driver = generated_driver(estimator, render(config, name, "double"), "double")
    return driver.instructions_per_step(write_inputs(inputs, folder), len(inputs))


def _tyre_model_rows(config, log: Log, folder: Path) -> list[str]:
    """The saturating tyre model (an extended KF, model.tyres) against the linear KF, each
    estimator with a 2-DOF KF in both, its other settings as shipped."""
    lines = ["The saturating tyre model (`tyre_model = \"saturating\"`) against the linear tyres, same "
             "log and options (column 'shipped': the model the shipped file gives the estimator):", "",
             "| estimator | shipped | linear | saturating | cost |", "|---|---|---|---|---|"]
    for name in (n for n in config.estimators if "tyre_model" in config.settings(n)):
        linear, saturating = (instructions_per_step(name, config.with_settings(name, tyre_model=model), log, folder)
                              for model in ("linear", "saturating"))
        lines.append(f"| {name} | {config.settings(name)['tyre_model']} | {linear:.1f} | {saturating:.1f} | "
                     f"+{saturating - linear:.0f} ({100 * (saturating / linear - 1):.0f} %) |")
    return lines


def main(argv: list[str] | None = None) -> None:
    section_command(__doc__.splitlines()[0], section, "vsegen-bench-", argv)


if __name__ == "__main__":
    main()
