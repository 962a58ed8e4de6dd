"""Seed 001 reproduction: the 80 km/h DLC and the 0.05 rad step steer at μ 1.0 and 0.5 with 1 kHz
logs (the paper's sample time); max |e| and standard deviation of e = β̂ − β (rad) for the plain EKF
(constant stiffness), the integral method alone and the fused method with three stiffness
regressors (the paper's literal left/right one, the spec's B2 per-axle option, and the vehicle
file's kinematic slip), beside the paper's Tables 3–4 (fused only). Also a plot of the estimated
axle stiffness against the truth plant's secant stiffness F_y / α over the DLC."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from bench.figures import save_figure
from vsegen.harness.host.run_log import run_estimator
from vsegen.harness.logs.table import Log
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.sim.scenarios import Case
from vsegen.model.params import VehicleConfig, parse_vehicle

NAME = "ekf_rls"
RATE_HZ = 1000.0
PAPER = {("dlc", 1.0): (0.0016, 0.00043), ("dlc", 0.5): (0.00202, 0.00044),
         ("step_steer", 1.0): (0.00035, 0.00004), ("step_steer", 0.5): (0.00082, 0.00016)}
"""Seed 001 Tables 3-4, fused method: (max |e|, std e) in rad (docs/methods.md, seed 001 §4)."""
CASES = tuple(Case.of(s, speed_kmh=80.0, mu=mu) if s == "dlc" else Case.of(s, mu=mu)
              for s, mu in PAPER)
MIN_SLIP = 0.002
"""Smallest |slip angle| (rad) at which the truth's secant stiffness is plotted."""


LITERAL = {"stiffness_regressor": "literal", "forgetting_factor": 0.9, "roll_gradient": 0.0}
"""The paper as the spec reconstructs it: side-wise regressor, tau = 0.9 per 1 ms, literal a_y."""
FUSED_PAPER = "fused, the paper's regressor (literal)"
FUSED_OURS = "fused, kinematic slip (vehicle file)"


def variants(vehicle_text: str, source: str, name: str) -> tuple[tuple[str, VehicleConfig], ...]:
    """(label, configuration at T = 1 ms) of each compared method; the fused ones last."""
    def with_keys(**keys) -> VehicleConfig:
        return parse_vehicle(with_settings(vehicle_text, f"estimator.{NAME}", **keys), source,
                             name).with_sample_time(1.0 / RATE_HZ)

    return (("plain EKF (constant stiffness)", with_keys(stiffness="constant")),
            ("integral method alone", with_keys(weighting="integral_only")),
            (FUSED_PAPER, with_keys(**LITERAL)),
            ("fused, per-axle EKF slip (B2)", with_keys(**{**LITERAL,
                                                          "stiffness_regressor": "ekf_slip"})),
            (FUSED_OURS, with_keys()))


def table(vehicle_text: str, source: str, name: str, seeds: int) -> list[str]:
    configs = variants(vehicle_text, source, name)
    lines = ["| scenario | method | max \\|e\\| (rad) | std e (rad) | paper, fused: max / std (rad) |",
             "|---|---|---|---|---|"]
    for case, paper in zip(CASES, PAPER.values()):
        for label, config in configs:
            values = []
            for seed in range(1, seeds + 1):
                log = case.simulate(config, RATE_HZ, seed)
                e = run_estimator(config, NAME, log)["beta"] - log["beta_ref"]
                values.append((np.abs(e).max(), e.std()))
            v = np.array(values).mean(axis=0)
            cite = f"{paper[0]} / {paper[1]}" if label in (FUSED_PAPER, FUSED_OURS) else "-"
            lines.append(f"| {case.label} | {label} | {v[0]:.5f} | {v[1]:.5f} | {cite} |")
    return lines


def secant_stiffness(config: VehicleConfig, log: Log) -> tuple[np.ndarray, np.ndarray]:
    """The truth plant's axle secant stiffness F_y / alpha (N/rad), from the truth states: forces
    from m (dv_y/dt + r v_x) and I_z dr/dt [21, 22], slip angles [3]; NaN where |alpha| is small."""
    v = config.vehicle
    m, iz, a, b = v["mass"], v["yaw_inertia"], v["cg_to_front_axle"], v["cg_to_rear_axle"]
    t, vx, vy, r, delta = log["t"], log["vx_ref"], log["vy_ref"], log["r_ref"], log["delta"]
    ay, r_dot = np.gradient(vy, t) + r * vx, np.gradient(r, t)
    fy_front = (b * m * ay + iz * r_dot) / ((a + b) * np.cos(delta))
    fy_rear = (a * m * ay - iz * r_dot) / (a + b)
    alpha_f, alpha_r = delta - (vy + a * r) / vx, -(vy - b * r) / vx
    with np.errstate(divide="ignore", invalid="ignore"):
        return (np.where(np.abs(alpha_f) > MIN_SLIP, fy_front / alpha_f, np.nan),
                np.where(np.abs(alpha_r) > MIN_SLIP, fy_rear / alpha_r, np.nan))


def stiffness_plot(vehicle_text: str, source: str, name: str, out: Path) -> str:
    """Estimated C_f, C_r against the truth's secant stiffness on the 80 km/h DLC, μ 1.0, seed 1;
    returns the Markdown line embedding it."""
    configs = variants(vehicle_text, source, name)
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    case = CASES[0]
    log = case.simulate(configs[0][1], RATE_HZ, 1)
    truth = secant_stiffness(configs[0][1], log)
    for axis, key, values, nominal in zip(axes, ("c_front", "c_rear"), truth,
                                          ("cornering_stiffness_front", "cornering_stiffness_rear")):
        axis.plot(log["t"], values / 1e3, color="black", lw=1.6, label="truth plant, secant F_y/α")
        axis.axhline(configs[0][1].vehicle[nominal] / 1e3, color="grey", ls="--", lw=1,
                     label="vehicle file (plain EKF)")
        for label, config in configs[2:]:
            axis.plot(log["t"], run_estimator(config, NAME, log)[key] / 1e3, lw=0.8, label=label)
        axis.set_ylabel(f"{'front' if key == 'c_front' else 'rear'} axle (kN/rad)")
    axes[1].set_xlabel("time (s)")
    return save_figure(fig, axes, out, f"Cornering stiffness on {case.label}, 1 kHz, vehicle "
                        f"{name}, seed 1", "stiffness against the truth")
