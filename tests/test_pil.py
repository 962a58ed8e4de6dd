"""Processor-in-the-loop: the generated C built for a Cortex-M, run under QEMU, equal to the host
build of the same precision (or within the verify tolerance, step by step) and to the reference;
its instruction count and stack measured on the target."""

from __future__ import annotations

import os
import sys
from dataclasses import replace

import numpy as np
import pytest
from cases import DECISIVE, PARTICLE_FILTERS
from junit_reports import read_junit
from locations import DEFAULT_VEHICLE, REPO

from vsegen.codegen.generate import render
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.target import emulator as pil
from vsegen.harness.verify.equivalence import against_reference, case_inputs, prepared
from vsegen.model.params import parse_vehicle

pytestmark = pytest.mark.skipif(bool(pil.available()), reason=pil.available() or "")


@pytest.fixture(scope="module")
def config():
    return load_vehicle(DEFAULT_VEHICLE)


@pytest.mark.slow          # test_every_estimator_runs_under_pil covers it in full
@pytest.mark.parametrize("name,board", [("kf2dof", "m4f"), ("switching", "m7")])
def test_one_estimator_per_target_runs_every_verification_scenario(config, name, board):
    results = pil.pil(config, (name,), board, "baked")
    assert len(results) == len(VERIFICATION_SET)
    for result in results:
        assert result.reference.ok, result.reference
        assert result.host.ok, (result.reference.case, result.host)
        assert result.instructions_per_step > 100 and 0 < result.stack_step < 4096


def test_a_float_kf2dof_on_the_m4f_is_bit_identical_to_the_host_build(config):
    result = pil.pil_case(config, "kf2dof", VERIFICATION_SET[0], 1, "m4f", "baked")
    assert result.host.identical


def _target_run(config, name: str, board: pil.Board):
    estimator, _, host, tolerance = prepared(config, name, board.real, "baked")
    inputs = case_inputs(config, estimator, VERIFICATION_SET[0], 1, board.real)
    elf = pil.build(estimator, render(config, name, board.real, "baked"), board)
    return estimator, host, tolerance, inputs, pil.run(elf, estimator, inputs, board)


def test_a_changed_value_on_the_target_fails_both_comparisons(config):
    board = pil.BOARDS["m7"]
    estimator, host, tolerance, inputs, run = _target_run(config, "kf2dof", board)
    states = run.states.copy()
    states[500, 0] *= 1.0 + 1e-9          # one state entry, one step, far above double rounding
    wrong = replace(run, states=states)
    assert not pil.against_host(wrong, host, estimator, inputs, board.real, tolerance).ok
    assert not against_reference(config, "kf2dof", VERIFICATION_SET[0].label, board.real, "baked", inputs,
                                 wrong.outputs, wrong.states).ok


def test_instructions_grow_with_the_particle_count(config):
    """The instruction count measures the step's work: twice the particles, about twice the count."""
    board = pil.BOARDS["m4f"]
    counts = []
    for particles in (100, 200):
        text = with_settings(DEFAULT_VEHICLE.read_text(), "estimator.pf_improved", particles=particles)
        car = parse_vehicle(text, "pf.toml", "pf")
        counts.append(_target_run(car, "pf_improved", board)[4].instructions_per_step)
    assert 1.8 < counts[1] / counts[0] < 2.1, counts


def test_without_qemu_the_command_is_one_line(tmp_path, vsegen):
    bare = tmp_path / "bin"
    bare.mkdir()
    os.symlink(sys.executable, bare / "python3")
    result = vsegen.process("pil", "--estimator", "kf2dof", env={**os.environ, "PATH": str(bare)})
    assert result.exit_code == 2 and result.stderr.count("\n") == 1
    assert "qemu-system-arm, arm-none-eabi-gcc not found: expected the Debian packages" in result.stderr


@pytest.mark.slow
@pytest.mark.parametrize("car, board", [("c_class", "m4f"), ("rwd_saloon", "m7")])
def test_every_estimator_runs_under_pil(board, car):
    """Every estimator of each car on one board, each board once (float on the M4F, double on the
    M7), on the decisive scenarios (the host build equals the reference on all of them, verify);
    the particle filters, whose 100,000 instructions a step take most of the emulator's time, on
    the default car's board only. `python -m bench.pil --vehicle FILE` runs a car on both boards
    and every scenario (docs/pil.md)."""
    path = REPO / "vehicles" / f"{car}.toml"
    vehicle = load_vehicle(path)
    names = tuple(n for n in vehicle.estimators if path == DEFAULT_VEHICLE or n not in PARTICLE_FILTERS)
    results = pil.pil(vehicle, names, board, "baked", DECISIVE)
    failures = [(r.reference.estimator, r.reference.case) for r in results if not r.ok]
    assert failures == []
    assert np.isfinite([r.instructions_per_step for r in results]).all()


def test_a_recorded_log_replays_on_the_target(tmp_path, vsegen):
    """`vsegen pil --log` runs the form that will be flashed on a user's log (here a fishhook on
    the saloon, written without truth as a logger would): equal to the reference and the host build."""
    vehicle = REPO / "vehicles" / "rwd_saloon.toml"
    log = tmp_path / "drive.csv"
    simulated = vsegen("simulate", "fishhook", "--vehicle", vehicle, "--seed", "4", "--no-truth", "--out", log)
    assert simulated.exit_code == 0
    junit = tmp_path / "pil.xml"
    result = vsegen("pil", "--vehicle", vehicle, "--log", log, "--estimator", "kf2dof", "--target", "m4f",
                    "--junit", junit)
    assert result.exit_code == 0, result.output
    assert "drive.csv" in result.stdout and "PIL passed" in result.stdout
    (suite,) = read_junit(junit)
    assert suite.name == "rwd_saloon.kf2dof.float-baked@m4f" and suite.failures == 0
    names = [case.name for case in suite]
    assert "drive.csv: beta" in names and "drive.csv: vs host build" in names and "cost on the target" in names


def test_a_log_at_another_rate_is_refused_in_one_line(tmp_path, vsegen):
    log = tmp_path / "fast.csv"
    assert vsegen("simulate", "dlc", "--rate", "200", "--out", log).exit_code == 0
    result = vsegen("pil", "--vehicle", DEFAULT_VEHICLE, "--log", log, "--estimator", "kf2dof", "--target", "m4f")
    assert result.exit_code != 0
    expected = "fast.csv: sample time 0.005 s: expected the vehicle file's [estimator] sample_time = 0.01 s"
    assert expected in result.stderr
    assert "Traceback" not in result.output
