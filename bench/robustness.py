"""Real roads and real sensors: every sideslip estimator under every disturbance, on both truth
cars and the core manoeuvres, plus the road scenarios. Per run: beta RMSE and max (deg), the
longest stretch of |beta error| > 2 deg with status 0 (s; "never silently wrong" allows 0.5 s),
and, for a fault that starts at a known time, the time from its start to the first non-zero
status (s). Seed 1, the shipped vehicle files (some of their settings were chosen on these runs).

    python -m bench.robustness [--scheduler local|serial|ADDRESS]

Writes docs/robustness.md; the runs go to the Dask cluster like bench.accuracy's.
"""

from __future__ import annotations

import math

import numpy as np

from bench import REPO
from bench.document import provenance, write_cluster_report
from bench.silent import MODEL_BASED
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.jobs.pool import DaskPool
from vsegen.harness.logs.table import SPIN_SIDESLIP
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.score.metrics import SILENT_DURATION, errors, silent_error_time, worse_than_zero
from vsegen.harness.sim.scenarios import Case
from vsegen.model.estimators import DEFINITIONS

CARS = ("c_class", "rwd_saloon")
SEED = 1
OUT = REPO / "docs" / "robustness.md"
FAULT_AT = 3.0
"""s: when the faults with an onset start (after the step steer's step at 1 s, inside the DLCs)."""

DISTURBANCES: dict[str, dict] = {
    "none": {},
    "bank 3°": {"bank": 100.0 * math.tan(math.radians(3.0))},
    "a_y offset 0.5 m/s²": {"ay_offset": 0.5},
    "a_y offset 0.5 m/s² from 3 s": {"ay_offset": 0.5, "offset_time": FAULT_AT},
    "gyro bias 0.3°/s + drift": {"gyro_bias": math.radians(0.3), "gyro_drift": 0.001},
    "steering offset 0.2°": {"steer_offset": math.radians(0.2)},
    "IMU misaligned 1° roll, 1° yaw": {"mount_roll": math.radians(1.0), "mount_yaw": math.radians(1.0)},
    "latency δ 20 ms, a_y and r 40 ms": {"latency": "delta:0.02,ay:0.04,r:0.04"},
    "quantised δ, a_y, r": {"quantise": "delta:0.0002,ay:0.03,r:0.002"},
    "spikes r 3 × 0.5 rad/s": {"spikes": "r:3x0.5"},
    "r factor × 1.3 (a DBC typo)": {"scale": "r:1.3"},
    "r frozen 1.5 s from 3 s": {"freeze": f"r:{FAULT_AT}:1.5"},
    "a_y frozen 1.5 s from 3 s": {"freeze": f"ay:{FAULT_AT}:1.5"},
    "δ frozen 1.5 s from 3 s": {"freeze": f"delta:{FAULT_AT}:1.5"},
    "δ frozen 2 s from 3 s": {"freeze": f"delta:{FAULT_AT}:2"},
    "every input lost 0.5 s from 3 s": {"dropout": f"all:{FAULT_AT}:0.5"},
    "+300 kg, 0.5 m behind the CG": {"mass_added": 300.0, "cg_shift": 0.5},
    "tyres −20 %": {"tyre_scale": 0.8},
    "tyres +20 %": {"tyre_scale": 1.2},
}
"""The disturbances of the matrix (options of harness.sim.disturbances) by their report name."""

FAULTS_WITH_ONSET = ("from 3 s",)
"""Report names of the disturbances that start at FAULT_AT (the others are there throughout)."""

MANOEUVRES = (Case.of("dlc", speed_kmh=80.0), Case.of("continuous_dlc"), Case.of("step_steer"))
ROADS = (Case.of("banked_curve"), Case.of("crossfall_lane_change"), Case.of("dlc", speed_kmh=80.0, bank=5.0),
         Case.of("downhill_brake_curve"), Case.of("crest_dip"))


COPING = [
    "How the shipped estimators cope (docs/estimators.md has the equations and the figures):", "",
    "* every model-based one (kf2dof, switching, fusion, ekf_rls, ukf, aukf) checks its inputs "
    "(model/input_monitors.py): a_x, a_y or r repeated bit for bit and a steer angle that stands "
    "still while the car turns (2048 INPUT_FROZEN), a_y against r·v_x in quasi-steady driving "
    "(8192 LATERAL_INCONSISTENT: a bank or an offset), the steering-angle zero learned in straight "
    "driving (16384 STEERING_OFFSET), and where it reads wheel speeds (ukf, aukf) or is given them "
    "for the check (switching and ekf_rls, which integrate r) the yaw rate against the non-driven "
    "wheels (32768 YAW_RATE_MISMATCH: a gyro offset, drift or a yaw-rate scale typed wrong in a "
    "DBC); ekf_rls learns no stiffness while "
    "any of them is raised;",
    "* switching and fusion learn the kinematic offset c of a bank or an accelerometer offset in "
    "near-straight driving, integrate a_y − r·v_x − c and let their KF take 0.4 c off its a_y "
    "(a bank and an offset cannot be told apart from a_y and r; 0.4 balances their worst cases); "
    "switching bounds its kinematic dwell (64), fusion flags its schemes parting (4096);",
    "* fusion pulls its integrator to a KF with saturating tyres within 0.2 s (k_c = 5/s), so a bank, "
    "an offset or a wrong yaw-rate scale cannot carry its output; kf2dof, fusion, ukf and aukf flag |a_y| "
    "beyond 4 m/s², ekf_rls, whose stiffness follows the tyres, beyond 6 m/s² (256 BEYOND_LINEAR_RANGE: "
    "β rests on the friction or the stiffness the model assumes), kf2dof for 0.2 s and ukf for 0.3 s "
    "after |a_y| fell back, while their estimate recovers from the limit;",
    "* kf2dof and fusion let their KF's process noise grow with |a_y| (process_noise_load): quiet in "
    "straight driving, so a fault their monitors need 0.3 s to see (a steering angle frozen in a "
    "reversal) costs less than answering β = 0;",
    "* the particle filters integrate v_y without a measurement and flag it (1024 DEAD_RECKONING): "
    "under a bank or an offset they are 3–15° off, and say so.",
    "",
    "Each option costs instructions: docs/benchmarks.md, \"What the real-road options cost\".",
]
"""The report's summary of what each estimator does against the disturbances."""


def matrix() -> list[tuple[str, str, Case]]:
    """(car, disturbance name, case) of every run of the report."""
    runs = [(car, name, Case.of(m.scenario, **dict(m.options), **options))
            for car in CARS for m in MANOEUVRES for name, options in DISTURBANCES.items()]
    return runs + [(car, "road", case) for car in CARS for case in ROADS]


def run_case(car: str, disturbance: str, case: Case) -> dict[str, dict[str, float]]:
    """Per sideslip estimator: beta RMSE and max (deg), longest silent stretch (s), time to the
    first status after the fault (s; inf: never; nan: no onset), and where it is not better than
    answering beta = 0, its unflagged RMSE and the bound (deg; else None). One cluster job."""
    config = load_vehicle(REPO / "vehicles" / f"{car}.toml")
    log = case.simulate(config, 1.0 / config.sample_time, SEED)
    onset = FAULT_AT if any(key in disturbance for key in FAULTS_WITH_ONSET) else math.nan
    scored = ~np.maximum.accumulate(np.abs(log["beta_ref"]) > SPIN_SIDESLIP)
    result = {}
    for name in DEFINITIONS:
        estimates = run_estimator(config, name, log)
        if "beta" not in estimates:
            continue
        e = np.rad2deg(errors(estimates["beta"][scored], log["beta_ref"][scored]))
        flagged = (log["t"] >= onset) & (estimates["status"] != 0)
        result[name] = {
            "rmse": float(np.sqrt(np.mean(e * e))), "max": float(np.abs(e).max()),
            "silent": silent_error_time(log, estimates)[0], "spun": log.notes.get("spun", "no"),
            "worse": (None if (worse := worse_than_zero(log, estimates)) is None else tuple(np.rad2deg(worse))),
            "to_status": (float(log["t"][np.argmax(flagged)] - onset) if flagged.any() else math.inf)
            if not math.isnan(onset) else math.nan,
        }
    return result


def _cell(row: dict[str, float]) -> str:
    silent = row["silent"]
    text = f"{row['rmse']:.2f} / {row['max']:.1f} / " + (f"**{silent:.2f}**" if silent > SILENT_DURATION
                                                          else f"{silent:.2f}")
    if not math.isnan(row["to_status"]):
        text += " / " + ("never" if math.isinf(row["to_status"]) else f"{row['to_status']:.2f}")
    return text


def report(scheduler: str | None) -> list[str]:
    runs = matrix()
    with DaskPool(scheduler) as cluster:
        results = cluster.map(run_case, runs)
    names = list(results[0])
    lines = ["# Real roads and real sensors", "",
             f"{provenance('python -m bench.robustness')}. Every sideslip estimator under each "
             "disturbance (`harness/sim/disturbances.py`, docs/scenarios.md) on the core manoeuvres "
             "and on the road scenarios; truth plant `harness/sim`, sensor-noise seed 1, the shipped "
             "vehicle files; some of their settings were chosen on these runs (docs/estimators.md says which), so "
             "the counts are not a hold-out score.", "",
             "Each cell: β RMSE (°) / β max |error| (°) / longest stretch of |β error| > 2° with "
             f"status 0 (s; **bold** beyond {SILENT_DURATION} s: silently wrong) / for a fault that "
             f"starts at {FAULT_AT:g} s, the time from its start to the first non-zero status (s; "
             "'never': no status bit). Samples from a spin on (|β| > 15°) are not scored.", "",
             *COPING, ""]
    for car in CARS:
        lines += [f"## {car}", "", "| manoeuvre | disturbance | " + " | ".join(names) + " |",
                  "|---|---|" + "---|" * len(names)]
        for (run_car, disturbance, case), row in zip(runs, results):
            if run_car == car:
                shown = case.scenario if disturbance != "road" else case.label
                spun = next(iter(row.values()))["spun"]
                if spun != "no":
                    shown += f" (the car spun: {spun.removeprefix('yes ')})"
                lines.append(f"| {shown} | {disturbance} | " + " | ".join(_cell(row[n]) for n in names) + " |")
        lines.append("")
    silent = sorted({(car, d, c.label, n) for (car, d, c), row in zip(runs, results)
                     for n in names if row[n]["silent"] > SILENT_DURATION})
    lines += ["## Where the rule does not hold yet", "",
              f"{len(silent)} of {len(runs) * len(names)} runs have a silent stretch beyond "
              f"{SILENT_DURATION} s:", ""]
    lines += [f"* {car}, {label}: {name}" for car, _, label, name in silent]
    worse = [f"* {car}, {case.label}, {disturbance}: {n} ({row[n]['worse'][0]:.2f}° unflagged, bound "
             f"{row[n]['worse'][1]:.2f}°)" for (car, disturbance, case), row in zip(runs, results)
             for n in names if n in MODEL_BASED and row[n]["worse"] is not None]
    lines += ["", "## Better than answering β = 0", "",
              f"Every model-based estimate ({', '.join(MODEL_BASED)}) must score a β RMSE within 0.7 × "
              "RMS(β_ref), or 0.1°, over the run, or else over its samples with status 0 (the status "
              "covers where it does not; `harness.score.metrics.worse_than_zero`, as in docs/silent.md). "
              f"{len(worse)} of {len(runs) * len([n for n in names if n in MODEL_BASED])} runs break it"
              + (":" if worse else "."), "", *worse]
    return lines


def main(argv: list[str] | None = None) -> None:
    write_cluster_report(__doc__.splitlines()[0], OUT, report, argv)


if __name__ == "__main__":
    main()
