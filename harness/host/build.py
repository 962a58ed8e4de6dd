"""Compiling generated C into a shared library and calling it from Python (ctypes).

Libraries are cached under the build cache, keyed by the SHA-256 of every source, the compiler
and the flags, so an unchanged estimator is compiled once.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsegen.codegen.generate import library_sources, render, template_environment
from vsegen.harness.project.paths import cache_dir
from vsegen.model.estimator import Estimator
from vsegen.model.estimators import build
from vsegen.model.params import VehicleConfig

WARNING_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror")
"""The generated code must compile cleanly with these (docs/integration.md)."""
LIBRARY_FLAGS = ("-O2", "-fPIC", "-shared")


class BuildError(RuntimeError):
    """The compiler rejected generated code (a bug in vsegen, not a user error)."""


def compiler() -> str:
    """The C compiler: $CC, else gcc, else cc."""
    return os.environ.get("CC") or shutil.which("gcc") or "cc"


def runner_source(estimator: Estimator, writable_calibration: bool = False) -> str:
    """The harness driver C for ``estimator`` (with a writable calibration for tuning builds)."""
    prefix = f"vse_{estimator.name}"
    template = template_environment(Path(__file__).parent).get_template("runner.c.j2")
    return template.render(est=estimator, p=prefix, P=prefix.upper(), writable_calibration=writable_calibration)


def build_library(files: dict[str, str], extra_sources: dict[str, str], cc: str | None = None,
                  flags: tuple[str, ...] = ()) -> Path:
    """Compile the library sources of ``files`` and ``extra_sources`` into a cached shared library."""
    return compile_cached({**library_files(files), **extra_sources}, cc or compiler(),
                          (*WARNING_FLAGS, *LIBRARY_FLAGS, *flags), "lib", ".so")


def library_files(files: dict[str, str]) -> dict[str, str]:
    """The library sources and every header of a generated folder's ``files``."""
    return {**{name: files[name] for name in library_sources(files)},
            **{name: text for name, text in files.items() if name.endswith(".h")}}


def compile_cached(sources: dict[str, str], cc: str, flags: tuple[str, ...], kind: str, suffix: str) -> Path:
    """Every .c of ``sources`` (file name -> text; headers beside them) compiled and linked with
    ``cc`` and ``flags`` (and libm) into the build cache, ``cache_dir()/kind/<digest><suffix>``,
    keyed by the SHA-256 of every source, the compiler and the flags: an unchanged build is
    compiled once. BuildError with the compiler's messages if it fails."""
    digest = hashlib.sha256()
    for name in sorted(sources):
        digest.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
    digest.update(" ".join((cc, *flags)).encode())
    target = cache_dir() / kind / f"{digest.hexdigest()[:24]}{suffix}"
    if target.exists():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="vsegen-build-") as tmp:
        for name, text in sources.items():
            (Path(tmp) / name).write_text(text)
        out = Path(tmp) / f"out{suffix}"
        result = subprocess.run([cc, *flags, "-o", str(out), *sorted(n for n in sources if n.endswith(".c")), "-lm"],
                                cwd=tmp, capture_output=True, text=True)
        if result.returncode != 0:
            raise BuildError(f"{cc} failed on generated code:\n{result.stderr}")
        shutil.move(str(out), str(target))
    return target


@dataclass
class CEstimator:
    """A compiled estimator, driven through the harness runner."""

    estimator: Estimator
    library: ctypes.CDLL

    def run(self, inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(outputs n x ny, states (n+1) x nx) for the input rows ``inputs`` (n x nu)."""
        inputs = np.ascontiguousarray(inputs, dtype=np.float64)
        n = inputs.shape[0]
        outputs = np.zeros((n, len(self.estimator.outputs)))
        states = np.zeros((n + 1, len(self.estimator.states)))
        self.library.vse_harness_run(ctypes.c_int(n), _ptr(inputs), _ptr(outputs), _ptr(states))
        return outputs, states

    def run_chunk(self, inputs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(outputs n x ny, state after the last row) for the input rows ``inputs`` (n x nu), from
        ``state`` (None: initialised from the first row): a long log runs chunk by chunk with the
        state carried, its outputs bit-identical to :meth:`run`'s."""
        inputs = np.ascontiguousarray(inputs, dtype=np.float64)
        outputs = np.zeros((inputs.shape[0], len(self.estimator.outputs)))
        carried = np.zeros(len(self.estimator.states)) if state is None else np.array(state, dtype=np.float64)
        self.library.vse_harness_run_chunk(ctypes.c_int(inputs.shape[0]), _ptr(inputs), _ptr(outputs),
                                           _ptr(carried), ctypes.c_int(state is None))
        return outputs, carried

    def set_calibration(self, values) -> None:
        """Write the calibration (one value per ``estimator.parameters.names``; tuning builds only)."""
        values = np.ascontiguousarray(values, dtype=np.float64)
        if values.shape != (len(self.estimator.parameters.names),):
            raise ValueError(f"{len(values)} calibration values: expected {len(self.estimator.parameters.names)}")
        self.library.vse_harness_set_calibration(_ptr(values))

    def calibration_check(self) -> int:
        """The generated ``<name>_calibration_check()``: 0, or the number of the first schema check
        the calibration breaks (tuning builds only)."""
        return int(self.library.vse_harness_calibration_check())

    def step(self, state: np.ndarray, inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(state_next, output) of one step from ``state``."""
        state = np.ascontiguousarray(state, dtype=np.float64)
        inputs = np.ascontiguousarray(inputs, dtype=np.float64)
        state_out = np.zeros(len(self.estimator.states))
        output = np.zeros(len(self.estimator.outputs))
        self.library.vse_harness_step(_ptr(state), _ptr(inputs), _ptr(state_out), _ptr(output))
        return state_out, output


def _ptr(array: np.ndarray):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def compile_estimator(config: VehicleConfig, name: str, real: str = "double",
                      params: str = "baked") -> tuple[Estimator, CEstimator]:
    """(symbolic estimator, its generated C compiled and loaded) of ``name`` for ``config``."""
    estimator = build(name, config, params)
    return estimator, load_estimator(estimator, render(config, name, real, params))


def load_estimator(estimator: Estimator, files: dict[str, str]) -> CEstimator:
    """Compile ``files`` (a generated folder's content) with the runner and load it."""
    library_path = build_library(files, {"vse_harness_runner.c": runner_source(estimator)})
    library = ctypes.CDLL(str(library_path))
    library.vse_harness_run.restype = None
    library.vse_harness_run_chunk.restype = None
    library.vse_harness_step.restype = None
    return CEstimator(estimator, library)


def load_tuning_estimator(config: VehicleConfig, name: str) -> CEstimator:
    """``name``'s calibratable double C for ``config``, compiled with a writable calibration
    (:meth:`CEstimator.set_calibration`) instead of the generated const one: one build serves every
    value of the numeric settings."""
    estimator = build(name, config, "calibratable")
    files = render(config, name, "double", "calibratable")
    files = {file: text for file, text in files.items() if file != f"vse_{name}_calibration.c"}
    library_path = build_library(files, {"vse_harness_runner.c": runner_source(estimator, True)})
    library = ctypes.CDLL(str(library_path))
    library.vse_harness_run.restype = None
    library.vse_harness_set_calibration.restype = None
    return CEstimator(estimator, library)
