"""Code coverage: which statements and branches of the generated C the verification scenarios run.

The kit's library sources, as ``codegen.render`` generates them, are compiled with gcc
``--coverage -O0`` beside the harness runner into a folder of their own, run over the scenarios'
inputs (ctypes), and the counters are dumped (``__gcov_dump``: the command line leaves without
the process's exit handlers) and read by gcovr. A file is *kernel* code (CasADi's straight-line
output) or *template* code (vsegen's API, calibration and checks).
"""

from __future__ import annotations

import ctypes
import json
import shutil
import subprocess
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsegen.codegen.generate import render
from vsegen.harness.host.build import CEstimator, compiler, library_files, runner_source
from vsegen.model.calibration_checks import Bound, Relation, StateMatrixNorm, calibration_checks, dynamics_checks
from vsegen.model.estimators import SCHEMAS, build
from vsegen.model.params import VehicleConfig

DUMP = """
/* Coverage builds only: write the gcov counters now. */
extern void __gcov_dump(void);
void vse_coverage_dump(void)
{
    __gcov_dump();
}
"""
FLAGS = ("-std=c99", "-O0", "--coverage", "-fPIC", "-shared")
RUNNER = "vse_harness_runner.c"


PROBE_SAMPLES = 5
"""Samples run with each broken calibration."""


def broken_calibrations(config: VehicleConfig, name: str, names: tuple[str, ...],
                        generated: np.ndarray) -> list[np.ndarray]:
    """One calibration per check the generated C makes on it and entry that check reads, that entry
    NaN (a NaN fails every comparison it enters); for the state-matrix norm check also an
    oversteering car, C_r = a C_f / (2 b) (not broken: the other sign of its coupling term), and a
    yaw inertia a thousand times too small (its yaw row alone beyond the limit)."""
    checks = (*calibration_checks(SCHEMAS[name], names), *dynamics_checks(SCHEMAS[name], names, tuple(generated)))
    broken = []
    for entry in sorted({entry for check in checks for entry in _entries_read(check)}):
        values = generated.copy()
        values[entry] = np.nan
        broken.append(values)
    for check in checks:
        if isinstance(check, StateMatrixNorm):     # an oversteering car: the other sign of |b C_r - a C_f|
            values = generated.copy()
            at = check.index
            values[at["cornering_stiffness_rear"]] = 0.5 * generated[at["cornering_stiffness_front"]] * \
                generated[at["cg_to_front_axle"]] / generated[at["cg_to_rear_axle"]]
            broken.append(values)
            light = generated.copy()               # the yaw row alone beyond the limit
            light[at["yaw_inertia"]] *= 1e-3
            broken.append(light)
    return broken


def _entries_read(check) -> set[int]:
    if isinstance(check, Bound):
        return {check.index}
    if isinstance(check, Relation):
        return {check.left, check.right}
    if isinstance(check, StateMatrixNorm):
        return set(check.index.values())
    return {i for row in check.indices for i in row}


@dataclass(frozen=True)
class FileCoverage:
    """Statements (lines with code) and branches of one generated file, and those never run."""

    file: str
    kind: str
    """"kernel" (CasADi's output) or "template" (vsegen's)."""
    lines: int
    lines_run: int
    branches: int
    branches_taken: int
    lines_never: tuple[int, ...]
    """Line numbers of statements never run."""
    branches_never: tuple[int, ...]
    """Line numbers with a branch never taken."""


def measure(config: VehicleConfig, name: str, real: str, params: str, inputs: Iterable[np.ndarray],
            folder: Path) -> list[FileCoverage]:
    """The coverage of ``name``'s generated C in form (``real``, ``params``) over the input rows of
    each run of ``inputs``, measured in ``folder`` (emptied first). A calibratable form also runs
    the first rows of the first run once per calibration of :func:`broken_calibrations` (every
    check's failing branch and every operand of a composite check, the API's calibration check,
    and the step's hold on a broken calibration)."""
    estimator = build(name, config, params)
    calibratable = estimator.parameters.calibratable
    files = library_files({f: t for f, t in render(config, name, real, params).items()
                           if not (calibratable and f == f"vse_{name}_calibration.c")})
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    for file, text in {**files, RUNNER: runner_source(estimator, calibratable) + DUMP}.items():
        (folder / file).write_text(text)
    sources = sorted(f for f in files if f.endswith(".c")) + [RUNNER]
    subprocess.run([compiler(), *FLAGS, "-o", "libcoverage.so", *sources, "-lm"], cwd=folder, check=True,
                   capture_output=True)
    library = ctypes.CDLL(str(folder / "libcoverage.so"))
    library.vse_harness_run.restype = None
    runner = CEstimator(estimator, library)
    runs = list(inputs)
    generated = np.array(estimator.parameters.values, dtype=float)
    if calibratable:
        runner.set_calibration(generated)
    for rows in runs:
        runner.run(rows)
    for broken in broken_calibrations(config, name, estimator.parameters.names, generated) if calibratable else ():
        runner.set_calibration(broken)
        runner.calibration_check()
        runner.run(runs[0][:PROBE_SAMPLES])
    library.vse_coverage_dump()
    report = folder / "coverage.json"
    subprocess.run([sys.executable, "-m", "gcovr", "--root", str(folder), "--json", str(report),
                    "--exclude", f".*{RUNNER}"], cwd=folder, check=True, capture_output=True)
    return [_file(entry) for entry in json.loads(report.read_text())["files"]]


def _file(entry: dict) -> FileCoverage:
    lines = [line for line in entry["lines"] if not line.get("gcovr/noncode")]
    branches = [(line["line_number"], branch["count"]) for line in lines for branch in line.get("branches", [])]
    name = Path(entry["file"]).name
    return FileCoverage(
        name, "kernel" if name.endswith(("_kernel.c", "_kernel.h")) else "template", len(lines),
        sum(1 for line in lines if line["count"] > 0), len(branches), sum(1 for _, n in branches if n > 0),
        tuple(line["line_number"] for line in lines if line["count"] == 0),
        tuple(sorted({number for number, n in branches if n == 0})))
