"""The new-car protocol on both truth cars: settings as shipped (c_class: reviewed by hand;
rwd_saloon: from ``vsegen identify`` on ordinary driving without ground truth), then ``vsegen tune``
on a training set of test-track manoeuvres with ground truth, scored on a held-out continuous DLC
that the search never saw.

    python -m bench.tuning [--trials N] [--scheduler ADDRESS]
"""

from __future__ import annotations

import argparse

from bench import VEHICLES
from vsegen.harness.project.vehicles import load_vehicle, with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.harness.tune.search import DEGREES, objective_value, tune
from vsegen.model.params import parse_vehicle

CARS = ("c_class", "rwd_saloon")
ESTIMATORS = ("switching", "kf2dof", "ekf_rls")
TRAINING = (Case.of("dlc", speed_kmh=80.0, mu=1.0), Case.of("step_steer"), Case.of("sine_steer"),
            Case.of("fishhook"))
"""Test-track manoeuvres with an optical beta reference (seed 1)."""
HOLDOUT = Case.of("continuous_dlc", speed_kmh=80.0)
"""At seed 000's 120 km/h the near-neutral rear-wheel-drive saloon spins in the mu = 0.35 section
(the plant has no stability control); at 80 km/h both cars stay in the cones."""
HOLDOUT_SEEDS = (1, 2, 3)
TRIALS = 40
SEED = 1


def copied_file(config):
    """What a user has before identify: the C-class file with ``config``'s mass, geometry and I_z
    (the C-class's stiffnesses, roll gradient and noise settings)."""
    own = ("mass", "yaw_inertia", "cg_to_front_axle", "cg_to_rear_axle", "wheelbase", "wheel_radius",
           "track_width", "cg_height")
    text = with_settings((VEHICLES / "c_class.toml").read_text(), "vehicle", **{k: config.vehicle[k] for k in own})
    return parse_vehicle(text, "copied.toml", config.name)


def table(scheduler: str | None = None, trials: int = TRIALS) -> list[str]:
    """Markdown lines: per car and estimator, β RMSE (°) on training and hold-out, before and after."""
    lines = [f"Training set: {', '.join(c.label for c in TRAINING)} (seed 1, with β reference); hold-out: "
             f"{HOLDOUT.label}, seeds {', '.join(map(str, HOLDOUT_SEEDS))} (never searched on). `vsegen tune` "
             f"objective rmse (a log is scored up to a spin, |β| > 15°), "
             f"{trials} trials, search seed {SEED}, batch 8; every candidate ran the "
             "calibratable generated C. \"before\" = the vehicle file as shipped (rwd_saloon: roll gradient, "
             "stiffnesses and noise from `vsegen identify`, other settings the C-class's).",
             "",
             "| car | estimator | hold-out β RMSE, C-class file with the car's mass and geometry (°) | training β RMSE "
             "before (°) | after (°) | hold-out β RMSE before (°) | after (°) |",
             "|---|---|---|---|---|---|---|"]
    for car in CARS:
        path = VEHICLES / f"{car}.toml"
        config = load_vehicle(path)
        rate = 1.0 / config.sample_time
        train = [case.simulate(config, rate, 1) for case in TRAINING]
        holdout = [HOLDOUT.simulate(config, rate, seed) for seed in HOLDOUT_SEEDS]
        copied = copied_file(config)
        for name in ESTIMATORS:
            result = tune(path.read_text(), config, name, train, holdout, trials, seed=SEED, scheduler=scheduler)
            naive = "-" if car == "c_class" else f"{objective_value(copied, name, holdout) * DEGREES:.3f}"
            lines.append(f"| {car} | {name} | {naive} | {result.baseline_train * DEGREES:.3f} | "
                         f"{result.tuned_train * DEGREES:.3f} | {result.baseline_holdout * DEGREES:.3f} | "
                         f"{result.tuned_holdout * DEGREES:.3f} |")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=TRIALS)
    parser.add_argument("--scheduler", default=None)
    args = parser.parse_args(argv)
    print("\n".join(table(args.scheduler, args.trials)))


if __name__ == "__main__":
    main()
