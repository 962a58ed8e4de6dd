"""The vsegen command line: main job, one-line errors, stale-folder detection."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from harness.paths import REPO


def vsegen(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], cwd=cwd,
                          capture_output=True, text=True)


def test_verify_default_vehicle_prints_table():
    result = vsegen("verify")
    assert result.returncode == 0, result.stderr
    assert "verify passed" in result.stdout
    assert "dlc(speed_kmh=120.0)" in result.stdout and "max rel diff" in result.stdout


def test_generate_check_is_clean_on_the_repository():
    result = vsegen("generate", "--check")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "up to date" in result.stdout


def test_generate_then_check_detects_an_edit(tmp_path):
    assert vsegen("generate", "--out", str(tmp_path)).returncode == 0
    target = tmp_path / "c_class" / "kf2dof" / "vse_kf2dof.h"
    target.write_text(target.read_text().replace("(0.01)", "(0.02)"))
    result = vsegen("generate", "--check", "--out", str(tmp_path))
    assert result.returncode == 1
    assert "-#define VSE_KF2DOF_SAMPLE_TIME (0.02)" in result.stdout
    assert "stale" in result.stderr


@pytest.mark.parametrize("args,fragment", [
    (["verify", "--estimator", "nope"], "unknown estimator 'nope'"),
    (["generate", "--vehicle", "missing.toml"], "missing.toml: cannot read vehicle file"),
])
def test_user_errors_are_one_line(args, fragment):
    result = vsegen(*args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in result.stderr


def test_bad_vehicle_file_is_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text((REPO / "vehicles" / "c_class.toml").read_text().replace("mass = 1412.0", "mass = -1"))
    result = vsegen("verify", "--vehicle", str(bad))
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1
    assert f"{bad}:5: [vehicle] mass = -1: expected a finite number > 0 (kg)" in result.stderr


def test_list():
    result = vsegen("list")
    assert result.returncode == 0 and "kf2dof" in result.stdout and "dlc" in result.stdout
