"""The real data in data/real/: the converter reproduces the shipped log from the source files, and
the shipped log reads as a log with its reference."""

from __future__ import annotations

import gzip
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from locations import REVS

CONVERTER = REVS / "convert.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(CONVERTER), *args], capture_output=True, text=True, check=False)


def test_the_converter_reproduces_the_shipped_lap_from_the_source_files(tmp_path: Path):
    out = tmp_path / "head.csv.gz"
    result = _run(str(REVS / "source_head"), str(out))
    assert result.returncode == 0, result.stderr
    converted = gzip.open(out, "rt").read().splitlines()
    shipped = gzip.open(REVS / "lap.csv.gz", "rt").read().splitlines()
    assert len(converted) == 201
    assert converted == shipped[:201]


def test_a_source_folder_with_files_of_unequal_length_is_one_line(tmp_path: Path):
    source = tmp_path / "source"
    source.mkdir()
    for path in (REVS / "source_head").iterdir():
        lines = path.read_text().splitlines()
        (source / path.name).write_text("\n".join(lines[:-1] if path.name == "vy.txt" else lines) + "\n")
    result = _run(str(source), str(tmp_path / "out.csv.gz"))
    assert result.returncode == 1
    assert result.stderr.strip().count("\n") == 0
    assert "differ in length" in result.stderr and "vy.txt 199" in result.stderr
    assert not (tmp_path / "out.csv.gz").exists()


def test_the_shipped_lap_is_a_log_with_its_reference(revs_lap):
    assert len(revs_lap) == 55001
    assert revs_lap.sample_time == np.float64(revs_lap.sample_time) and abs(revs_lap.sample_time - 0.01) < 1e-9
    beta = np.arctan2(revs_lap["vy_ref"], revs_lap["vx_ref"])
    assert np.max(np.abs(beta - revs_lap["beta_ref"])) < 1e-6
    # the INS yaw rate turns with the path: positive left (ISO 8855), as a_y / v_x
    assert np.corrcoef(revs_lap["r"], revs_lap["ay"] / revs_lap["vx"])[0, 1] > 0.95


def test_the_unit_check_accepts_the_real_lap_with_a_first_guess_file_that_oversteers(revs_lap, revs_car):
    """The base file's guessed stiffnesses (100 kN/rad each, a ahead of b) make the linear model
    oversteer and diverge above 48 m/s; the delta relation must not call that a unit error."""
    from vsegen.harness.physics.units import check_units
    from vsegen.model.bicycle import stability_factor

    assert stability_factor(revs_car.vehicle) < 0
    assert check_units(revs_lap, revs_car.vehicle) == []


def test_an_estimator_that_needs_wheel_speeds_says_why_and_what_runs_instead(revs_lap, revs_car):
    """The lap has no wheel speeds: the unscented filters refuse in one line that says why and names
    the estimators that run without them."""
    from vsegen.harness.host.run_log import run_estimator
    from vsegen.harness.logs.table import LogError

    piece = revs_lap.window(200.0, 201.0)
    with pytest.raises(LogError) as refused:
        run_estimator(revs_car, "ukf", piece)
    message = str(refused.value)
    assert "\n" not in message and "missing column 'omega_fl'" in message and "longitudinal" in message
    assert "kf2dof" in message and "ukf" not in message.split("run ")[-1].split(", or set")[0]
    assert 'longitudinal_force = "free_rolling"' in message
    assert run_estimator(revs_car, "kf2dof", piece)["beta"].shape == (len(piece),)
    free_rolling = revs_car.with_settings("ukf", longitudinal_force="free_rolling")
    assert run_estimator(free_rolling, "ukf", piece)["beta"].shape == (len(piece),)   # the setting it names runs
