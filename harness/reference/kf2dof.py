"""Reference kf2dof: 2-DOF bicycle model + Kalman filter (docs/methods.md, seed 000 §2.5,
§2.8-2.10, run alone; harness.reference.bicycle_kf), the project's hold rule, prediction with the
previous sample's inputs.
"""

from __future__ import annotations

import math

import numpy as np

from vsegen.harness.reference import bicycle_kf, blocks, monitors

INPUTS = ("delta", "vx", "ay", "r")
"""What the KF reads; the input monitors may add theirs (:func:`input_names`)."""
OUTPUTS = ("beta", "vy", "r", "status")


def input_names(config) -> tuple[str, ...]:
    return monitors.inputs(INPUTS, _settings(config))


def _monitored(config) -> bool:
    return _settings(config)["residual_window"] > 0


def _monitor_states(config) -> tuple[str, ...]:
    """The consistency and input monitors' state entries (those that are on)."""
    return (*(blocks.MONITOR_STATES if _monitored(config) else ()),
            *monitors.states(_settings(config), input_names(config)))


def names(config):
    """(inputs, states, outputs) names of the flat vectors."""
    return (input_names(config), ("vy", "r", "P_vy_vy", "P_vy_r", "P_r_r", "delta_prev", "vx_prev",
                     *_monitor_states(config), "holding"), OUTPUTS)


def _settings(config):
    return config.settings("kf2dof")


def init(config, u0) -> np.ndarray:
    s = _settings(config)
    first, holding = blocks.first_sample(config.limits, dict(zip(input_names(config), u0)), s["vx_min"],
                                         s["vx_resume"], monitors.monitored_only(INPUTS, s))
    P0 = np.array(s["initial_covariance"])
    entries = {**{k: 0.0 for k in blocks.MONITOR_STATES}, **monitors.initial(s, input_names(config), first)}
    return np.array([0.0, first["r"], P0[0, 0], P0[0, 1], P0[1, 1], first["delta"], first["vx"],
                     *(entries[k] for k in _monitor_states(config)), holding])


def step(config, state, u):
    s = _settings(config)
    T = config.sample_time
    vx_max = config.limits["vx_max"]
    inputs = dict(zip(input_names(config), u))
    entries = dict(zip(_monitor_states(config), state[7:-1]))    # the monitors' entries when they are on
    vy, r, p11, p12, p22, delta_prev, vx_prev = state[:7]
    holding = state[-1]
    active, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                         holding > 0.5, monitors.monitored_only(INPUTS, s))
    delta_keep, vx_keep = blocks.kept_previous(inputs, ok, delta_prev, vx_prev)
    if not active:
        P0 = np.array(s["initial_covariance"])
        new = np.array([0.0, r, P0[0, 0], P0[0, 1], P0[1, 1], delta_keep, vx_keep,
                        *entries.values(), 1.0])
        return new, np.array([0.0, 0.0, r, float(status)])

    def clamp(v):
        return min(max(v, s["vx_min"]), vx_max)

    vx = clamp(inputs["vx"])
    x, P, innovation = bicycle_kf.step(s, config.vehicle, T, np.array([vy, r]),
                                       np.array([[p11, p12], [p12, p22]]), delta_prev, clamp(vx_prev),
                                       inputs["delta"], vx, np.array([inputs["ay"], inputs["r"]]))
    status |= blocks.beyond_linear_range(inputs["ay"], s)
    updates, flags = monitors.step(entries, inputs, ok, s, T, input_names(config), config.vehicle)
    entries.update(updates)
    status |= flags
    if _monitored(config):
        updates, suspect, _ = blocks.residual_monitor(entries, innovation, s, T)
        entries.update(updates)
        status |= blocks.MODEL_INCONSISTENT if suspect else 0
    new = np.array([x[0], x[1], P[0, 0], P[0, 1], P[1, 1], delta_keep, vx_keep, *entries.values(), 0.0])
    return new, np.array([math.atan2(x[0], vx), x[0], x[1], float(status)])
