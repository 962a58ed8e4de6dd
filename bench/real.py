"""Every sideslip estimator on real data, calibrated by vsegen's own commands on one part of a log and
scored on another, beside the textbook baseline that ships with the data.

    python -m bench.real [--out docs/real.md] [--work DIR]

The Revs lap (data/real/revs_250lm): the first CALIBRATION_SAMPLES samples are the calibration part,
the rest the scoring part; nothing is calibrated on what it is scored on. Calibration:
``vsegen identify`` on the calibration part without its reference columns (what a car without an INS
gets) and with them, then ``vsegen tune`` of the Kalman-filter estimators on the calibration part with
its reference. Every sideslip estimator then runs (``vsegen run``, its generated C) on the
scoring part with each calibrated file and is scored there: beta RMSE and max, the longest stretch
with |beta error| > 2 deg and status 0, and the share of RMS(beta_ref) (an estimate above 0.7 of it
is hardly better than answering beta = 0). The textbook KF (bench.textbook_kf) runs with its
hand-picked and its fitted stiffnesses, its noise from the calibration part.
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from bench import REPO, textbook_kf
from bench.document import provenance
from bench.figures import save_figure
from vsegen.harness.logs.table import Log, read_log, write_log
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.score.metrics import silent_error_time

DATA = REPO / "data" / "real" / "revs_250lm"
CALIBRATION_SAMPLES = 27500
"""The first 275 s of the lap."""
ESTIMATORS = ("kf2dof", "switching", "fusion", "ekf_rls", "ukf", "aukf", "pf_adaptive", "pf_improved")
"""Every estimator with a sideslip output."""
BETTER_THAN_ZERO = 0.7
"""An RMSE above this share of RMS(beta_ref) is hardly better than answering beta = 0."""
CALIBRATIONS = {"no reference": "identified without the reference columns",
                "with reference": "identified with the INS reference columns",
                "tuned": "identified and tuned with the INS reference columns"}
TUNED = ("kf2dof", "switching", "fusion", "ekf_rls")
"""The estimators `vsegen tune` searches on the calibration part (with its reference) after identify."""
TUNE_TRIALS = 200
"""Candidates per tune: 40 (the default) found nothing better than the identified file for switching."""


@dataclass(frozen=True)
class Row:
    """One estimator under one calibration on the scoring part (degrees, seconds)."""

    estimator: str
    calibration: str
    rmse: float | None
    max: float | None
    silent: float | None
    silent_at: float | None
    silent_lap: float | None
    """The longest silent stretch of a run over the whole lap (both parts), s."""
    silent_lap_at: float | None
    flagged: float | None
    why_not: str = ""


def split(lap: Log) -> tuple[Log, Log]:
    """(calibration part, scoring part) of the lap: disjoint, in time order."""
    cut = CALIBRATION_SAMPLES
    return (Log({k: v[:cut] for k, v in lap.columns.items()}, "calibration.csv"),
            Log({k: v[cut:] for k, v in lap.columns.items()}, "scoring.csv"))


def vsegen(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(["vsegen", *args], cwd=cwd, capture_output=True, text=True, check=False)


def identify(work: Path, calibration: Log) -> dict[str, tuple[Path, str]]:
    """Per calibration: (the identified vehicle file, identify's printed lines)."""
    out = {}
    for name, log in (("no reference", calibration.without_truth()), ("with reference", calibration)):
        stem = name.replace(" ", "_")
        write_log(log, work / f"calibration_{stem}.csv")
        done = vsegen("identify", "--log", f"calibration_{stem}.csv", "--vehicle", str(DATA / "car.toml"),
                      "--out", f"car_{stem}.toml", "--report", f"identify_{stem}.md", cwd=work)
        if done.returncode != 0:
            raise SystemExit(f"bench.real: vsegen identify ({name}) failed: {done.stderr.strip()}")
        out[name] = (work / f"car_{stem}.toml", done.stdout)
    return out


def run_estimator(work: Path, vehicle: Path, estimator: str, scoring: Log, calibration: str) -> tuple[Row, Log | None]:
    """An estimator's row and its estimates on the scoring part (None when it cannot run)."""
    out = work / f"{estimator}_{calibration.replace(' ', '_')}.csv"
    done = vsegen("run", "--log", "scoring.csv", "--estimator", estimator, "--vehicle", str(vehicle),
                  "--out", str(out), cwd=work)
    if done.returncode != 0:
        why = done.stderr.strip().splitlines()[-1].removeprefix("vsegen: ").removeprefix("error: ")
        return Row(estimator, calibration, None, None, None, None, None, None, None, why), None
    estimates = read_log(out, required=("t", "beta", "status"), all_numeric=True)
    error = np.degrees(estimates["beta"] - scoring["beta_ref"])
    silent, at = silent_error_time(scoring, estimates)
    whole = work / f"{estimator}_{calibration.replace(' ', '_')}_lap.csv"
    vsegen("run", "--log", str(DATA / "lap.csv.gz"), "--estimator", estimator, "--vehicle", str(vehicle),
           "--out", str(whole), cwd=work).check_returncode()
    silent_lap, lap_at = silent_error_time(read_log(DATA / "lap.csv.gz"),
                                           read_log(whole, required=("t", "beta", "status"), all_numeric=True))
    flagged = float(np.mean(estimates["status"] != 0) * 100)
    return Row(estimator, calibration, float(np.sqrt(np.mean(error**2))), float(np.abs(error).max()),
               silent, at, silent_lap, lap_at, flagged), estimates


def textbook_rows(calibration: Log, scoring: Log, vehicle) -> tuple[list[Row], dict[str, np.ndarray], tuple]:
    sigmas = textbook_kf.noise(calibration)
    fitted = textbook_kf.fitted_stiffness(calibration, vehicle)
    rows, betas = [], {}
    for label, stiffness in (("hand-picked C_f, C_r", textbook_kf.HAND_PICKED), ("fitted C_f, C_r", fitted)):
        beta = textbook_kf.run(scoring, vehicle, stiffness, sigmas)
        error = np.degrees(beta - scoring["beta_ref"])
        rows.append(Row("textbook KF", label, float(np.sqrt(np.mean(error**2))), float(np.abs(error).max()),
                        None, None, None, None, None))
        betas[f"textbook KF, {label}"] = beta
    return rows, betas, fitted


def figure(scoring: Log, curves: dict[str, np.ndarray], out: Path) -> str:
    fig, axes = plt.subplots(2, 1, figsize=(10, 6))
    t = scoring["t"]
    for axis, (start, stop) in zip(axes, ((t[0], t[-1]), (t[0] + 100, t[0] + 130))):
        keep = (t >= start) & (t <= stop)
        axis.plot(t[keep], np.degrees(scoring["beta_ref"][keep]), "k", lw=1.5, label="INS reference")
        for label, beta in curves.items():
            axis.plot(t[keep], np.degrees(beta[keep]), lw=0.8, label=label)
        axis.set_ylabel("beta (deg)")
    axes[1].set_xlabel("t (s)")
    return save_figure(fig, axes, out, "Revs lap, scoring part: sideslip angle (below: 30 s of it)",
                       "beta against the INS reference on the scoring part")


def tune(work: Path, vehicle: Path, estimator: str) -> tuple[Path, str]:
    """(the file `vsegen tune` writes for ``estimator`` from ``vehicle`` on the calibration part with its
    reference, its summary line); the identified file itself when tune refuses (exit 3)."""
    out = work / f"car_tuned_{estimator}.toml"
    done = vsegen("tune", "--estimator", estimator, "--vehicle", str(vehicle), "--log",
                  "calibration_with_reference.csv", "--out", str(out), "--trials", str(TUNE_TRIALS),
                  "--scheduler", "serial", cwd=work)
    if done.returncode == 3:
        return vehicle, f"{estimator}: " + done.stderr.strip().splitlines()[-1].removeprefix("vsegen: ")
    if done.returncode != 0:
        raise SystemExit(f"bench.real: vsegen tune ({estimator}) failed: {done.stderr.strip()}")
    summary = next((line.removeprefix("# ") for line in out.read_text().splitlines() if "cross-validated" in line), "")
    return out, f"{estimator}: {summary}"


def report(work: Path) -> list[str]:
    lap = read_log(DATA / "lap.csv.gz")
    calibration, scoring = split(lap)
    write_log(scoring, work / "scoring.csv")
    base = load_vehicle(DATA / "car.toml")
    identified = identify(work, calibration)
    rows: list[Row] = []
    curves: dict[str, np.ndarray] = {}
    for name, (vehicle, _) in identified.items():
        for estimator in ESTIMATORS:
            row, estimates = run_estimator(work, vehicle, estimator, scoring, name)
            rows.append(row)
            if estimates is not None and estimator in ("kf2dof", "switching") and name == "no reference":
                curves[f"{estimator}, {CALIBRATIONS[name]}"] = estimates["beta"]
    tuned = []
    for estimator in TUNED:
        vehicle, summary = tune(work, identified["with reference"][0], estimator)
        tuned.append(summary)
        row, estimates = run_estimator(work, vehicle, estimator, scoring, "tuned")
        rows.append(row)
        if estimates is not None and estimator == "switching":
            curves[f"{estimator}, {CALIBRATIONS['tuned']}"] = estimates["beta"]
    textbook, betas, fitted = textbook_rows(calibration, scoring, base.vehicle)
    curves.update(betas)
    rms_beta = float(np.degrees(np.sqrt(np.mean(scoring["beta_ref"] ** 2))))
    lines = ["# Real data: the Revs lap", "", provenance("python -m bench.real") + ".", "",
             "Car: Stanford Revs' 1964 Ferrari 250 LM at Thunderhill, one lap session, OxTS INS reference "
             "(data/real/revs_250lm, MIT). Calibration part: the first 275 s (27,500 samples); scoring part: "
             f"the remaining {len(scoring)} samples ({scoring['t'][0]:.2f}..{scoring['t'][-1]:.2f} s). "
             "Nothing is calibrated or tuned on the scoring part. Shipped settings otherwise; the base "
             "vehicle file (data/real/revs_250lm/car.toml) has the car's mass, geometry and I_z, "
             "guessed stiffnesses (100 kN/rad each) and the saturating tyre model in its Kalman filters.", "",
             f"RMS of the reference sideslip on the scoring part: {rms_beta:.2f} deg; an estimate worse than "
             f"{BETTER_THAN_ZERO:g} x that ({BETTER_THAN_ZERO * rms_beta:.2f} deg) is hardly better than "
             "answering beta = 0.", "", "## What identify found on the calibration part", ""]
    for name, (_, printed) in identified.items():
        lines += [f"{CALIBRATIONS[name][0].upper()}{CALIBRATIONS[name][1:]} (`vsegen identify`):", "", "```"]
        lines += [line for line in printed.splitlines() if "stiffness" in line or "friction" in line]
        lines += ["```", ""]
    lines += [f"`vsegen tune` ({TUNE_TRIALS} trials, on the calibration part with its reference, from the file "
              "identified with it):", "", "```", *tuned, "```", ""]
    lines += [f"The textbook KF's fitted stiffnesses (least squares of the reference slip angles, |a_y| < "
              f"{textbook_kf.LINEAR_RANGE:g} m/s^2): C_f = {fitted[0]:.0f} N/rad, C_r = {fitted[1]:.0f} N/rad.", "",
              "## Scores on the scoring part", "",
              "| estimator | calibration | beta RMSE (deg) | share of RMS(beta_ref) | beta max (deg) | "
              "longest silent stretch > 2 deg (s) | the same, whole lap (s) | time flagged (%) |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for row in [*rows, *textbook]:
        calibration_text = CALIBRATIONS.get(row.calibration, row.calibration)
        if row.rmse is None:
            lines.append(f"| {row.estimator} | {calibration_text} | cannot run: {row.why_not} | | | | | |")
            continue
        silent, silent_lap = (stretch(length, at) for length, at in ((row.silent, row.silent_at),
                                                                     (row.silent_lap, row.silent_lap_at)))
        flagged = "-" if row.flagged is None else f"{row.flagged:.1f}"
        lines.append(f"| {row.estimator} | {calibration_text} | {row.rmse:.3f} | {row.rmse / rms_beta:.2f} | "
                     f"{row.max:.2f} | {silent} | {silent_lap} | {flagged} |")
    lines += ["", figure(scoring, curves, REPO / "docs" / "figures" / "real_revs.png"), "", *findings(rows, rms_beta)]
    return lines


def stretch(length: float | None, at: float | None) -> str:
    """A silent stretch as the table shows it: its length in s and, when there is one, its start."""
    if length is None:
        return "-"
    return f"{length:.2f}" + (f" (at {at:.1f} s)" if length > 0 else "")


def findings(rows: list[Row], rms_beta: float) -> list[str]:
    """What the table says against the product's rules: silent stretches over 0.5 s, estimates no
    better than answering beta = 0 while unflagged, estimators that cannot run."""
    silent = [f"{r.estimator} ({CALIBRATIONS[r.calibration]}: {r.silent_lap:.2f} s from {r.silent_lap_at:.1f} s)"
              for r in rows if r.silent_lap is not None and r.silent_lap > 0.5]
    poor = [f"{r.estimator} ({CALIBRATIONS[r.calibration]}: {r.rmse:.2f} deg, flagged {r.flagged:.0f} % of the time)"
            for r in rows if r.rmse is not None and r.rmse > BETTER_THAN_ZERO * rms_beta]
    absent = sorted({f"{r.estimator} ({r.why_not})" for r in rows if r.rmse is None})
    return ["## Against the rules", "",
            "* Silent stretches over 0.5 s on the whole lap (|beta error| > 2 deg, status 0): "
            + ("; ".join(silent) or "none") + ".",
            f"* Worse than {BETTER_THAN_ZERO:g} x RMS(beta_ref): " + ("; ".join(poor) or "none") + ".",
            "* Cannot run: " + ("; ".join(absent) or "none") + "."]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "real.md")
    parser.add_argument("--work", type=Path, default=None, help="Folder for the logs and files (default: temporary).")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as temporary:
        work = args.work or Path(temporary)
        work.mkdir(parents=True, exist_ok=True)
        text = "\n".join(report(work)) + "\n"
    args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
