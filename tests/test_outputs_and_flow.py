"""Outputs and flow without silent mistakes: estimates in MDF4 carry their units and every command
that reads estimates reads them; forms of a kit never overwrite one another; ``run`` runs the form
that will be flashed; the plot tells holds from the KF mode and marks suspect samples."""

from __future__ import annotations

import numpy as np
import pytest
from asammdf import MDF
from locations import VEHICLES

from vsegen.harness.logs.table import write_log
from vsegen.harness.outputs.estimates import read_estimates
from vsegen.harness.score.plot import state_spans
from vsegen.harness.sim.scenarios import Case

C_CLASS = VEHICLES / "c_class.toml"


@pytest.fixture(scope="module")
def dlc_csv(config, tmp_path_factory):
    path = tmp_path_factory.mktemp("flow") / "dlc.csv"
    write_log(Case.of("dlc").simulate(config, 100.0, 1), path)
    return path


def test_mdf4_estimates_carry_units_and_score_and_plot_read_them(tmp_path, dlc_csv, vsegen):
    """Before, `run --out X.mf4` wrote channels without units and `score`/`plot` refused the file
    ("not a text file")."""
    out = tmp_path / "est.mf4"
    ran = vsegen("run", "--log", dlc_csv, "--estimator", "switching", "--vehicle", C_CLASS, "--out", out)
    assert ran.exit_code == 0, ran.output
    mdf = MDF(out)
    assert {name: str(mdf.get(name).unit) for name in ("beta", "vy", "r", "status")} == {
        "beta": "rad", "vy": "m/s", "r": "rad/s", "status": "-"}
    scored = vsegen("score", "--log", dlc_csv, "--est", out)
    assert scored.exit_code == 0 and "beta (deg)" in scored.stdout, scored.output
    assert vsegen("plot", "--log", dlc_csv, "--est", out, "--out", tmp_path / "p.png").exit_code == 0
    np.testing.assert_allclose(read_estimates(out)["beta"], read_estimates(_csv_estimates(tmp_path, dlc_csv, vsegen))
                               ["beta"], rtol=0, atol=1e-15)


def _csv_estimates(tmp_path, log, vsegen):
    out = tmp_path / "est.csv"
    assert vsegen("run", "--log", log, "--estimator", "switching", "--vehicle", C_CLASS, "--out", out).exit_code == 0
    return out


def test_an_mdf4_estimate_in_other_units_is_converted_or_refused(tmp_path, dlc_csv, vsegen):
    from asammdf import Signal

    est = read_estimates(_csv_estimates(tmp_path, dlc_csv, vsegen))
    for unit, factor in (("deg", np.degrees(1.0)), ("km/h", 1.0)):
        mdf = MDF(version="4.10")
        mdf.append([Signal(est["beta"] * factor, est["t"], name="beta", unit=unit)])
        mdf.save(tmp_path / f"{unit.replace('/', '_')}.mf4", overwrite=True)
    np.testing.assert_allclose(read_estimates(tmp_path / "deg.mf4")["beta"], est["beta"], atol=1e-15)
    result = vsegen("score", "--log", dlc_csv, "--est", tmp_path / "km_h.mf4")
    assert result.exit_code == 2 and "channel 'beta' unit = 'km/h': expected a unit of angle" in result.stderr


def test_forms_of_a_kit_never_overwrite_one_another(tmp_path, vsegen):
    """Before, a second `generate` with another --real/--params replaced the first kit."""
    base = ["generate", "--vehicle", C_CLASS, "--estimator", "kf2dof", "--out", tmp_path]
    for form in ((), ("--real", "float"), ("--real", "double", "--params", "calibratable")):
        assert vsegen(*base, *form).exit_code == 0
    kits = sorted(p.name for p in (tmp_path / "c_class").iterdir())
    assert kits == ["kf2dof", "kf2dof-double-calibratable", "kf2dof-float-baked", "kf2dof-float-calibratable"]
    header = (tmp_path / "c_class" / "kf2dof-float-baked" / "vse_kf2dof_kernel.h").read_text()
    assert "#define casadi_real float" in header
    assert (tmp_path / "c_class" / "kf2dof-double-calibratable" / "vse_kf2dof.a2l").exists()


def test_run_runs_the_form_that_will_be_flashed(tmp_path, dlc_csv, vsegen):
    runs = {}
    for form in (("--real", "double"), ("--real", "float", "--params", "calibratable")):
        out = tmp_path / f"{form[1]}.csv"
        result = vsegen("run", "--log", dlc_csv, "--estimator", "kf2dof", "--vehicle", C_CLASS, *form, "--out", out)
        assert result.exit_code == 0, result.output
        runs[form[1]] = read_estimates(out)
    assert "float, calibratable" in " ".join(result.stdout.split())
    difference = np.abs(runs["float"]["beta"] - runs["double"]["beta"])
    assert 0 < difference.max() < 1e-4        # float rounding, nothing else
    refused = vsegen("run", "--log", dlc_csv, "--estimator", "kf2dof", "--backend", "reference", "--real", "float",
                     "--out", tmp_path / "x.csv")
    assert refused.exit_code == 2 and "expected --backend c" in refused.stderr


def test_the_plot_tells_holds_from_the_kf_mode(tmp_path, config, vsegen):
    """Before, a hold (mode reset to the KF) was shaded as 'dynamic scheme (KF)'."""
    log_path, est_path = tmp_path / "bad.csv", tmp_path / "est.csv"
    write_log(Case.of("invalid_inputs").simulate(config, 100.0, 1), log_path)
    ran = vsegen("run", "--log", log_path, "--estimator", "switching", "--out", est_path, "--no-unit-check")
    assert ran.exit_code == 0, ran.output
    spans = state_spans(read_estimates(est_path))
    kf, hold = spans[("dynamic scheme (KF)", "tab:green")], spans[("hold (low speed or invalid input)", "0.5")]
    assert hold.any() and kf.any() and not (kf & hold).any()


def test_score_and_plot_read_every_format_run_writes(tmp_path, vsegen, dlc_csv):
    tables = {}
    for suffix in (".csv", ".mf4", ".parquet"):
        est = tmp_path / f"est{suffix}"
        assert vsegen("run", "--log", dlc_csv, "--estimator", "switching", "--out", est).exit_code == 0
        result = vsegen("score", "--log", dlc_csv, "--est", est)
        assert result.exit_code == 0, result.stderr
        tables[suffix] = [line for line in result.stdout.splitlines() if "beta (deg)" in line]
    assert tables[".csv"] and tables[".csv"] == tables[".mf4"] == tables[".parquet"]
    result = vsegen("plot", "--log", dlc_csv, "--est", tmp_path / "est.parquet", "--est", tmp_path / "est.mf4",
                    "--out", tmp_path / "fig.png")
    assert result.exit_code == 0, result.stderr
    (tmp_path / "bad.parquet").write_text("t,beta\n0,0\n")
    result = vsegen.process("score", "--log", str(dlc_csv), "--est", str(tmp_path / "bad.parquet"))
    assert result.exit_code == 2 and "bad.parquet: not a Parquet file" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_a_run_builds_its_estimator_once(tmp_path, dlc_csv, vsegen, monkeypatch):
    """Before, `run` built the estimator four times (its inputs, the stream, the C, the kit)."""
    from vsegen.model import estimators

    built = []
    real_build = estimators.build_fresh
    monkeypatch.setattr(estimators, "build_fresh", lambda *args: built.append(args[:1] + args[2:]) or real_build(*args))
    monkeypatch.setattr(estimators, "_built", type(estimators._built)())
    assert vsegen("run", "--log", dlc_csv, "--estimator", "switching", "--out", tmp_path / "e.csv").exit_code == 0
    assert built == [("switching", "baked")]
