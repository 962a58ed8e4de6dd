"""Processor-in-the-loop: the generated C built for a Cortex-M and run under QEMU.

Each estimator is cross-built with the board files in ``harness/target/boards`` (a vector table whose
reset handler enables the FPU, a linker script for QEMU's MPS2 boards) and ``pil_main.c.j2`` (log
in, outputs and states out, through newlib's semihosting), then run on ``qemu-system-arm`` with
``-icount shift=0``, so that guest time advances exactly 1 ns per instruction. The driver counts
SysTick ticks spent inside ``step`` and the ticks of a loop of known length, which converts ticks
to instructions; it paints the stack to measure what init and step really use.

Equality rules (measured, see the README's PIL section):
* the target and the host build of the same precision are compiled with ``-std=c99`` (so no FMA
  contraction: ``-ffp-contract=off`` is the ISO C default, and stated again here) and compute
  every + - * / and sqrt identically (IEEE 754);
* newlib's libm and the host's glibc may round a transcendental (atan2, exp, log, sin, cos, ...)
  to the neighbouring number. So a run that is not bit-identical to the host's is checked step by
  step: the host build's step, taken from the target's own state, must give the target's next
  state and outputs within the verify tolerance (what the estimator's algorithm makes of one
  rounding, as for the reference). A float particle filter may also resample another particle
  than the host where a point lies within float rounding of a cumulative weight; such steps are
  counted, and every target step is checked against the reference with its flip rule.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsegen.codegen.generate import render, template_environment
from vsegen.harness.host.build import WARNING_FLAGS, compile_cached, library_files
from vsegen.harness.jobs.pool import ProcessPool
from vsegen.harness.sim.scenarios import VERIFICATION_SET, Case
from vsegen.harness.target.toolchains import Target, build_for_target, target_for
from vsegen.harness.verify.compare import Difference, Tolerance, as_seen_by, difference, relative_errors
from vsegen.harness.verify.equivalence import CaseResult, against_reference, case_inputs, prepared
from vsegen.model.estimator import Estimator, Particles
from vsegen.model.params import VehicleConfig

BOARDS_FOLDER = Path(__file__).parent / "boards"
QEMU = "qemu-system-arm"
PIL_FLAGS = ("-O2", "-ffp-contract=off", "--specs=rdimon.specs", "-Wl,--gc-sections")
TIMEOUT_S = 600


@dataclass(frozen=True)
class Board:
    """A QEMU machine standing in for a production core."""

    name: str
    machine: str
    target: Target
    clock_hz: float
    """Clock of the production part the CPU load is stated for."""

    @property
    def real(self) -> str:
        return self.target.real


BOARDS = {
    "m4f": Board("m4f", "mps2-an386", target_for("float"), 168e6),
    "m7": Board("m7", "mps2-an500", target_for("double"), 400e6),
}
"""--target choices: a Cortex-M4F (single-precision FPU, float code) and a Cortex-M7 (double FPU)."""


class PilError(RuntimeError):
    """A PIL run failed on the target (a crash, a time-out, output of the wrong size)."""


@dataclass(frozen=True)
class PilRun:
    """What one run on the target gave."""

    outputs: np.ndarray
    """n x outputs."""
    states: np.ndarray
    """(n + 1) x state entries, the state after init first."""
    instructions_per_step: float
    stack_init: int
    """Bytes of stack init used (painted), measured from main's stack pointer."""
    stack_step: int


def available() -> str:
    """'' when PIL can run here, else what is missing (one line)."""
    missing = [tool for tool in (QEMU, target_for("float").compiler) if shutil.which(tool) is None]
    if missing:
        return (f"{', '.join(missing)} not found: expected the Debian packages qemu-system-arm and "
                f"gcc-arm-none-eabi (run scripts/setup.sh)")
    return ""


def driver_source(estimator: Estimator) -> str:
    """The PIL main of ``estimator``."""
    prefix = f"vse_{estimator.name}"
    template = template_environment(Path(__file__).parent).get_template("pil_main.c.j2")
    return template.render(est=estimator, p=prefix, P=prefix.upper())


def build(estimator: Estimator, files: dict[str, str], board: Board) -> Path:
    """The PIL firmware (ELF) of the generated ``files`` for ``board``, cached by content."""
    sources = {**library_files(files), "vse_pil_main.c": driver_source(estimator),
               **{path.name: path.read_text() for path in sorted(BOARDS_FOLDER.iterdir())}}
    return compile_cached(sources, board.target.compiler,
                          (*WARNING_FLAGS, *board.target.flags, *PIL_FLAGS, "-T", "mps2.ld"), "pil", ".elf")


def run(elf: Path, estimator: Estimator, inputs: np.ndarray, board: Board) -> PilRun:
    """Run the firmware ``elf`` on ``board``'s QEMU machine over the input rows ``inputs``."""
    n_out, n_state = len(estimator.outputs), len(estimator.states)
    with tempfile.TemporaryDirectory(prefix="vsegen-pil-") as tmp:
        source, sink = Path(tmp) / "in.bin", Path(tmp) / "out.bin"
        source.write_bytes(np.int32(len(inputs)).tobytes() + np.ascontiguousarray(inputs, "<f8").tobytes())
        command = [QEMU, "-M", board.machine, "-nographic", "-monitor", "none", "-serial", "none",
                   "-icount", "shift=0", "-semihosting-config",
                   f"enable=on,target=native,arg=pil,arg={source},arg={sink}", "-kernel", str(elf)]
        try:
            result = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            raise PilError(f"{estimator.name} on {board.machine}: no result after {TIMEOUT_S} s") from None
        report = re.search(r"vse_pil steps=(\d+) step_ticks=(\d+) calibration_ticks=(\d+) "
                           r"calibration_instructions=(\d+) stack_init=(\d+) stack_step=(\d+)", result.stdout)
        if result.returncode != 0 or report is None:
            raise PilError(f"{estimator.name} on {board.machine}: exit {result.returncode}: "
                           f"{(result.stdout + result.stderr).strip()[-300:]}")
        data = np.frombuffer(sink.read_bytes(), "<f8")
    steps, step_ticks, calibration_ticks, calibration_instructions, stack_init, stack_step = map(int, report.groups())
    if data.size != n_state + steps * (n_out + n_state):
        raise PilError(f"{estimator.name} on {board.machine}: {data.size} values written: expected "
                       f"{n_state + steps * (n_out + n_state)}")
    rows = data[n_state:].reshape(steps, n_out + n_state)
    states = np.vstack([data[:n_state], rows[:, n_out:]])
    per_tick = calibration_instructions / calibration_ticks
    return PilRun(rows[:, :n_out].copy(), states, step_ticks * per_tick / steps, stack_init, stack_step)


@dataclass(frozen=True)
class HostComparison:
    """A target run against the host build of the same precision."""

    identical: bool
    """Bit-identical outputs and states over the whole run."""
    steps: Difference
    """Else: each target step against the host build's step from the same (target) state."""
    resampling: int = 0
    """Float particle filters: steps whose resampled particles differ from the host's beyond the
    tolerance (a resampling point within float rounding of a cumulative weight; every target
    step is checked against the reference, flips included)."""

    @property
    def ok(self) -> bool:
        return self.identical or self.steps.ok


def against_host(pil: PilRun, host, estimator: Estimator, inputs: np.ndarray, real: str,
                 tolerance: Tolerance) -> HostComparison:
    """Compare a target run with the ``host`` build (a harness.host.build.CEstimator) of the same
    precision: bit for bit, else step by step from the target's own states within ``tolerance``
    (the verify tolerance: libm rounding, amplified by the algorithm as the reference's is)."""
    host_outputs, host_states = host.run(inputs)
    if np.array_equal(host_outputs, pil.outputs) and np.array_equal(host_states, pil.states):
        return HostComparison(True, difference("step vs host step", pil.outputs, host_outputs, tolerance))
    n_state = len(estimator.states)
    expected = np.array([np.concatenate(host.step(pil.states[k], row)) for k, row in enumerate(inputs)])
    actual = np.hstack([pil.states[1:], pil.outputs])
    scales = np.concatenate([estimator.states.scales, estimator.outputs.scales])
    resampling = 0
    if isinstance(estimator.structure, Particles) and real == "float":
        errors = relative_errors(actual[:, :n_state], expected[:, :n_state], tolerance, scales[:n_state])
        flipped = errors.max(axis=1) > tolerance.relative
        expected[flipped, :n_state] = actual[flipped, :n_state]
        resampling = int(flipped.sum())
    return HostComparison(False, difference("step vs host step", actual, expected, tolerance, scale=scales),
                          resampling)


@dataclass(frozen=True)
class PilResult:
    """One estimator on one scenario on a target."""

    board: str
    reference: CaseResult
    host: HostComparison
    instructions_per_step: float
    stack_init: int
    stack_step: int

    @property
    def ok(self) -> bool:
        return self.reference.ok and self.host.ok


def pil_case(config: VehicleConfig, name: str, case: Case, seed: int, board_name: str, params: str) -> PilResult:
    """Build ``name`` for the board (cached), run it on ``case`` under QEMU, compare the run with
    the reference (as `vsegen verify` does) and with the host build of the same precision."""
    estimator, *_ = prepared(config, name, BOARDS[board_name].real, params)
    inputs = case_inputs(config, estimator, case, seed, BOARDS[board_name].real)
    return pil_inputs(config, name, inputs, case.label, board_name, params)


def pil_log(config: VehicleConfig, name: str, log, label: str, board_name: str, params: str) -> PilResult:
    """:func:`pil_case` on a recorded ``log`` (a :class:`~vsegen.harness.logs.table.Log` at the
    vehicle file's sample time), named ``label`` in the report."""
    estimator, *_ = prepared(config, name, BOARDS[board_name].real, params)
    inputs = as_seen_by(BOARDS[board_name].real, log.matrix(estimator.inputs.names))
    return pil_inputs(config, name, inputs, label, board_name, params)


def pil_inputs(config: VehicleConfig, name: str, inputs: np.ndarray, label: str, board_name: str,
               params: str) -> PilResult:
    """Run ``name`` on the input rows under QEMU and compare with the reference and the host build."""
    board = BOARDS[board_name]
    estimator, _, host, tolerance = prepared(config, name, board.real, params)
    elf = build(estimator, render(config, name, board.real, params), board)
    target = run(elf, estimator, inputs, board)
    return PilResult(board.name, against_reference(config, name, label, board.real, params, inputs, target.outputs,
                                                   target.states, host_libm=False),
                     against_host(target, host, estimator, inputs, board.real, tolerance),
                     target.instructions_per_step, target.stack_init, target.stack_step)


def _build(config: VehicleConfig, name: str, board_name: str, params: str) -> None:
    board = BOARDS[board_name]
    estimator, *_ = prepared(config, name, board.real, params)
    build(estimator, render(config, name, board.real, params), board)


def pil(config: VehicleConfig, names: tuple[str, ...], board_name: str, params: str,
        cases: tuple[Case, ...] = VERIFICATION_SET, seed: int = 1,
        on_done: Callable[[PilResult], None] | None = None) -> list[PilResult]:
    """Every estimator of ``names`` on every case on the board, spread over worker processes."""
    with ProcessPool() as pool:
        pool.map(_build, [(config, name, board_name, params) for name in names])
        jobs = [(config, name, case, seed, board_name, params) for name in names for case in cases]
        return pool.map(pil_case, jobs, on_done=(lambda _, result: on_done(result)) if on_done else None)


@dataclass(frozen=True)
class Cost:
    """What an estimator costs on a board, over a set of PIL runs."""

    estimator: str
    board: Board
    instructions_mean: float
    """Instructions per step, averaged over every step of every run."""
    instructions_max: float
    """The largest per-run average (the most expensive scenario)."""
    load: float
    """instructions_mean x sample rate / board.clock_hz: the share of the core, taking an
    instruction as a cycle (an estimate: caches, flash wait states and FPU latencies not modelled)."""
    stack_init: int
    stack_step: int
    static_stack_init: int
    """gcc -fstack-usage along the worst call path (library frames not known)."""
    static_stack_step: int


def cost(config: VehicleConfig, name: str, board: Board, params: str, results: list[PilResult]) -> Cost:
    """``name``'s cost on ``board`` from its PIL ``results``, with the static stack of the same build."""
    runs = [r for r in results if r.reference.estimator == name]
    static = build_for_target(render(config, name, board.real, params), name, board.target)
    steps = sum(r.reference.samples for r in runs)
    mean = sum(r.instructions_per_step * r.reference.samples for r in runs) / steps
    return Cost(name, board, mean, max(r.instructions_per_step for r in runs),
                mean / config.sample_time / board.clock_hz, max(r.stack_init for r in runs),
                max(r.stack_step for r in runs), static.stack_init, static.stack_step)
