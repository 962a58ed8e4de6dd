"""Calibratable parameters: a const calibration struct read at run time, equivalent to baked."""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pytest
from locations import VEHICLES

from vsegen.codegen.generate import render
from vsegen.harness.host.build import load_estimator, load_tuning_estimator
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.reference import REFERENCES
from vsegen.harness.reference import kf2dof as reference
from vsegen.harness.reference.loop import run_reference
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.verify.compare import TOLERANCES, difference
from vsegen.model.calibration import calibratable, calibration_values
from vsegen.model.calibration_checks import unchecked_rules
from vsegen.model.estimators import SCHEMAS, build
from vsegen.model.params import parse_vehicle
from vsegen.model.status import INVALID_CALIBRATION


def test_calibration_file_and_struct(config):
    files = render(config, "kf2dof", params="calibratable")
    assert "vse_kf2dof_calibration.c" in files
    header = files["vse_kf2dof.h"]
    assert "} vse_kf2dof_calibration_t;" in header and "vse_kf2dof_real mass;" in header
    assert "extern const volatile vse_kf2dof_calibration_t vse_kf2dof_calibration;" in header
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


@pytest.mark.parametrize("vehicle", ["c_class", "rwd_saloon"])
def test_every_calibration_field_is_read_at_run_time(vehicle):
    """The calibration struct holds only what the code reads at run time (CasADi's which_depends);
    the values read only at generation are baked and listed in the header."""
    config = load_vehicle(VEHICLES / f"{vehicle}.toml")
    for name in config.estimators:
        estimator = build(name, config, "calibratable")
        assert estimator.read_parameters() == estimator.parameters.names, name
        full = calibratable(config, name)
        assert set(estimator.parameters.names) | set(estimator.parameters.fixed) == set(full.names)
        if estimator.parameters.fixed:
            header = render(config, name, params="calibratable")[f"vse_{name}.h"]
            assert "Baked at generation" in header and estimator.parameters.fixed[-1] in header


def test_every_schema_rule_is_repeated_in_the_generated_checks():
    """Each rule of every estimator's schema is a comparison the generated C can repeat."""
    assert {name: unchecked_rules(schema) for name, schema in SCHEMAS.items()
            if unchecked_rules(schema)} == {}


def _with_entry(config, estimator: str, entry: str, value: float):
    """``config`` with the calibration entry ``entry`` (a [vehicle] or [inputs] key, a setting,
    ``<key>_<i>`` of a list or ``<key>_<i><j>`` of a symmetric matrix) set to ``value``."""
    if entry in config.vehicle:
        return replace(config, vehicle=MappingProxyType({**config.vehicle, entry: value}))
    if entry in config.limits:
        return replace(config, limits=MappingProxyType({**config.limits, entry: value}))
    settings = dict(config.settings(estimator))
    if entry in settings:
        settings[entry] = value
    else:
        key, index = entry.rsplit("_", 1)
        old = settings[key]
        if isinstance(old[0], tuple):
            i, j = int(index[0]) - 1, int(index[1]) - 1
            rows = [list(row) for row in old]
            rows[i][j] = rows[j][i] = value
            settings[key] = tuple(tuple(row) for row in rows)
        else:
            settings[key] = tuple(value if k == int(index) - 1 else v for k, v in enumerate(old))
    return replace(config, estimators=MappingProxyType({**config.estimators,
                                                        estimator: MappingProxyType(settings)}))


def _small(entry: str, names, values) -> float:
    """A small non-zero value for a zero entry: 0.1 sqrt(P_ii P_jj) for a matrix's off-diagonal
    entry (the matrix stays positive definite), else 0.01."""
    key, _, index = entry.rpartition("_")
    if len(index) == 2 and index.isdigit() and index[0] != index[1]:
        diagonal = [values[names.index(f"{key}_{k}{k}")] for k in index]
        return 0.1 * float(np.sqrt(diagonal[0] * diagonal[1]))
    return 0.01


@pytest.mark.parametrize("name", ["kf2dof", pytest.param("switching", marks=pytest.mark.slow)])
def test_each_calibration_field_changes_the_output_as_regeneration_does(config, name):
    """Each calibration field changed alone (by 3 %) in the running C gives what the reference of
    a vehicle file with that value gives: the field is read, and read as that setting; and at least
    half of them change the reference's outputs or state on this run (a limit changes nothing until
    it is crossed)."""
    tuning = load_tuning_estimator(config, name)
    names, values = tuning.estimator.parameters.names, calibration_values(
        config, name, tuning.estimator.parameters.names)
    inputs = Case.of("dlc", speed_kmh=100.0).simulate(config, 100.0).matrix(tuning.estimator.inputs.names)
    base = run_reference(REFERENCES[name], config, inputs)
    changed = 0
    for index, entry in enumerate(names):
        new = values[index] * 1.03 if values[index] != 0.0 else _small(entry, names, values)
        calibration = list(values)
        calibration[index] = new
        tuning.set_calibration(calibration)
        c_out, _ = tuning.run(inputs)
        ref_out, ref_states = run_reference(REFERENCES[name], _with_entry(config, name, entry, new), inputs)
        for i, signal in enumerate(tuning.estimator.outputs.names):
            assert difference(signal, c_out[:, i], ref_out[:, i], TOLERANCES["double"],
                              integer=signal in ("status", "mode")).ok, (entry, signal)
        changed += not (np.array_equal(ref_out, base[0]) and np.array_equal(ref_states, base[1]))
    assert changed >= len(names) // 2


def test_the_checks_sums_read_a_recalibrated_input_limit(config):
    """switching's yaw-rate check alone reads a_x, summed between its runs only where |a_x| is
    within the [inputs] limit: in a calibratable build that is the calibration's ax_max, as the
    kernels' guard reads it. Recalibrated to 0.3 m/s^2, inside the DLC's a_x, the C keeps the
    state and outputs the reference of a file with that limit keeps (the sums' test once read the
    generated value)."""
    tuning = load_tuning_estimator(config, "switching")
    names = tuning.estimator.parameters.names
    calibration = list(calibration_values(config, "switching", names))
    calibration[names.index("ax_max")] = 0.3
    tuning.set_calibration(calibration)
    inputs = Case.of("dlc", speed_kmh=100.0).simulate(config, 100.0).matrix(tuning.estimator.inputs.names)
    assert 0.1 < np.mean(np.abs(inputs[:, tuning.estimator.inputs.index("ax")]) > 0.3) < 0.9
    c_out, c_states = tuning.run(inputs)
    ref_out, ref_states = run_reference(REFERENCES["switching"], _with_entry(config, "switching", "ax_max", 0.3),
                                        inputs)
    sum_ax = tuning.estimator.states.index("checks_sum_ax")
    np.testing.assert_allclose(c_states[:, sum_ax], ref_states[:, sum_ax], rtol=1e-12, atol=1e-12)
    for i, signal in enumerate(tuning.estimator.outputs.names):
        assert difference(signal, c_out[:, i], ref_out[:, i], TOLERANCES["double"],
                          integer=signal in ("status", "mode")).ok, signal


@pytest.mark.parametrize("name", ["kf2dof", pytest.param("switching", marks=pytest.mark.slow),
                                  pytest.param("pf_improved", marks=pytest.mark.slow)])
def test_an_invalid_calibration_holds_with_its_status(config, name):
    """The generated C repeats the schema's checks on the calibration: a mass <= 0, a zero
    cornering stiffness, a NaN, a resume speed below the hold speed or (for the 2x2 matrices) a
    covariance that is not positive definite hold the estimator with status INVALID_CALIBRATION
    and outputs 0, its state untouched; the generated calibration runs as before."""
    tuning = load_tuning_estimator(config, name)
    names = tuning.estimator.parameters.names
    values = calibration_values(config, name, names)
    inputs = Case.of("dlc", speed_kmh=80.0).simulate(config, 100.0).matrix(tuning.estimator.inputs.names)
    status_index = tuning.estimator.outputs.index("status")
    tuning.set_calibration(values)
    good, _ = tuning.run(inputs)
    assert not np.any(good[:, status_index].astype(int) & INVALID_CALIBRATION)
    breaks = {"mass": -1412.0, "cornering_stiffness_front": 0.0, "yaw_inertia": float("nan"),
              "vx_resume": 0.5 * values[names.index("vx_min")]}
    if "measurement_noise_12" in names:
        r11, r22 = values[names.index("measurement_noise_11")], values[names.index("measurement_noise_22")]
        breaks["measurement_noise_12"] = 1.5 * float(np.sqrt(r11 * r22))
    for entry, value in breaks.items():
        if entry not in names:
            continue
        calibration = list(values)
        calibration[names.index(entry)] = value
        tuning.set_calibration(calibration)
        outputs, states = tuning.run(inputs)
        assert np.all(outputs[:, status_index].astype(int) == INVALID_CALIBRATION), entry
        others = [i for i in range(outputs.shape[1]) if i != status_index]
        assert not np.any(outputs[:, others]), entry
        assert np.array_equal(states[1:], np.repeat(states[:1], len(inputs), axis=0)), entry


def test_the_header_exposes_the_parameter_hash(config, variant):
    """The parameter set's SHA-256 is a constant the firmware can report; it changes with a value."""
    header = render(config, "kf2dof")["vse_kf2dof.h"]
    assert f'#define VSE_KF2DOF_PARAMETER_HASH "{config.parameter_hash("kf2dof")}"' in header
    heavier = variant("vehicle", mass=1500.0)
    assert heavier.parameter_hash("kf2dof") != config.parameter_hash("kf2dof")
    assert heavier.parameter_hash("kf2dof") in render(heavier, "kf2dof")["vse_kf2dof.h"]


@pytest.mark.parametrize("field,value", [("mass", math.inf), ("mass", math.nan), ("mass", 1e30),
                                         ("cornering_stiffness_front", 1e20), ("measurement_noise_11", math.inf),
                                         ("mass", -1.0), ("vx_min", 1e38)])
def test_a_bad_calibration_is_named_refused_and_forgotten_when_it_is_mended(config, field, value):
    """C_f = 1e20 or +Inf, R11 = +Inf or a mass of 1e30 written into the calibration made beta and v_y
    NaN for the rest of the log; now every value is bounded: the integrator's check names the broken
    rule, the steps hold with INVALID_CALIBRATION and a finite state, and the estimator recovers
    when the good value returns."""
    estimator = load_tuning_estimator(config, "kf2dof")
    names = estimator.estimator.parameters.names
    good = np.array(calibration_values(config, "kf2dof", names))
    inputs = Case.of("dlc").simulate(config, 100.0, 1).matrix(estimator.estimator.inputs.names)
    estimator.set_calibration(good)
    assert estimator.calibration_check() == 0
    reference, _ = estimator.run(inputs)
    bad = good.copy()
    bad[names.index(field)] = value
    estimator.set_calibration(bad)
    failing = estimator.calibration_check()
    assert failing > 0
    checks = checks_in_words(config)
    assert checks[failing - 1].split()[0] == field
    outputs, states = estimator.run(inputs)
    assert np.isfinite(states).all() and np.isfinite(outputs).all()
    assert (outputs[:, -1].astype(int) & INVALID_CALIBRATION).all()
    estimator.set_calibration(good)
    mended, _ = estimator.run(inputs)
    np.testing.assert_array_equal(mended, reference)


def checks_in_words(config) -> list[str]:
    """The generated C's names of its calibration checks, in order."""
    text = render(config, "kf2dof", "double", "calibratable")["vse_kf2dof.c"]
    table = text.split("vse_kf2dof_calibration_checks[VSE_KF2DOF_N_CALIBRATION_CHECKS] = {")[1].split("};")[0]
    return [line.strip().rstrip(",").strip('"') for line in table.strip().splitlines()]


@pytest.mark.parametrize("field,value", [("cornering_stiffness_rear", 9.01421e6), ("yaw_inertia", 5.49587)])
def test_a_calibration_within_its_bounds_but_beyond_the_planned_dynamics_is_refused(config, field, value):
    """The calibration fuzzer found it: a rear stiffness of 9e6 N/rad or a yaw inertia of 5.5 kg m^2
    pass every bound, yet make ||A|| T several times larger than the ZOH series was planned for, and
    the prediction exploded to Inf. The check of the state-matrix norm refuses them."""
    estimator = load_tuning_estimator(config, "kf2dof")
    names = estimator.estimator.parameters.names
    bad = np.array(calibration_values(config, "kf2dof", names))
    bad[names.index(field)] = value
    estimator.set_calibration(bad)
    failing = estimator.calibration_check()
    assert failing > 0 and checks_in_words(config)[failing - 1].startswith("||A(vx)||_inf <=")
    inputs = Case.of("dlc").simulate(config, 100.0, 1).matrix(estimator.estimator.inputs.names)
    outputs, states = estimator.run(inputs)
    assert np.isfinite(states).all() and (outputs[:, -1].astype(int) & INVALID_CALIBRATION).all()


def test_a_calibrated_residual_window_of_minus_zero_keeps_the_state_finite(config):
    """-0 passes "residual_window >= 0"; exp(-T / -0) was +Inf and the monitor's mean NaN."""
    estimator = load_tuning_estimator(config, "kf2dof")
    names = estimator.estimator.parameters.names
    calibration = np.array(calibration_values(config, "kf2dof", names))
    calibration[names.index("residual_window")] = -0.0
    estimator.set_calibration(calibration)
    assert estimator.calibration_check() == 0
    inputs = Case.of("dlc").simulate(config, 100.0, 1).matrix(estimator.estimator.inputs.names)
    outputs, states = estimator.run(inputs)
    assert np.isfinite(states).all() and np.isfinite(outputs).all()


def test_a_noise_sigma_the_code_divides_by_has_a_physical_minimum(vehicle_text):
    """A particle filter's measurement sigma of 1e-300 squared to 0 and N_eff became Inf: the
    schema (and so the generated check) now asks for at least 1e-6."""
    head, table = vehicle_text.split("[estimator.pf_improved]")
    table = table.replace("measurement_noise = [0.3, 0.3, 0.01745]", "measurement_noise = [1e-300, 0.3, 0.01745]", 1)
    text = head + "[estimator.pf_improved]" + table
    with pytest.raises(ValueError, match=r"measurement_noise.*>= 1e-06"):
        parse_vehicle(text, "car.toml", "car")


def test_the_c_norm_check_draws_its_line_where_the_model_does(config):
    """The generated check repeats model.bicycle.state_matrix_norm_bound: a rear stiffness that puts
    the bound just under the limit passes, one just over it fails."""
    from scipy.optimize import brentq

    from vsegen.model.bicycle import state_matrix_norm_bound
    from vsegen.model.calibration_checks import dynamics_checks

    estimator = load_tuning_estimator(config, "kf2dof")
    names = estimator.estimator.parameters.names
    good = np.array(calibration_values(config, "kf2dof", names))
    (check,) = dynamics_checks(SCHEMAS["kf2dof"], names, tuple(good))

    def bound_with(stiffness: float) -> float:
        values = dict(zip(names, good))
        values["cornering_stiffness_rear"] = stiffness
        return state_matrix_norm_bound(values, values["vx_min"], values["vx_max"])

    edge = brentq(lambda c: bound_with(c) - check.limit, good[names.index("cornering_stiffness_rear")], 1e8)
    for stiffness, passes in ((edge * (1 - 1e-9), True), (edge * (1 + 1e-9), False)):
        calibration = good.copy()
        calibration[names.index("cornering_stiffness_rear")] = stiffness
        estimator.set_calibration(calibration)
        assert (estimator.calibration_check() == 0) == passes, stiffness
