"""Calibratable parameters: a const calibration struct read at run time, equivalent to baked."""

from __future__ import annotations

import numpy as np
import pytest

from codegen.generate import render
from harness.build import load_estimator
from harness.compare import TOLERANCES, difference
from harness.reference import kf2dof as reference
from harness.reference.run import run_reference
from harness.scenarios import Case
from model.estimators import build
from model.params import parse_vehicle


def test_calibration_file_and_struct(config):
    files = render(config, "kf2dof", params="calibratable")
    assert "vse_kf2dof_calibration.c" in files
    header = files["vse_kf2dof.h"]
    assert "} vse_kf2dof_calibration_t;" in header and "vse_kf2dof_real mass;" in header
    assert "extern const vse_kf2dof_calibration_t vse_kf2dof_calibration;" in header
    assert "1412.0, /* mass */" in files["vse_kf2dof_calibration.c"]
    assert "vse_kf2dof_calibration.c" in files["CMakeLists.txt"] and \
        "vse_kf2dof_calibration.o" in files["Makefile"]
    assert "1412" not in files["vse_kf2dof_kernel.c"].split("*/", 1)[1]  # not baked in the kernel


def test_recalibration_without_regenerating(config, vehicle_text):
    """New values in the calibration file alone make the same kernel compute what the reference
    computes for the new vehicle file."""
    heavier = parse_vehicle(vehicle_text.replace("mass = 1412.0", "mass = 1600.0")
                            .replace("vx_min = 3.0 ", "vx_min = 3.2 "), "heavier.toml", "c_class")
    files = render(config, "kf2dof", params="calibratable")
    recalibrated = render(heavier, "kf2dof", params="calibratable")
    files["vse_kf2dof_calibration.c"] = recalibrated["vse_kf2dof_calibration.c"]
    compiled = load_estimator(build("kf2dof", config, "calibratable"), files)
    for case in (Case.of("dlc", speed_kmh=100.0), Case.of("low_speed")):
        inputs = case.simulate(config, 100.0).matrix(reference.INPUTS)
        c_out, _ = compiled.run(inputs)
        new_out, _ = run_reference(reference, heavier, inputs)
        old_out, _ = run_reference(reference, config, inputs)
        assert difference("beta", c_out[:, 0], new_out[:, 0], TOLERANCES["double"]).ok
        assert not difference("beta", c_out[:, 0], old_out[:, 0], TOLERANCES["double"]).ok
        np.testing.assert_array_equal(c_out[:, 3], new_out[:, 3])


def test_unknown_parameter_mode(config):
    with pytest.raises(ValueError, match="parameter mode"):
        build("kf2dof", config, "flashy")
