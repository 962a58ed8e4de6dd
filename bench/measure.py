"""Measuring one step: callgrind instructions, wall time, host code size.

Drivers are compiled from ``driver.c.j2`` around either a generated estimator (its public API) or
the hand-written baseline; each runs init once and then step over a log's inputs.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsegen.codegen.generate import template_environment
from vsegen.harness.host.build import library_files
from vsegen.harness.logs.table import Log
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.target.toolchains import link_to_api
from vsegen.model.bicycle import state_matrix_norm_bound
from vsegen.model.discretize import plan_zoh
from vsegen.model.estimator import Estimator
from vsegen.model.params import VehicleConfig, parse_vehicle

LOG_CASE = Case.of("continuous_dlc")
"""The log every instruction count runs on."""
HERE = Path(__file__).parent
CC = "gcc"
FLAGS = ("-std=c99", "-O2")
HAND_SOURCES = ("kf2dof_hand.c",)


@dataclass
class Driver:
    """A compiled benchmark driver in a kept temporary folder."""

    folder: tempfile.TemporaryDirectory
    exe: Path
    step_function: str
    text_bytes: int

    def instructions_per_step(self, inputs_file: Path, steps: int) -> float:
        """Callgrind: instructions executed inside the step function (inclusive), per step."""
        out = Path(self.folder.name) / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        f"--toggle-collect={self.step_function}", str(self.exe), str(inputs_file),
                        "count"], check=True, capture_output=True)
        totals = re.search(r"^(?:summary|totals): (\d+)", out.read_text(), flags=re.M)
        return int(totals.group(1)) / steps

    def ns_per_step(self, inputs_file: Path, passes: int = 51) -> float:
        """Median wall time per step over ``passes`` passes of the log (noisy on shared machines)."""
        result = subprocess.run([str(self.exe), str(inputs_file), "time", str(passes)], check=True,
                                capture_output=True, text=True)
        return float(result.stdout.split()[0])


def switched_off(vehicle: Path, name: str, off: Mapping[str, float], **also: float) -> tuple[VehicleConfig, dict]:
    """(the vehicle file ``vehicle`` with estimator ``name``'s settings of ``off`` that are on set
    to their off value, and ``also`` set; which of ``off`` were on)."""
    config = load_vehicle(vehicle)
    settings = config.settings(name)
    on = {key: value for key, value in off.items() if key in settings and settings[key] != value}
    text = with_settings(vehicle.read_text(), f"estimator.{name}", **on, **also)
    return parse_vehicle(text, str(vehicle), config.name), on


def section_command(description: str, section: Callable[[Path, Log, Path], list[str]], prefix: str,
                    argv: list[str] | None = None) -> None:
    """The command line of a benchmarks.md section measured on LOG_CASE: parse ``--vehicle`` and
    ``--out``, then write ``section(vehicle, log, scratch folder)``."""
    from bench import BENCHMARKS, DEFAULT_VEHICLE
    from bench.document import write_section

    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--vehicle", type=Path, default=DEFAULT_VEHICLE)
    parser.add_argument("--out", type=Path, default=BENCHMARKS)
    args = parser.parse_args(argv)
    config = load_vehicle(args.vehicle)
    log = LOG_CASE.simulate(config, 1.0 / config.sample_time)
    write_section(args.out, section(args.vehicle, log, Path(tempfile.mkdtemp(prefix=prefix))))


def write_inputs(inputs: np.ndarray, folder: Path) -> Path:
    path = folder / "inputs.bin"
    np.ascontiguousarray(inputs, dtype=np.float64).tofile(path)
    return path


def generated_driver(estimator: Estimator, files: dict[str, str], real: str) -> Driver:
    p = f"vse_{estimator.name}"
    set_inputs = "\n".join(f"            in.{s.name} = ({p}_real)u[{i}];"
                           for i, s in enumerate(estimator.inputs.signals))
    code = {
        "includes": f'#include "{p}.h"',
        "declarations": f"    {p}_state state;\n    {p}_input in;\n    {p}_output out;",
        "init": "        {\n            const double *u = inputs;\n" + set_inputs +
                f"\n            {p}_init(&state, &in);\n        }}",
        "step": set_inputs + f"\n            {p}_step(&state, &in, &out);\n"
                             f"            checksum += (double)out.{estimator.outputs.signals[0].name};",
    }
    return _compile(code, estimator.inputs, library_files(files), f"{p}_step",
                    api=(f"{p}_init", f"{p}_step"))


def hand_raw_parameters(config: VehicleConfig) -> list[float]:
    """The hand-written baseline's parameter vector for ``config``: the generated code's ZOH plan,
    or no series terms and no squarings (Phi = I + A T, Gamma = B T) for forward Euler."""
    v, s, lim = config.vehicle, config.settings("kf2dof"), config.limits
    if s["discretisation"] not in ("zoh", "euler"):
        raise ValueError("the hand-written baseline implements the zoh and euler discretisations")
    plan = plan_zoh(state_matrix_norm_bound(v, s["vx_min"], lim["vx_max"]), config.sample_time)
    terms, squarings = (plan.terms, plan.squarings) if s["discretisation"] == "zoh" else (0, 0)
    q, r, p0 = s["process_noise"], s["measurement_noise"], s["initial_covariance"]
    return [v["mass"], v["yaw_inertia"], v["cg_to_front_axle"], v["cg_to_rear_axle"],
            v["cornering_stiffness_front"], v["cornering_stiffness_rear"],
            q[0][0], q[0][1], q[1][1], r[0][0], r[0][1], r[1][1], p0[0][0], p0[0][1], p0[1][1],
            s["vx_min"], s["vx_resume"], lim["vx_max"], lim["delta_max"], lim["ay_max"],
            lim["r_max"], config.sample_time, terms, squarings]


def hand_driver(config: VehicleConfig, inputs_layout) -> Driver:
    raw = ", ".join(repr(float(x)) for x in hand_raw_parameters(config))
    code = {
        "includes": '#include "kf2dof_hand.h"',
        "declarations": f"    static const double raw[24] = {{{raw}}};\n    kf2dof_hand_params params;\n"
                        "    kf2dof_hand_state state;\n    double y[4];\n"
                        "    kf2dof_hand_setup(&params, raw);",
        "init": "        kf2dof_hand_init(&state, &params, inputs);",
        "step": "            kf2dof_hand_step(&state, &params, u, y);\n            checksum += y[0];",
    }
    files = {n: (HERE / "handwritten" / n).read_text() for n in (*HAND_SOURCES, "kf2dof_hand.h")}
    return _compile(code, inputs_layout, files, "kf2dof_hand_step",
                    api=("kf2dof_hand_init", "kf2dof_hand_step"))


def _compile(code: dict[str, str], inputs_layout, files: dict[str, str], step: str,
             api: tuple[str, ...]) -> Driver:
    driver = template_environment(HERE).get_template("driver.c.j2").render(n_inputs=len(inputs_layout),
                                                    fn_step=step, **code)
    folder = tempfile.TemporaryDirectory(prefix="vsegen-bench-")
    root = Path(folder.name)
    for name, text in {**files, "driver.c": driver}.items():
        (root / name).write_text(text)
    library = sorted(n for n in files if n.endswith(".c"))
    subprocess.run([CC, *FLAGS, "-o", "driver", "driver.c", *library, "-lm"], cwd=root, check=True,
                   capture_output=True)
    return Driver(folder, root / "driver", step, _text_size(root, library, api))


def _text_size(root: Path, sources: list[str], api: tuple[str, ...]) -> int:
    """Host .text of the library linked with --gc-sections to its API (x86-64, -O2)."""
    subprocess.run([CC, *FLAGS, "-ffunction-sections", "-fdata-sections", "-c", *sources], cwd=root,
                   check=True, capture_output=True)
    return link_to_api(root, [s[:-2] + ".o" for s in sources], api, CC)[0]
