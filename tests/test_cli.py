"""The vsegen command line: main job, one-line errors, stale-folder detection."""

from __future__ import annotations

import json
import re

import pytest
from junit_reports import read_junit
from junitparser import Properties
from locations import DEFAULT_VEHICLE, REPO

from vsegen.harness.sim.scenarios import VERIFICATION_SET


@pytest.mark.slow
def test_verify_default_vehicle_prints_table(vsegen):
    """The command end to end on two estimators (every estimator of the default vehicle is verified
    in this form by tests/test_equivalence.py and tests/test_pf_adaptive_pf_improved.py)."""
    result = vsegen.process("verify", "--real", "double", "--params", "baked", "--estimator", "kf2dof",
                            "--estimator", "switching")
    assert result.exit_code == 0, result.stderr
    assert f"verify passed: {2 * len(VERIFICATION_SET)} runs in 1 form(s)" in result.stdout


def test_verify_compiles_the_checked_in_c_and_fails_first_on_an_edit(tmp_path, vsegen):
    """A kernel constant multiplied by 1.01 in the project's generated/: verify fails before any
    run, with the diff and the command that regenerates the folder; a form never generated too."""
    (tmp_path / "vehicles").mkdir()
    (tmp_path / "vehicles" / "c_class.toml").write_text(DEFAULT_VEHICLE.read_text())
    assert vsegen.process("generate", "--estimator", "kf2dof", cwd=tmp_path).exit_code == 0
    kernel = tmp_path / "generated" / "c_class" / "kf2dof" / "vse_kf2dof_kernel.c"
    text = kernel.read_text()
    line = re.search(r"\n(\s*a\d+=)(\d\.\d+e[+-]\d+);", text)
    kernel.write_text(text.replace(line.group(0), f"\n{line.group(1)}{float(line.group(2)) * 1.01!r};", 1))
    result = vsegen.process("verify", "--estimator", "kf2dof", cwd=tmp_path)
    assert result.exit_code == 1 and "verifying" not in result.stderr
    assert f"+{line.group(1)}{line.group(2)};" in result.stdout        # the diff back to the generated line
    assert ("generated/c_class/kf2dof differs from what" in result.stderr
            and "run `vsegen generate --vehicle" in result.stderr and "--estimator kf2dof`" in result.stderr)
    missing = vsegen.process("verify", "--estimator", "switching", cwd=tmp_path)
    assert missing.exit_code == 1 and "generated/c_class/switching is missing" in missing.stderr


@pytest.mark.slow      # 35 s (verify runs two forms on every scenario); the default suite keeps generate --check
def test_a_form_generated_once_is_declared_then_regenerated_checked_and_verified(tmp_path, vsegen):
    (tmp_path / "vehicles").mkdir()
    vehicle = tmp_path / "vehicles" / "c_class.toml"
    vehicle.write_text(re.sub(r"\nforms = \[[^\]]*\]", "", DEFAULT_VEHICLE.read_text()))
    generated = vsegen.process("generate", "--estimator", "kf2dof", "--real", "float", "--params", "baked",
                               cwd=tmp_path)
    assert generated.exit_code == 0, generated.stderr
    assert "declared    kf2dof:float-baked in vehicles/c_class.toml [codegen] forms" in generated.stdout
    assert 'forms = ["kf2dof:float-baked"]' in vehicle.read_text()
    assert vsegen.process("generate", "--estimator", "kf2dof", cwd=tmp_path).exit_code == 0
    check = vsegen.process("generate", "--check", "--estimator", "kf2dof", cwd=tmp_path)
    assert check.exit_code == 0 and "up to date  generated/c_class/kf2dof-float-baked" in check.stdout
    verified = vsegen.process("verify", "--estimator", "kf2dof", cwd=tmp_path)
    assert verified.exit_code == 0, verified.stderr
    assert f"verify passed: {2 * len(VERIFICATION_SET)} runs in 2 form(s)" in verified.stdout
    vehicle.write_text(vehicle.read_text().replace("mass = 1412.0", "mass = 1500.0"))
    stale = vsegen.process("generate", "--check", "--estimator", "kf2dof", cwd=tmp_path)
    assert stale.exit_code == 1 and "generated/c_class/kf2dof-float-baked" in stale.stderr
    assert vsegen.process("generate", "--estimator", "kf2dof", cwd=tmp_path).exit_code == 0
    assert vsegen.process("generate", "--check", "--estimator", "kf2dof", cwd=tmp_path).exit_code == 0


def test_generate_check_is_clean_on_the_repository_and_reports_each_folder(vsegen, tmp_path):
    junit, data = tmp_path / "generate.xml", tmp_path / "generate.json"
    result = vsegen.process("generate", "--check", "--junit", str(junit), "--json", str(data))
    assert result.exit_code == 0, result.stdout + result.stderr
    for folder in ("c_class/kf2dof", "c_class/kf2dof-float-calibratable",
                   "c_class/pf_improved-float-baked", "ev_seed002/aukf"):
        assert f"up to date  generated/{folder}\n" in result.stdout
    folders = sorted(p for vehicle in (REPO / "generated").iterdir() for p in vehicle.iterdir() if p.is_dir())
    cases = {(suite.name, case.name): case for suite in read_junit(junit) for case in suite}
    assert len(cases) == len(folders) and all(case.is_passed for case in cases.values())
    form = cases[("c_class.kf2dof.float-calibratable", "generated/c_class/kf2dof-float-calibratable")]
    assert {p.name: p.value for p in next(form.iterchildren(Properties))} == {
        "vehicle": "c_class", "estimator": "kf2dof", "real": "float", "params": "calibratable", "files": "11",
        "files_differing": "0"}
    assert json.loads(data.read_text())["ok"]


def test_generate_then_check_detects_an_edit(tmp_path, vsegen):
    assert vsegen.process("generate", "--out", str(tmp_path)).exit_code == 0
    target = tmp_path / "c_class" / "kf2dof" / "vse_kf2dof.h"
    target.write_text(target.read_text().replace("(0.01)", "(0.02)"))
    (tmp_path / "c_class" / "removed_estimator").mkdir()       # left over from an older tree
    result = vsegen.process("generate", "--check", "--out", str(tmp_path))
    assert result.exit_code == 1
    assert "-#define VSE_KF2DOF_SAMPLE_TIME (0.02)" in result.stdout
    assert "stale" in result.stderr
    assert "removed_estimator: no vehicle file or estimator generates this folder" in result.stderr


@pytest.mark.parametrize("args,fragment", [
    (["verify", "--estimator", "nope"], "unknown estimator 'nope'"),
    (["generate", "--vehicle", "missing.toml"], "missing.toml: cannot read vehicle file"),
])
def test_user_errors_are_one_line(args, fragment, vsegen):
    result = vsegen.process(*args)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in result.stderr


def test_bad_vehicle_file_is_one_line(tmp_path, vsegen):
    bad = tmp_path / "bad.toml"
    bad.write_text((REPO / "vehicles" / "c_class.toml").read_text().replace("mass = 1412.0", "mass = -1"))
    result = vsegen.process("verify", "--vehicle", str(bad))
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1
    assert f"{bad}:5: [vehicle] mass = -1: expected a number from 10 to 100000 (kg)" in result.stderr


def test_list(vsegen):
    result = vsegen.process("list")
    assert result.exit_code == 0 and "kf2dof" in result.stdout and "dlc" in result.stdout
    text = " ".join(result.stdout.split())                      # rich may wrap long lines
    assert "[options: mu=0.85 v_start=12.5" in text and "yaw_moment=0.0]" in text
    assert "bank=0.0 (% cross slope, 3 % = 1.7 deg)" in text and "freeze= (channel:start s:duration s)" in text


def test_simulate_run_score_plot(tmp_path, vsegen):
    log, est, ref, fig = (tmp_path / n for n in ("log.csv", "est.csv", "ref.csv", "fig.png"))
    result = vsegen.process("simulate", "dlc", "--set", "speed_kmh=100", "--seed", "2", "--out", str(log))
    assert result.exit_code == 0, result.stderr
    assert "stayed in cones" in " ".join(result.stdout.split())          # rich may wrap long lines
    for backend, out in (("c", est), ("reference", ref)):
        result = vsegen.process("run", "--log", str(log), "--estimator", "kf2dof", "--backend", backend,
                                "--out", str(out))
        assert result.exit_code == 0, result.stderr
    header = est.read_text().splitlines()[0]
    assert header == "t,beta,vy,r,status"
    result = vsegen.process("score", "--log", str(log), "--est", str(est))
    assert result.exit_code == 0 and "beta (deg)" in result.stdout and "RMSE" in result.stdout
    result = vsegen.process("plot", "--log", str(log), "--est", str(est), "--est", str(ref), "--out", str(fig))
    assert result.exit_code == 0, result.stderr
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_run_at_another_rate_generates_for_it(tmp_path, vsegen):
    log, est = tmp_path / "log.csv", tmp_path / "est.csv"
    assert vsegen.process("simulate", "sine_steer", "--rate", "200", "--out", str(log)).exit_code == 0
    result = vsegen.process("run", "--log", str(log), "--estimator", "kf2dof", "--out", str(est))
    assert result.exit_code == 0, result.stderr
    assert "T = 0.005 s" in result.stdout


@pytest.mark.parametrize("args,fragment", [
    (["simulate", "nope", "--out", "x.csv"], "unknown scenario 'nope'"),
    (["simulate", "dlc", "--set", "mu=slippery", "--out", "x.csv", "--vehicle", str(DEFAULT_VEHICLE)],
     "mu = 'slippery': expected a float"),
    (["run", "--log", "missing.csv", "--estimator", "kf2dof", "--out", "x.csv", "--vehicle", str(DEFAULT_VEHICLE)],
     "missing.csv: cannot read"),
    (["verify", "--estimator", "kf2dof"], "no vehicle file in"),
    (["generate"], "no vehicle file in"),
    (["score", "--log", "missing.csv", "--est", "e.csv"], "missing.csv: cannot read"),
])
def test_more_user_errors(tmp_path, args, fragment, vsegen):
    result = vsegen.process(*args, cwd=tmp_path)
    assert result.exit_code == 2, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and fragment in result.stderr
    assert not (tmp_path / "x.csv").exists()


def test_score_rejects_mismatched_files(tmp_path, vsegen):
    a, b, est = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "est.csv"
    assert vsegen.process("simulate", "sine_steer", "--out", str(a)).exit_code == 0
    assert vsegen.process("simulate", "step_steer", "--out", str(b)).exit_code == 0
    assert vsegen.process("run", "--log", str(b), "--estimator", "kf2dof", "--out", str(est)).exit_code == 0
    result = vsegen.process("score", "--log", str(a), "--est", str(est))
    assert result.exit_code == 2 and "expected the same time stamps" in result.stderr


def test_yaw_rate_estimator_from_a_yaw_moment_log_is_scored_and_plotted(tmp_path, vsegen):
    """arx_dual_kf estimates r only: score and plot use the yaw rate; a log with mz feeds it."""
    log, est, fig, bad = (tmp_path / n for n in ("log.csv", "arx.csv", "arx.png", "bad.csv"))
    assert vsegen.process("simulate", "sine_steer", "--set", "yaw_moment=1000", "--out", str(log)).exit_code == 0
    assert "mz" in log.read_text().splitlines()[0].split(",")
    result = vsegen.process("run", "--log", str(log), "--estimator", "arx_dual_kf", "--out", str(est))
    assert result.exit_code == 0, result.stderr
    result = vsegen.process("score", "--log", str(log), "--est", str(est))
    assert result.exit_code == 0 and "r (deg/s)" in result.stdout and "beta" not in result.stdout
    result = vsegen.process("plot", "--log", str(log), "--est", str(est), "--out", str(fig))
    assert result.exit_code == 0, result.stderr
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad.write_text("t,x\n0,1\n0.01,2\n")
    result = vsegen.process("score", "--log", str(log), "--est", str(bad))
    assert result.exit_code == 2 and "no estimated signal: expected a column beta, vy or r" in result.stderr


def test_a_log_at_another_rate_than_the_vehicle_file_is_said_once(tmp_path, vsegen):

    from vsegen.harness.logs.table import write_log
    from vsegen.harness.project.vehicles import load_vehicle
    from vsegen.harness.sim.scenarios import Case

    config = load_vehicle(REPO / "vehicles" / "c_class.toml")
    write_log(Case.of("sine_steer").simulate(config, 200.0, 1), tmp_path / "fast.csv")
    result = vsegen("run", "--log", str(tmp_path / "fast.csv"), "--estimator", "kf2dof",
                    "--out", str(tmp_path / "est.csv"))
    assert result.exit_code == 0, result.output
    said = [line for line in result.stderr.splitlines() if "differs from [estimator] sample_time" in line]
    assert len(said) == 1 and "sample time 0.005 s" in said[0] and "sample_time = 0.01 s" in said[0]


def test_a_road_log_without_reference_is_plotted_with_the_status(tmp_path, vsegen):


    for arguments in (["simulate", "sine_steer", "--no-truth", "--out", str(tmp_path / "road.csv")],
                      ["run", "--log", str(tmp_path / "road.csv"), "--estimator", "kf2dof", "--out",
                       str(tmp_path / "est.csv")],
                      ["plot", "--log", str(tmp_path / "road.csv"), "--est", str(tmp_path / "est.csv"), "--out",
                       str(tmp_path / "road.png")]):
        result = vsegen(*arguments)
        assert result.exit_code == 0, result.output
    assert (tmp_path / "road.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_time_window_runs_scores_and_plots_part_of_a_log(tmp_path, vsegen):

    from vsegen.harness.outputs.estimates import read_estimates

    log, est = str(tmp_path / "dlc.csv"), str(tmp_path / "est.csv")
    assert vsegen("simulate", "dlc", "--out", log).exit_code == 0
    window = ["--from", "2", "--to", "6"]
    for arguments in (["run", "--log", log, "--estimator", "kf2dof", "--out", est, *window],
                      ["score", "--log", log, "--est", est, *window],
                      ["plot", "--log", log, "--est", est, "--out", str(tmp_path / "p.png"), *window]):
        result = vsegen(*arguments)
        assert result.exit_code == 0, result.output
    t = read_estimates(tmp_path / "est.csv")["t"]
    assert t[0] >= 2.0 and t[-1] <= 6.0 and len(t) == 401
    result = vsegen("run", "--log", log, "--estimator", "kf2dof", "--out", str(tmp_path / "x.csv"),
                    "--from", "50")
    assert result.exit_code == 2
    assert "time window 50.0 .. None s holds 0 sample(s): expected at least 2 inside 0 .. " in result.stderr
    assert not (tmp_path / "x.csv").exists()
