"""vsegen identify: parameters from ordinary driving logs, with intervals, refusals and the written
vehicle file; on both truth cars and on a synthetic bicycle-model log with known parameters."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from locations import VEHICLES
from scipy.signal import lsim

from vsegen.harness.identify import identify
from vsegen.harness.identify.vehicle_file import identified_vehicle_file
from vsegen.harness.logs.table import Log, write_log
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.model.bicycle import GRAVITY
from vsegen.model.estimators import underived_warning
from vsegen.model.params import parse_vehicle

ORDINARY_DRIVING = (
    Case.of("step_steer", delta=0.02, duration=8.0),
    Case.of("step_steer", delta=0.04, speed_kmh=70.0, duration=8.0),
    Case.of("sine_steer"),
    Case.of("dlc", speed_kmh=60.0),
    Case.of("hil_sine"),
)
"""A handful of ordinary manoeuvres, as a test drive would have them."""
OTHER = {"c_class": "rwd_saloon", "rwd_saloon": "c_class"}


def plant_axle_stiffness(config) -> tuple[float, float]:
    """The truth plant's axle cornering stiffnesses at static load (Magic Formula load law), computed
    here from [plant] and the geometry, independently of the [vehicle] values."""
    v, p = config.vehicle, config.plant
    m, a, b = v["mass"], v["cg_to_front_axle"], v["cg_to_rear_axle"]
    fz0, k1, k2 = p["tyre_nominal_load"], p["tyre_cornering_factor"], p["tyre_cornering_load_factor"]

    def tyre(fz: float) -> float:
        return k1 * fz0 * math.sin(2 * math.atan(fz / (k2 * fz0)))

    return 2 * tyre(m * GRAVITY * b / (a + b) / 2), 2 * tyre(m * GRAVITY * a / (a + b) / 2)


def start_file(car: str) -> tuple[str, object]:
    """What a user starts from: the car's file with the other car's stiffnesses and roll gradients
    (only mass, geometry and I_z are the car's own)."""
    text = (VEHICLES / f"{car}.toml").read_text()
    other = load_vehicle(VEHICLES / f"{OTHER[car]}.toml")
    text = with_settings(text, "vehicle", cornering_stiffness_front=other.vehicle["cornering_stiffness_front"],
                         cornering_stiffness_rear=other.vehicle["cornering_stiffness_rear"])
    for name in other.estimators:
        if "roll_gradient" in other.settings(name) and f"[estimator.{name}]" in text:
            text = with_settings(text, f"estimator.{name}", roll_gradient=other.settings(name)["roll_gradient"])
    return text, parse_vehicle(text, f"{car}_start.toml", car)


@pytest.mark.parametrize("car", ["c_class", "rwd_saloon"])
def test_recovers_the_roll_gradient_and_the_axle_stiffnesses_without_ground_truth(car):
    truth = load_vehicle(VEHICLES / f"{car}.toml")
    text, start = start_file(car)
    logs = [case.simulate(truth, 100.0, 1).without_truth() for case in ORDINARY_DRIVING]
    ident = identify(logs, start)
    assert not ident.uses_reference
    k = ident.estimates["roll_gradient"]
    assert abs(k.value / truth.plant["roll_gradient"] - 1) < 0.10
    assert k.low < truth.plant["roll_gradient"] < k.high
    front, rear = plant_axle_stiffness(truth)
    assert abs(ident.value("cornering_stiffness_front") / front - 1) < 0.15
    assert abs(ident.value("cornering_stiffness_rear") / rear - 1) < 0.15
    noise = ident.estimates["gyro_noise"]
    assert noise.low < truth.sensors["gyro_noise"] < noise.high
    written = parse_vehicle(identified_vehicle_file(text, start, ident), "car.toml", car)
    assert written.derived_for == written.vehicle_fingerprint()
    assert all(underived_warning(written, name) is None for name in written.estimators)
    assert written.settings("switching")["roll_gradient"] == pytest.approx(k.value, rel=1e-3)


def _bicycle_matrices(cf: float, cr: float, vehicle, vx: float = 20.0):
    """(A, B, vx) of the linear bicycle model, state [v_y, r], input delta (docs/conventions.md)."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    A = np.array([[-(cf + cr) / (m * vx), (b * cr - a * cf) / (m * vx) - vx],
                  [(b * cr - a * cf) / (iz * vx), -(a * a * cf + b * b * cr) / (iz * vx)]])
    B = np.array([[cf / m], [a * cf / iz]])
    return A, B, vx


def _bicycle_log(cf: float, cr: float, vehicle, seconds: float = 40.0, dt: float = 0.01) -> Log:
    """A synthetic log of the linear bicycle model (scipy's lsim, independent of identify's own
    integration) at 20 m/s with a chirp steer after 5 s of straight driving, seed-000 noise."""
    A, B, vx = _bicycle_matrices(cf, cr, vehicle)
    C = np.array([[A[0, 0], A[0, 1] + vx], [0.0, 1.0]])
    D = np.array([[B[0, 0]], [0.0]])
    t = np.arange(0.0, seconds, dt)
    phase = 2 * np.pi * (0.1 * (t - 5) + 0.02 * (t - 5) ** 2)
    delta = np.where(t > 5, 0.012 * np.sin(phase), 0.0)
    _, y, _ = lsim((A, B, C, D), delta, t)
    rng = np.random.default_rng(7)
    return Log({"t": t, "delta": delta, "vx": np.full_like(t, vx), "ax": rng.normal(0, 0.3, len(t)),
                "ay": y[:, 0] + rng.normal(0, 0.3, len(t)), "r": y[:, 1] + rng.normal(0, 0.017453, len(t))},
               "bicycle.csv")


def test_stiffness_intervals_hold_the_known_values_of_a_bicycle_model_log(config):
    cf, cr = 120000.0, 110000.0
    text = with_settings((VEHICLES / "c_class.toml").read_text(), "estimator.switching", roll_gradient=0.0)
    start = parse_vehicle(text.replace("roll_gradient = 0.0082", "roll_gradient = 0.0"), "start.toml", "c")
    ident = identify([_bicycle_log(cf, cr, config.vehicle)], start)
    assert ident.estimates["cornering_stiffness_front"].low < cf < ident.estimates["cornering_stiffness_front"].high
    assert ident.estimates["cornering_stiffness_rear"].low < cr < ident.estimates["cornering_stiffness_rear"].high
    assert abs(ident.value("cornering_stiffness_front") / cf - 1) < 0.03
    refused = {r.name: r.why for r in ident.refusals}
    assert "no quasi-steady cornering above 2 m/s^2" in refused["roll_gradient"]


def test_a_log_that_excites_nothing_is_refused_line_by_line_with_exit_2(tmp_path: Path, vsegen):
    t = np.arange(0.0, 20.0, 0.01)
    rng = np.random.default_rng(3)
    crawl = Log({"t": t, "delta": np.zeros_like(t), "vx": np.full_like(t, 2.0), "ax": rng.normal(0, 0.3, len(t)),
                 "ay": rng.normal(0, 0.3, len(t)), "r": rng.normal(0, 0.0175, len(t))}, "crawl.csv")
    write_log(crawl, tmp_path / "crawl.csv")
    out = tmp_path / "car.toml"
    result = vsegen("identify", "--log", str(tmp_path / "crawl.csv"), "--vehicle",
                    str(VEHICLES / "c_class.toml"), "--out", str(out))
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.strip().splitlines() if "units not checked" not in line]
    assert len(lines) == 11 and all(line.startswith("vsegen: not identified: ") for line in lines)
    assert "units not checked" in result.stderr      # a crawl judges no unit, and says so
    assert any("no straight driving above 5 m/s" in line for line in lines)
    assert any("roll_gradient: no quasi-steady cornering above 2 m/s^2" in line for line in lines)
    assert not out.exists()


def test_a_file_copied_to_another_car_warns_and_the_shipped_files_do_not(tmp_path: Path, vsegen):
    for path in sorted(VEHICLES.glob("*.toml")):
        config = load_vehicle(path)
        assert all(underived_warning(config, name) is None for name in config.estimators), path
    text = with_settings((VEHICLES / "c_class.toml").read_text(), "vehicle", mass=1780.0)
    (tmp_path / "new_car.toml").write_text(text)
    result = vsegen("generate", "--vehicle", str(tmp_path / "new_car.toml"),
                    "--estimator", "switching", "--out", str(tmp_path / "out"))
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1
    assert ("[estimator.switching] roll_gradient = 0.0082, measurement_noise = [0.09, 0.0003046] were not "
            "derived for this vehicle (see vsegen identify") in warnings[0]


@pytest.mark.slow      # 29 s; the default suite keeps identify's fits without a reference
def test_a_gnss_lateral_velocity_reference_enters_the_fit_and_narrows_it(config):
    cf, cr = 120000.0, 110000.0
    text = (VEHICLES / "c_class.toml").read_text().replace("roll_gradient = 0.0082", "roll_gradient = 0.0")
    start = parse_vehicle(text, "start.toml", "c")
    plain = _bicycle_log(cf, cr, config.vehicle)
    A, B, _ = _bicycle_matrices(cf, cr, config.vehicle)
    _, vy, _ = lsim((A, B, np.array([[1.0, 0.0]]), np.zeros((1, 1))), plain["delta"], plain["t"])
    rng = np.random.default_rng(11)
    referenced = Log({**plain.columns, "vy_ref": vy + rng.normal(0, 0.02, len(vy))}, "gnss.csv")
    without = identify([plain], start)
    with_gnss = identify([referenced], start)
    assert with_gnss.uses_reference and not without.uses_reference
    for name in ("cornering_stiffness_front", "cornering_stiffness_rear"):
        narrow, wide = with_gnss.estimates[name], without.estimates[name]
        assert narrow.high - narrow.low < wide.high - wide.low
        assert narrow.low < (cf if name.endswith("front") else cr) < narrow.high
        assert "(filter error, the reference lateral velocity)" in narrow.support


@pytest.mark.slow   # two 275-s filter-error fits, 17 s: the default suite is at its 5-min budget
def test_a_race_lap_pins_the_stiffnesses_and_the_friction_down_with_and_without_its_reference(revs_lap, revs_car):
    """The first half of the Revs lap (data/real/revs_250lm): hardly any quasi-steady linear cornering,
    29 % of it beyond 8 m/s^2. The filter-error fit identifies both stiffnesses and the friction from
    the sensors alone; the INS reference narrows the stiffnesses' intervals (not the friction's: the
    limit is as visible in a_y and r as in the reference)."""
    first = revs_lap.window(None, revs_lap["t"][0] + 275.0)
    plain = identify([first.without_truth()], revs_car)
    referenced = identify([first], revs_car)
    assert referenced.uses_reference and not plain.uses_reference
    assert "tyre_friction" in referenced.estimates
    for name in ("cornering_stiffness_front", "cornering_stiffness_rear"):
        wide, narrow = plain.estimates[name], referenced.estimates[name]
        assert narrow.high - narrow.low < wide.high - wide.low, name
    assert 0.9 < plain.value("tyre_friction") < 1.2          # a dry track, racing tyres
    assert plain.value("cornering_stiffness_rear") > plain.value("cornering_stiffness_front")  # understeer
