"""Seed 004 evaluation (the patent reports no figures): yaw-rate error of the ARX dual Kalman
filter against the truth plant, beside the raw gyro and the 2-DOF KF's yaw rate, on scenarios with
a direct yaw moment, with seed 000's gyro outliers and on the continuous DLC's friction steps;
mean ± standard deviation over seeds. Also a plot of the ARX parameters over the continuous DLC
(convergence and the response to the friction changes)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from bench.figures import save_figure
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.model.params import parse_vehicle

NAME = "arx_dual_kf"
CASES = (Case.of("dlc", speed_kmh=80.0, yaw_moment=1000.0),
         Case.of("sine_steer", yaw_moment=1000.0),
         Case.of("dlc", speed_kmh=120.0, outliers=True),
         Case.of("continuous_dlc"),
         Case.of("continuous_dlc", yaw_moment=300.0))
PLOT_CASE = Case.of("continuous_dlc", yaw_moment=300.0)
"""The parameter plot's scenario: friction steps, and yaw-moment pulses that excite b_mz."""


def variants(vehicle_text: str, source: str, name: str):
    """(label, configuration) of the patent form (mz) and the E2 form (mz and delta)."""
    def exogenous(value: str):
        return parse_vehicle(with_settings(vehicle_text, f"estimator.{NAME}", exogenous=value),
                             source, name)

    return (("ARX dual KF, patent (mz)", exogenous("mz")),
            ("ARX dual KF, E2 (mz, δ)", exogenous("mz_delta")))


def _errors(estimate: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """(RMSE, max |e|) in deg/s."""
    e = np.rad2deg(estimate - truth)
    return float(np.sqrt(np.mean(e ** 2))), float(np.abs(e).max())


def table(vehicle_text: str, source: str, name: str, seeds: int) -> list[str]:
    configs = variants(vehicle_text, source, name)
    base = configs[0][1]
    lines = []
    for case in CASES:
        rows: dict[str, list[tuple[float, float]]] = {}
        for seed in range(1, seeds + 1):
            log = case.simulate(base, 1.0 / base.sample_time, seed)
            truth = log["r_ref"]
            rows.setdefault("raw gyro", []).append(_errors(log["r"], truth))
            rows.setdefault("kf2dof (2-DOF KF)", []).append(
                _errors(run_estimator(base, "kf2dof", log)["r"], truth))
            for label, config in configs:
                rows.setdefault(label, []).append(_errors(run_estimator(config, NAME, log)["r"], truth))
        lines += [f"### {case.label}, {seeds} seeds", "",
                  "| yaw rate from | RMSE (°/s) | max \\|e\\| (°/s) |", "|---|---|---|"]
        for label, values in rows.items():
            v = np.array(values)
            lines.append(f"| {label} | {v[:, 0].mean():.3f} ± {v[:, 0].std():.3f} | "
                         f"{v[:, 1].mean():.3f} ± {v[:, 1].std():.3f} |")
        lines.append("")
    return lines


def parameter_plot(vehicle_text: str, source: str, name: str, out: Path) -> str:
    """theta over time on the continuous DLC (seed 1), both variants, with the friction steps;
    returns the Markdown line embedding it."""
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(9, 8))
    log = None
    for label, config in variants(vehicle_text, source, name):
        log = PLOT_CASE.simulate(config, 1.0 / config.sample_time, 1)
        estimate = run_estimator(config, NAME, log)
        for axis, key in zip(axes[:3], ("a1", "a2", "b_mz")):
            axis.plot(log["t"], estimate[key], lw=1.0, label=label)
            axis.set_ylabel(key)
    axes[3].plot(log["t"], log["mu"], color="black", lw=1.2)
    axes[3].set_ylabel("road μ")
    axes[3].set_xlabel("time (s)")
    return save_figure(fig, axes, out, f"ARX parameters on {PLOT_CASE.label}, vehicle {name}, "
                        "seed 1", "ARX parameters over the continuous DLC")
