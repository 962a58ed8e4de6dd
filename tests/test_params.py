"""Vehicle-file loading: the shipped file is valid; every kind of mistake gives one clear line."""

from __future__ import annotations

import pytest

from vsegen.harness.project.vehicles import load_vehicle, with_form
from vsegen.model.params import ParameterError, parse_vehicle


def test_default_vehicle_values(config):
    assert config.name == "c_class"
    assert config.vehicle["mass"] == 1412.0
    assert config.vehicle["yaw_inertia"] == 1964.4
    assert config.vehicle["cg_to_front_axle"] + config.vehicle["cg_to_rear_axle"] == pytest.approx(2.91)
    assert config.sample_time == 0.01
    kf = config.settings("kf2dof")
    assert kf["discretisation"] == "zoh"
    assert kf["measurement_noise"] == ((0.09, 0.0), (0.0, 3.046e-4))


def test_parameter_hash_tracks_parameters(config, write_vehicle):
    same = load_vehicle(write_vehicle(name="c_class.toml"))
    assert same.parameter_hash("kf2dof") == config.parameter_hash("kf2dof")
    heavier = load_vehicle(write_vehicle("mass = 1412.0", "mass = 1413.0", name="c_class.toml"))
    assert heavier.parameter_hash("kf2dof") != config.parameter_hash("kf2dof")
    assert len(config.parameter_hash("kf2dof")) == 64


BAD_FILES = [
    # (old text, new text, fragments the one-line message must contain)
    ("mass = 1412.0", "", ["[vehicle] missing key 'mass'", "a number from 10 to 100000 (kg)"]),
    ("mass = 1412.0", "mass = 1412.0\nmasss = 3.0", ["unknown key 'masss'", ":6:"]),
    ("mass = 1412.0", 'mass = "heavy"', ["mass = 'heavy'", "expected a number from 10 to 100000 (kg)", ":5:"]),
    ("mass = 1412.0", "mass = nan", ["mass = nan", "a number from 10"]),
    ("mass = 1412.0", "mass = inf", ["mass = inf", "a number from 10"]),
    ("mass = 1412.0", "mass = -1412.0", ["mass = -1412.0", "from 10 to"]),
    ("mass = 1412.0", "mass = 1e30", ["mass = 1e+30", "to 100000 (kg)"]),
    ("cornering_stiffness_front = 149900.0", "cornering_stiffness_front = 1.248e9",
     ["cornering_stiffness_front = 1248000000.0", "from 100 to 1e+08 (N/rad)"]),
    ("mass = 1412.0", "mass = true", ["mass = True", "number"]),
    ("yaw_inertia = 1964.4", "yaw_inertia = 0", ["yaw_inertia = 0", "from 1 to 1e+07 (kg*m^2)"]),
    ("cg_height = 0.54", "cg_height = -0.5", ["cg_height = -0.5", "from 0.01 to 100 (m)"]),
    ("measurement_noise = [0.09, 3.046e-4]", "measurement_noise = [1e20, 3.046e-4]",
     ["measurement_noise", "each at most 1e+12 in magnitude"]),
    ("cornering_stiffness_front = 149900.0", "cornering_stiffness_front = -149900.0",
     ["cornering_stiffness_front = -149900.0", "N/rad"]),
    ("wheelbase = 2.91", "wheelbase = 2.92", ["wheelbase = 2.92", "cg_to_front_axle + cg_to_rear_axle",
                                             "0.001 m", ":9:"]),
    ("measurement_noise = [0.09, 3.046e-4]", "measurement_noise = [0.09, -3.046e-4]",
     ["measurement_noise", "positive-definite"]),
    ("process_noise = [0.125, 0.01]", "process_noise = [[0.125, 0.5], [0.5, 0.01]]",
     ["process_noise", "not positive definite"]),
    ("process_noise = [0.125, 0.01]", "process_noise = [[0.125, 0.001], [0.0, 0.01]]",
     ["process_noise", "not symmetric"]),
    ("initial_covariance = [0.09, 4.0e-4]", "initial_covariance = [0.09]",
     ["initial_covariance = [0.09]", "2x2"]),
    ("initial_covariance = [0.09, 4.0e-4]", "initial_covariance = 0.09", ["initial_covariance", "2x2"]),
    ('discretisation = "zoh"', 'discretisation = "rk4"',
     ["discretisation = 'rk4'", '"euler", "tustin", "zoh"']),
    ("vx_resume = 3.5", "vx_resume = 2.0", ["vx_resume = 2.0", "above vx_min = 3.0"]),
    ("sample_time = 0.01", "sample_time = 0", ["sample_time = 0", "> 0 and <= 10000 (s)"]),
    ("[inputs]", "[input]", ["unknown key 'input'"]),
    ("mass = 1412.0", "mass = = 3", ["not valid TOML", "line 5"]),
    ('"kf2dof:float-baked"', '"kf2dof:half-baked"', ["[codegen] forms", '"<estimator>:<real>-<params>"', ":35:"]),
    ('"kf2dof:float-baked"', '"nope:float-baked"', ["[codegen] forms names nope: expected an estimator the file "
                                                    "configures", ":35:"]),
]


@pytest.mark.parametrize("old,new,fragments", BAD_FILES, ids=[b[1][:40] or b[0] for b in BAD_FILES])
def test_bad_vehicle_file_gives_one_clear_line(write_vehicle, old, new, fragments):
    path = write_vehicle(old, new)
    with pytest.raises(ParameterError) as error:
        load_vehicle(path)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(str(path))
    for fragment in fragments:
        assert fragment in message, message


def test_missing_tables_and_files(tmp_path):
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    with pytest.raises(ParameterError, match=r"missing table \[vehicle\]"):
        load_vehicle(empty)
    with pytest.raises(ParameterError, match="cannot read vehicle file"):
        load_vehicle(tmp_path / "nope.toml")
    junk = tmp_path / "junk.toml"
    junk.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ParameterError, match="not a text file"):
        load_vehicle(junk)


def test_other_sample_time(config):
    fast = config.with_sample_time(0.001)
    assert fast.sample_time == 0.001
    assert fast.parameter_hash("kf2dof") != config.parameter_hash("kf2dof")


def test_with_settings_edits_one_table_only(vehicle_text):
    from vsegen.harness.project.vehicles import with_settings

    text = with_settings(vehicle_text, "estimator.switching", threshold=2.0, prefilter="bessel")
    config = parse_vehicle(text, "variant.toml", "c_class")
    assert config.settings("switching")["threshold"] == 2.0
    assert config.settings("switching")["prefilter"] == "bessel"
    assert config.settings("fusion")["threshold"] == 1.5          # same key, other table: kept
    with pytest.raises(KeyError, match=r"\[estimator.switching\] has no key nope"):
        with_settings(vehicle_text, "estimator.switching", nope=1.0)


@pytest.mark.parametrize("edit", ["as shipped", "no forms key", "no codegen table"])
def test_a_form_is_added_to_the_vehicle_file_and_nothing_else_changes(vehicle_text, edit):
    import re

    text = {"as shipped": vehicle_text,
            "no forms key": re.sub(r"\n# the other forms.*\nforms = \[[^\]]*\]", "", vehicle_text),
            "no codegen table": vehicle_text[:vehicle_text.index("[codegen]")]
            + vehicle_text[vehicle_text.index("[estimator]\n"):]}[edit]
    before = parse_vehicle(text, "car.toml", "car")
    after = parse_vehicle(with_form(text, "switching", "float", "calibratable"), "car.toml", "car")
    assert after.codegen["forms"] == (*before.codegen["forms"], ("switching", "float", "calibratable"))
    assert (after.vehicle, after.estimators, after.codegen["real"]) == (before.vehicle, before.estimators,
                                                                        before.codegen["real"])
    assert with_form(with_form(text, "switching", "float", "calibratable"), "switching", "float", "calibratable") \
        == with_form(text, "switching", "float", "calibratable")
