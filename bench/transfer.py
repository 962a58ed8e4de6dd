"""Transfer protocol: settings tuned on one truth car, scored on the other, for every sideslip
estimator; and which estimator is best where.

For each car A and estimator, ``vsegen tune`` searches the estimator's tunable settings on A's
test-track training set (bench.tuning.PROTOCOLS[0]); the tuned values are then written into car B's own file
(B's identified car-specific settings stay) and scored on B's hold-out (that protocol's,
never searched on). β RMSE in degrees, mean over the hold-out seeds.

    python -m bench.transfer [--trials N] [--scheduler ADDRESS]
"""

from __future__ import annotations

import argparse

from bench import VEHICLES
from bench.tuning import CARS, HOLDOUT_SEEDS, PROTOCOLS, SEED, TRIALS
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.tune.search import DEGREES, objective_value, settings_text, tune
from vsegen.model.estimators import build
from vsegen.model.params import parse_vehicle


def sideslip_estimators(config) -> list[str]:
    return [name for name in config.estimators if "beta" in build(name, config).outputs.names]


TRAINING, HOLDOUT = PROTOCOLS[0].training, PROTOCOLS[0].holdout


def table(scheduler: str | None = None, trials: int = TRIALS) -> list[str]:
    """Markdown lines: per estimator and scored car, hold-out β RMSE with the car's shipped
    settings, tuned on the same car, and tuned on the other car; then the best per column. The
    tuned settings are the search's choice, whether or not ``vsegen tune`` would have written them."""
    configs = {car: load_vehicle(VEHICLES / f"{car}.toml") for car in CARS}
    texts = {car: (VEHICLES / f"{car}.toml").read_text() for car in CARS}
    rate = {car: 1.0 / configs[car].sample_time for car in CARS}
    train = {car: [case.simulate(configs[car], rate[car], 1) for case in TRAINING] for car in CARS}
    holdout = {car: [HOLDOUT.simulate(configs[car], rate[car], seed) for seed in HOLDOUT_SEEDS] for car in CARS}
    names = [n for n in sideslip_estimators(configs[CARS[0]]) if n in configs[CARS[1]].estimators]
    scores: dict[tuple[str, str], dict[str, float]] = {}
    for name in names:
        tuned = {car: tune(texts[car], configs[car], name, train[car], [], trials, seed=SEED,
                           scheduler=scheduler).best.point for car in CARS}
        for scored in CARS:
            row = {"shipped": objective_value(configs[scored], name, holdout[scored])}
            for source in CARS:
                text = settings_text(texts[scored], name, configs[scored], tuned[source])
                config = parse_vehicle(text, f"{scored}+{source}.toml", scored)
                row[source] = objective_value(config, name, holdout[scored])
            scores[(name, scored)] = row
    lines = [f"Tuned on each car's training set ({', '.join(c.label for c in TRAINING)}, seed 1; "
             f"{trials} trials, search seed {SEED}), scored on the other car's and its own hold-out "
             f"{HOLDOUT.label} (seeds {', '.join(map(str, HOLDOUT_SEEDS))}); the scored car keeps its own "
             "identified car-specific settings. β RMSE (°).", ""]
    header = "| estimator | " + " | ".join(f"on {scored}: shipped | tuned on {scored} | tuned on "
                                          f"{_other(scored)}" for scored in CARS) + " |"
    lines += [header, "|---|" + "---|" * (3 * len(CARS))]
    for name in names:
        cells = []
        for scored in CARS:
            row = scores[(name, scored)]
            cells += [f"{row['shipped'] * DEGREES:.3f}", f"{row[scored] * DEGREES:.3f}",
                      f"{row[_other(scored)] * DEGREES:.3f}"]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", "Best estimator per column:", ""]
    for scored in CARS:
        for column in ("shipped", scored, _other(scored)):
            best = min(names, key=lambda n: scores[(n, scored)][column])
            label = "shipped settings" if column == "shipped" else f"tuned on {column}"
            lines.append(f"* on {scored}, {label}: {best} ({scores[(best, scored)][column] * DEGREES:.3f}°)")
    return lines


def _other(car: str) -> str:
    return next(c for c in CARS if c != car)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=TRIALS)
    parser.add_argument("--scheduler", default=None)
    args = parser.parse_args(argv)
    print("\n".join(table(args.scheduler, args.trials)))


if __name__ == "__main__":
    main()
