"""The FMU (`vsegen fmu`), judged from outside by FMPy: its modelDescription.xml passes FMPy's
validation, and FMPy's co-simulation of it equals `vsegen run`'s C bit for bit, status included;
a tunable parameter acts as the same vehicle-file value does; a value out of bounds, a calibration
the kit's checks reject and a step that is not a multiple of the sample time are refused with an
error status, and the run goes on unchanged."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
from cases import DECISIVE
from fmpy import calloc, extract, free, read_model_description, simulate_fmu
from fmpy.build import build_platform_binary
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from vsegen.codegen.fmi_units import base_units
from vsegen.harness.fmu.package import build_fmu
from vsegen.harness.host.build import compile_estimator
from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.verify.equivalence import case_inputs
from vsegen.model.estimators import DEFINITIONS

DLC = VERIFICATION_SET[0]


def fmu_run(path: Path, estimator, inputs: np.ndarray, sample_time: float, start_values=None) -> np.ndarray:
    """FMPy's simulation of the FMU at ``path`` on the input rows ``inputs``: the outputs after
    each step (n x ny), i.e. of the sample each step consumed."""
    names = [f"input.{s}" for s in estimator.inputs.names]
    signals = np.zeros(len(inputs), dtype=[("time", np.float64)] + [(name, np.float64) for name in names])
    signals["time"] = np.arange(len(inputs)) * sample_time
    for i, name in enumerate(names):
        signals[name] = inputs[:, i]
    outputs = [f"output.{s}" for s in estimator.outputs.names]
    result = simulate_fmu(str(path), validate=False, stop_time=len(inputs) * sample_time, step_size=sample_time,
                          output_interval=sample_time, input=signals, output=outputs,
                          start_values=start_values or {})
    assert len(result) == len(inputs) + 1
    return np.column_stack([result[name][1:] for name in outputs])


def assert_same_as_run(config, name, real, params, fmi, cases, tmp_path):
    path = build_fmu(config, name, real, params, fmi, tmp_path / f"{name}-{real}-{params}-{fmi}.fmu").path
    assert validate_fmu(str(path)) == []
    unzipped = Path(extract(str(path), unzipdir=str(tmp_path / path.stem)))       # extracted once, simulated often
    estimator, compiled = compile_estimator(config, name, real, params)
    for case in cases:
        inputs = case_inputs(config, estimator, case, 1, real)
        expected, _ = compiled.run(inputs)
        got = fmu_run(unzipped, estimator, inputs, config.sample_time)
        for i, signal in enumerate(estimator.outputs.names):
            assert np.array_equal(got[:, i], expected[:, i]), f"{name} {real} {params} FMI {fmi} {case.label} {signal}"


@pytest.mark.parametrize("fmi", [3, 2])
def test_fmpy_validates_the_fmu_and_its_simulation_is_the_c_of_run_bit_for_bit(config, fmi, tmp_path):
    assert_same_as_run(config, "kf2dof", "float", "calibratable", fmi, VERIFICATION_SET[:2], tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(DEFINITIONS))
def test_every_estimator_and_form_as_an_fmu_is_the_c_of_run_on_the_decisive_scenarios(config, name, tmp_path):
    """The FMU wraps the C that verify checks on every scenario: the decisive ones show it wraps it whole."""
    for real in ("double", "float"):
        for params in ("baked", "calibratable"):
            assert_same_as_run(config, name, real, params, 3, DECISIVE, tmp_path)
            assert_same_as_run(config, name, real, params, 2, VERIFICATION_SET[:1], tmp_path)


@pytest.mark.parametrize("fmi", [3, 2])
def test_the_fmu_sources_build_with_fmpy_into_the_same_estimator(config, fmi, tmp_path):
    """An outside build of the FMU's sources/ (FMPy's CMake project, its own FMI headers, Release
    flags) instead of our binary: the same outputs, bit for bit."""
    path = build_fmu(config, "kf2dof", "float", "calibratable", fmi, tmp_path / "kf.fmu").path
    directory = Path(extract(str(path), unzipdir=str(tmp_path / "unzipped")))
    shutil.rmtree(directory / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(directory, build_dir=tmp_path / "build")
    estimator, compiled = compile_estimator(config, "kf2dof", "float", "calibratable")
    inputs = case_inputs(config, estimator, DLC, 1, "float")
    assert np.array_equal(fmu_run(directory, estimator, inputs, config.sample_time), compiled.run(inputs)[0])


def test_the_fmu_describes_units_bounds_and_the_sample_time(config, tmp_path):
    path = build_fmu(config, "kf2dof", "double", "calibratable", 3, tmp_path / "kf.fmu").path
    md = read_model_description(str(path))
    variables = {v.name: v for v in md.modelVariables}
    assert float(md.coSimulation.fixedInternalStepSize) == config.sample_time == float(md.defaultExperiment.stepSize)
    assert variables["input.ay"].unit == "m/s^2" and variables["input.ay"].causality == "input"
    assert variables["output.status"].type == "Int32" and variables["output.status"].start == "1"
    assert "2048 INPUT_FROZEN" in variables["output.status"].description
    mass = variables["calibration.mass"]
    assert (mass.causality, mass.variability, float(mass.start)) == ("parameter", "tunable", config.vehicle["mass"])
    assert float(mass.min) == 10.0 and mass.unit == "kg"
    units = {u.name: u.baseUnit for u in md.unitDefinitions}
    assert (units["N/rad"].kg, units["N/rad"].m, units["N/rad"].s, units["N/rad"].rad) == (1, 1, -2, -1)
    with zipfile.ZipFile(path) as archive:
        names = set(archive.namelist())
    assert {"binaries/x86_64-linux/vse_kf2dof.so", "sources/buildDescription.xml", "sources/vse_kf2dof_kernel.c",
            "sources/vse_fmi3.c"} <= names
    assert "sources/vse_kf2dof_calibration.c" not in names       # the FMU holds the calibration itself


def test_a_tunable_parameter_acts_as_the_same_vehicle_file_value(config, variant, tmp_path):
    path = build_fmu(config, "kf2dof", "double", "calibratable", 3, tmp_path / "kf.fmu").path
    stiffer = variant("vehicle", cornering_stiffness_front=120000.0)
    estimator, compiled = compile_estimator(stiffer, "kf2dof", "double", "calibratable")
    inputs = case_inputs(config, estimator, DLC, 1, "double")
    expected, _ = compiled.run(inputs)
    got = fmu_run(path, estimator, inputs, config.sample_time,
                  {"calibration.cornering_stiffness_front": 120000.0})
    assert np.array_equal(got, expected)
    as_generated, _ = compile_estimator(config, "kf2dof", "double", "calibratable")[1].run(inputs)
    assert not np.array_equal(got[:, 0], as_generated[:, 0])


class Instance:
    """An FMU instance driven call by call through FMPy, its logged messages kept; ``directory``:
    the FMU extracted (instances of one directory share one loaded library)."""

    def __init__(self, path: Path, fmi: int, directory: str):
        md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.outputs = [v.valueReference for v in md.modelVariables
                        if v.causality == "output" and v.type in ("Float64", "Real")]
        self.messages: list[str] = []
        self.fmi = fmi
        slave = FMU3Slave if fmi == 3 else FMU2Slave
        self.fmu = slave(guid=md.guid, unzipDirectory=directory, modelIdentifier=md.coSimulation.modelIdentifier,
                         instanceName="kf")
        if fmi == 3:
            self.fmu.instantiate(logMessage=lambda env, status, category, message: self.keep(message))
            self.fmu.enterInitializationMode()
        else:
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, message: self.keep(message))
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            self.fmu.instantiate(callbacks=callbacks)
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def keep(self, message: bytes) -> None:
        self.messages.append(message.decode())

    def set(self, name: str, value: float) -> None:
        (self.fmu.setFloat64 if self.fmi == 3 else self.fmu.setReal)([self.vr[name]], [value])

    def reals(self) -> list[float]:
        return list((self.fmu.getFloat64 if self.fmi == 3 else self.fmu.getReal)(self.outputs))

    def step(self, time: float, size: float) -> None:
        self.fmu.doStep(time, size)


@pytest.mark.parametrize("fmi", [3, 2])
def test_refused_values_and_steps_leave_the_run_unchanged(config, fmi, tmp_path):
    path = build_fmu(config, "kf2dof", "double", "calibratable", fmi, tmp_path / "kf.fmu").path
    estimator, compiled = compile_estimator(config, "kf2dof", "double", "calibratable")
    inputs = case_inputs(config, estimator, DLC, 1, "double")[:300]
    expected, _ = compiled.run(inputs)
    T = config.sample_time
    instance = Instance(path, fmi, extract(str(path), unzipdir=str(tmp_path / "unzipped")))
    refusals = {150: ("calibration.mass", -5.0), 151: ("calibration.residual_limit", float("nan")),
                152: ("calibration.vx_resume", 0.5 * config.estimators["kf2dof"]["vx_min"])}
    for k, row in enumerate(inputs):
        for i, signal in enumerate(estimator.inputs.names):
            instance.set(f"input.{signal}", row[i])
        if k in refusals:
            with pytest.raises(FMICallException):
                instance.set(*refusals[k])
        if k == 200:
            with pytest.raises(FMICallException):
                instance.step(k * T, 1.5 * T)
        instance.step(k * T, T)
        assert instance.reals() == list(expected[k, :3]), f"sample {k}"
    mass = "calibration.mass = -5 refused: expected a finite value with mass >= 10, mass <= 100000"
    assert any(mass in m for m in instance.messages), instance.messages
    assert any("calibration.residual_limit = nan refused" in m for m in instance.messages)
    assert any("breaks check" in m and "vx_resume > vx_min" in m for m in instance.messages)
    assert any("step size 0.015 s refused: expected a whole multiple of the sample time 0.01 s" in m
               for m in instance.messages), instance.messages


def test_two_instances_in_one_process_keep_their_own_calibration(config, variant, tmp_path):
    path = build_fmu(config, "kf2dof", "double", "calibratable", 3, tmp_path / "kf.fmu").path
    stiffer = variant("vehicle", cornering_stiffness_front=120000.0)
    estimator, as_generated = compile_estimator(config, "kf2dof", "double", "calibratable")
    inputs = case_inputs(config, estimator, DLC, 1, "double")[:400]
    expected = {"as generated": as_generated.run(inputs)[0],
                "stiffer": compile_estimator(stiffer, "kf2dof", "double", "calibratable")[1].run(inputs)[0]}
    directory = extract(str(path), unzipdir=str(tmp_path / "unzipped"))
    instances = {label: Instance(path, 3, directory) for label in expected}
    instances["stiffer"].set("calibration.cornering_stiffness_front", 120000.0)
    for k, row in enumerate(inputs):          # interleaved: one library, one global calibration object
        for instance in instances.values():
            for i, signal in enumerate(estimator.inputs.names):
                instance.set(f"input.{signal}", row[i])
        for label, instance in instances.items():
            instance.step(k * config.sample_time, config.sample_time)
            assert instance.reals() == list(expected[label][k, :3]), f"{label}, sample {k}"


def test_the_units_of_the_catalogue_become_fmi_base_units():
    assert base_units("m/s^2") == {"m": 1, "s": -2}
    assert base_units("kg*m^2") == {"kg": 1, "m": 2}
    assert base_units("(rad/s^2)^2*s") == {"rad": 2, "s": -3}
    assert base_units("rad/(m/s^2)") == {"rad": 1, "m": -1, "s": 2}
    assert base_units("1/rad^2") == {"rad": -2}
    assert base_units("N*m") == {"kg": 1, "m": 2, "s": -2}
    for prose in ("-", "", "SI units squared", "[vy, r]: (m/s)^2, (rad/s)^2", "m/(s", "kg^x"):
        assert base_units(prose) is None, prose


def test_a_step_of_several_samples_runs_that_many_steps(config, tmp_path):
    path = build_fmu(config, "kf2dof", "double", "baked", 3, tmp_path / "kf.fmu").path
    estimator, compiled = compile_estimator(config, "kf2dof", "double", "baked")
    row = case_inputs(config, estimator, DLC, 1, "double")[400]
    expected, _ = compiled.run(np.repeat(row[None, :], 5, axis=0))
    instance = Instance(path, 3, extract(str(path), unzipdir=str(tmp_path / "unzipped")))
    for i, signal in enumerate(estimator.inputs.names):
        instance.set(f"input.{signal}", row[i])
    instance.step(0.0, 5 * config.sample_time)
    assert instance.reals() == list(expected[-1, :3])


def test_the_fmu_command_writes_a_valid_fmu(tmp_path, vsegen):
    out = tmp_path / "sw.fmu"
    result = vsegen("fmu", "--estimator", "switching", "--fmi", "2", "--out", str(out))
    assert result.exit_code == 0, result.output
    assert "FMI 2.0 co-simulation" in result.output and validate_fmu(str(out)) == []
    bad = vsegen("fmu", "--estimator", "nope", "--out", str(out))
    assert bad.exit_code == 2 and "unknown estimator 'nope'" in bad.output
