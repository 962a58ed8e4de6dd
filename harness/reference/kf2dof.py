"""Reference kf2dof: 2-DOF bicycle model + Kalman filter (docs/methods.md, seed 000 §2.5,
§2.8-2.10, run alone; harness.reference.bicycle_kf), the project's hold rule, prediction with the
previous sample's inputs.
"""

from __future__ import annotations

import math

import numpy as np

from vsegen.harness.reference import bicycle_kf, blocks
from vsegen.harness.reference.monitor_block import Checks

INPUTS = ("delta", "vx", "ay", "r")
"""What the KF reads; the monitors may add theirs (:func:`input_names`)."""
OUTPUTS = ("beta", "vy", "r", "status")
CHECKS = Checks(consistency=True, linear_range=True)


def _monitors(config):
    return CHECKS.block(INPUTS, _settings(config))


def input_names(config) -> tuple[str, ...]:
    return _monitors(config).inputs


def names(config):
    """(inputs, states, outputs) names of the flat vectors."""
    return input_names(config), _state_names(_monitors(config)), OUTPUTS


def _state_names(block) -> tuple[str, ...]:
    return ("vy", "r", "P_vy_vy", "P_vy_r", "P_r_r", "delta_prev", "vx_prev", *block.states, "holding",
            *block.segment)


def _settings(config):
    return config.settings("kf2dof")


def init(config, u0) -> np.ndarray:
    s = _settings(config)
    block = _monitors(config)
    first, holding = blocks.first_sample(config.limits, dict(zip(block.inputs, u0)), s["vx_min"],
                                         s["vx_resume"], block.monitored)
    P0 = np.array(s["initial_covariance"])
    entries = block.initial(first)
    return np.array([0.0, first["r"], P0[0, 0], P0[0, 1], P0[1, 1], first["delta"], first["vx"],
                     *(entries[k] for k in block.states), holding, *(entries[k] for k in block.segment)])


def step(config, state, u):
    s, block = _settings(config), _monitors(config)
    T = config.sample_time
    vx_max = config.limits["vx_max"]
    inputs = dict(zip(block.inputs, u))
    x = dict(zip(_state_names(block), state))
    entries = {k: x[k] for k in block.states}    # the model checks' entries when they are on
    vy, r, p11, p12, p22, delta_prev, vx_prev = state[:7]
    active, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                         x["holding"] > 0.5, block.monitored)
    watched, flags = block.watch_inputs(x, inputs, ok, active, T, config.vehicle, config.limits)
    delta_keep, vx_keep = blocks.kept_previous(inputs, ok, delta_prev, vx_prev)
    if not active:
        P0 = np.array(s["initial_covariance"])
        new = np.array([0.0, r, P0[0, 0], P0[0, 1], P0[1, 1], delta_keep, vx_keep,
                        *entries.values(), 1.0, *(watched[k] for k in block.segment)])
        return new, np.array([0.0, 0.0, r, float(status)])

    def clamp(v):
        return min(max(v, s["vx_min"]), vx_max)

    vx = clamp(inputs["vx"])
    x_new, P, innovation, ay_model = bicycle_kf.step(s, config.vehicle, T, np.array([vy, r]),
                                                 np.array([[p11, p12], [p12, p22]]), delta_prev, clamp(vx_prev),
                                                 inputs["delta"], vx, np.array([inputs["ay"], inputs["r"]]))
    judged, judgement, _ = block.judge_model(entries, innovation, T, inputs["ay"], ay_model)
    entries.update(judged)
    status |= flags | judgement
    new = np.array([x_new[0], x_new[1], P[0, 0], P[0, 1], P[1, 1], delta_keep, vx_keep, *entries.values(), 0.0,
                    *(watched[k] for k in block.segment)])
    return new, np.array([math.atan2(x_new[0], vx), x_new[0], x_new[1], float(status)])
