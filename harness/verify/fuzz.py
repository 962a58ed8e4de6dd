"""Fuzzing generated C: every step under AddressSanitizer and UBSan with adversarial inputs.

The driver (``fuzz.c.j2``) checks after every step that state and outputs are finite, the
covariance is positive semi-definite and INVALID_INPUT is set exactly when an input was
implausible; any sanitizer report aborts the run.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from vsegen.codegen.generate import library_sources, render, template_environment
from vsegen.model import signals
from vsegen.model.estimators import build, monitor_only_inputs
from vsegen.model.guard import LIMIT_KEYS
from vsegen.model.params import VehicleConfig

SANITIZE = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer")


@dataclass(frozen=True)
class FuzzReport:
    steps: int
    rejected: int
    ok: bool
    message: str


def compiler() -> str:
    return shutil.which("clang") or shutil.which("gcc") or "cc"


def fuzz_source(config: VehicleConfig, name: str, real: str, params: str = "baked") -> str:
    estimator = build(name, config, params)
    names = estimator.states.names
    cov = [i for i, n in enumerate(names) if n.startswith("P_")]
    n = 0
    while n * (n + 1) // 2 < len(cov):
        n += 1
    p = f"vse_{name}"
    return template_environment(Path(__file__).parent).get_template("fuzz.c.j2").render(
        est=estimator, p=p, P=p.upper(), real=real, cov_n=n, cov_indices=cov,
        limits=[repr(config.limits[LIMIT_KEYS[s]]) for s in estimator.inputs.names],
        limits_now=[f"(double)fuzz_calibration.{LIMIT_KEYS[s]}" if LIMIT_KEYS[s] in estimator.parameters.names
                    else repr(config.limits[LIMIT_KEYS[s]]) for s in estimator.inputs.names],
        typical=[repr(signals.INPUT[s].typical) for s in estimator.inputs.names],
        decides=[0 if s in monitor_only_inputs(config, name) else 1 for s in estimator.inputs.names],
        vx_index=estimator.inputs.index("vx"),
        calibration=[repr(float(v)) for v in estimator.parameters.values])


def fuzz_estimator(config: VehicleConfig, name: str, real: str, steps: int, seed: int = 1,
                   files: dict[str, str] | None = None, params: str = "baked") -> FuzzReport:
    """Build ``name``'s generated C (or the given ``files``) with sanitizers and run ``steps``
    fuzzed steps; a calibratable build (``params``) has its calibration struct fuzzed too, so the
    generated instance of it is left out."""
    files = files or render(config, name, real, params)
    if params == "calibratable":
        files = {file: text for file, text in files.items() if file != f"vse_{name}_calibration.c"}
    with tempfile.TemporaryDirectory(prefix="vsegen-fuzz-") as tmp:
        folder = Path(tmp)
        for file, text in files.items():
            (folder / file).write_text(text)
        (folder / "fuzz.c").write_text(fuzz_source(config, name, real, params))
        build_result = subprocess.run(
            [compiler(), "-std=c99", "-O1", "-g", *SANITIZE, "-o", "fuzz", "fuzz.c",
             *library_sources(files), "-lm"], cwd=folder, capture_output=True, text=True)
        if build_result.returncode != 0:
            return FuzzReport(0, 0, False, "build failed: " + build_result.stderr.strip()[:500])
        run = subprocess.run(["./fuzz", str(steps), str(seed)], cwd=folder, capture_output=True,
                             text=True)
    words = run.stdout.split()
    if run.returncode == 0 and words[:1] == ["OK"]:
        return FuzzReport(int(words[1]), int(words[2]), True, "")
    return FuzzReport(steps, 0, False, (run.stdout + run.stderr).strip()[:800])
