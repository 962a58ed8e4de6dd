"""Reference kf2dof: 2-DOF bicycle model + Kalman filter (docs/methods.md, seed 000 §2.5,
§2.8-2.10, run alone; harness.reference.bicycle_kf), the project's hold rule, prediction with the
previous sample's inputs.
"""

from __future__ import annotations

import math

import numpy as np

from vsegen.harness.reference import bicycle_kf, blocks
from vsegen.harness.reference.input_checks import frozen
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
    return input_names(config), _state_names(_settings(config), _monitors(config)), OUTPUTS


def _state_names(s, block) -> tuple[str, ...]:
    return (*bicycle_kf.names(s), *bicycle_kf.covariance_names(s), "delta_prev", "vx_prev", *block.states,
            "holding", *block.segment)


def _settings(config):
    return config.settings("kf2dof")


def init(config, u0) -> np.ndarray:
    s = _settings(config)
    block = _monitors(config)
    first, holding = blocks.first_sample(config.limits, dict(zip(block.inputs, u0)), s["vx_min"],
                                         s["vx_resume"], block.monitored)
    entries = {**bicycle_kf.initial_entries(s, first["r"]), "delta_prev": first["delta"], "vx_prev": first["vx"],
               **block.initial(first), "holding": holding}
    return np.array([entries[k] for k in _state_names(s, block)])


def step(config, state, u):
    s, block = _settings(config), _monitors(config)
    T = config.sample_time
    vx_max = config.limits["vx_max"]
    inputs = dict(zip(block.inputs, u))
    names = _state_names(s, block)
    x = dict(zip(names, state))
    entries = {k: x[k] for k in block.states}    # the model checks' entries when they are on
    kf, P = bicycle_kf.state(s, x)
    delta_prev, vx_prev = x["delta_prev"], x["vx_prev"]
    active, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                         x["holding"] > 0.5, block.monitored)
    watched, flags = block.watch_inputs(x, inputs, ok, active, T, config.vehicle, config.limits)
    delta_keep, vx_keep = blocks.kept_previous(inputs, ok, delta_prev, vx_prev)
    if not active:       # vy := 0, P := P_0; r and the friction scale held
        held = {**x, **bicycle_kf.entries(s, np.array([0.0, *kf[1:]]), bicycle_kf.initial_covariance(s)),
                "delta_prev": delta_keep, "vx_prev": vx_keep, "holding": 1.0, **{k: watched[k] for k in block.segment}}
        return np.array([held[k] for k in names]), np.array([0.0, 0.0, x["r"], float(status)])

    def clamp(v):
        return min(max(v, s["vx_min"]), vx_max)

    vx = clamp(inputs["vx"])
    x_new, P, innovation, ay_model = bicycle_kf.step(s, config.vehicle, T, kf, P, delta_prev, clamp(vx_prev),
                                                     inputs["delta"], vx, np.array([inputs["ay"], inputs["r"]]),
                                                     frozen.any_frozen(x, s, block.check_time(T), ("ay", "r")))
    judged, judgement, _ = block.judge_model(entries, innovation, T, inputs["ay"], ay_model,
                                             friction_scale=bicycle_kf.friction_scale(s, x_new))
    status |= flags | judgement
    new = {**x, **bicycle_kf.entries(s, x_new, P), "delta_prev": delta_keep, "vx_prev": vx_keep, **judged,
           "holding": 0.0, **{k: watched[k] for k in block.segment}}
    return np.array([new[k] for k in names]), np.array([math.atan2(x_new[0], vx), x_new[0], x_new[1], float(status)])
