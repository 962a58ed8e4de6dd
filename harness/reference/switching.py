"""Reference switching estimator (docs/methods.md, seed 000 §2.2-2.10, §5 defaults),
written from the spec: threshold switch on the median-filtered a_y, hand-off both ways ([E25],
[E26]), kinematic integrator [E14], the KF, and the hold rule (harness.reference.kinematic_dynamic)."""

from __future__ import annotations

import math

from vsegen.harness.reference import bicycle_kf, blocks, kinematic_dynamic
from vsegen.harness.reference.input_checks import frozen
from vsegen.harness.reference.kinematic_dynamic import DYN, KIN, KINEMATIC_INPUTS
from vsegen.harness.reference.monitor_block import Checks

TABLE = "switching"
OUTPUTS = ("beta", "vy", "r", "mode", "status")
CHECKS = Checks()
"""The input monitors only."""


def _monitors(config):
    return CHECKS.block(kinematic_dynamic.INPUTS, config.settings(TABLE))


def extra(config) -> tuple[str, ...]:
    """Own state entries: the remembered peak |a_y,f| (A10 on), the kinematic dwell count."""
    s = config.settings(TABLE)
    return (*(("ay_peak",) if s["adaptive_memory"] > 0 else ()),
            *(("kin_samples",) if s["kinematic_max_dwell"] > 0 else ()),
            *(("kin_offset",) if s["offset_memory"] > 0 else ()))


def names(config):
    block = _monitors(config)
    return block.inputs, kinematic_dynamic.state_names(config, TABLE, block, extra(config)), OUTPUTS


def init(config, u0):
    return kinematic_dynamic.init(config, TABLE, _monitors(config), u0, extra(config))


def step(config, state, u):
    return kinematic_dynamic.step(config, TABLE, _monitors(config), state, u, lambda *args: _switch(config, *args),
                                  extra(config))


def _switch(config, x, updates, r_k, ay_f, status, u):
    s = config.settings(TABLE)
    threshold = s["threshold"]
    new = {**x, **updates}
    if s["adaptive_memory"] > 0:                                                  # A10 option
        peak = max(abs(ay_f), x["ay_peak"] * math.exp(-config.sample_time / s["adaptive_memory"]))
        threshold = max(threshold, min(s["adaptive_fraction"] * peak, s["adaptive_max"]))
        new["ay_peak"] = peak
    offset = x.get("kin_offset", 0.0)
    hysteresis = s["hysteresis"] if x["mode"] == KIN else -s["hysteresis"]        # A7 option
    mode = KIN if abs(ay_f) > threshold - hysteresis else DYN
    if frozen.any_frozen(x, s, _monitors(config).check_time(config.sample_time), KINEMATIC_INPUTS):  # inputs frozen
        mode = DYN
    if s["kinematic_max_dwell"] > 0:                        # beyond the paper: bounded kinematic dwell
        above = mode == KIN
        if above and (x["kin_samples"] + 0.5) * config.sample_time > s["kinematic_max_dwell"]:
            mode = DYN
            status += blocks.KINEMATIC_DWELL_LIMITED
        new["kin_samples"] = x["kin_samples"] + (1.0 if mode == KIN else 0.0) if above else 0.0
    new["mode"] = mode
    if s["offset_memory"] > 0:               # beyond the paper: learned in near-straight dynamic driving
        new["kin_offset"] = kinematic_dynamic.learned_offset(s, config.sample_time, offset, ay_f, new["ay_last"],
                                                             new["r_last"], u["vx"], allowed=mode == DYN)
    if mode == KIN:
        vy_kin = x["vy"] if x["mode"] == DYN else x["vy_kin"]                         # [E25]
        vy_kin += config.sample_time * (x["ay_last"] - x["r_last"] * x["vx_prev"] - offset)  # [E14]
        new["vy_kin"] = vy = vy_kin
    else:
        x0, P = bicycle_kf.state(s, x)
        if x["mode"] == KIN:                                                           # [E26]
            x0[0], x0[1], P = x["vy_kin"], x["r_last"], bicycle_kf.initial_covariance(s)
        sensor = s["offset_sensor_share"] * new["kin_offset"] if s["offset_memory"] > 0 else 0.0
        inputs_frozen = frozen.any_frozen(x, s, _monitors(config).check_time(config.sample_time), KINEMATIC_INPUTS)
        xk, P, _, _ = kinematic_dynamic.kalman(config, TABLE, x0, P, x["delta_prev"], x["vx_prev"], u, r_k,
                                            ay_offset=sensor,   # beyond the paper: the offset's sensor share
                                            inputs_frozen=inputs_frozen)
        new.update(bicycle_kf.entries(s, xk, P))
        vy = xk[0]
    new.update(delta_prev=u["delta"], vx_prev=u["vx"], holding=0.0)
    return new, [kinematic_dynamic.beta(config, TABLE, vy, u["vx"]), vy, r_k, mode, status]
