"""Reference fusion estimator: seed 000's comparison method (§4.4 stand-in). Both schemes every
sample, integral correction k_c of the integrator towards the KF, weighted output
beta = w beta_kin + (1 - w) beta_KF with w = clamp(|a_y,f| / (2 a_yT), 0, 1)."""

from __future__ import annotations

from vsegen.harness.reference import bicycle_kf, blocks, kinematic_dynamic
from vsegen.harness.reference.input_checks import frozen
from vsegen.harness.reference.kinematic_dynamic import DYN, KINEMATIC_INPUTS
from vsegen.harness.reference.monitor_block import Checks

TABLE = "fusion"
OUTPUTS = ("beta", "vy", "r", "weight", "status")
CHECKS = Checks(consistency=True, linear_range=True)
"""The input monitors, the consistency monitor of the KF's innovations, the linear-range flag."""


def _monitors(config):
    return CHECKS.block(kinematic_dynamic.INPUTS, config.settings(TABLE))


def extra(config) -> tuple[str, ...]:
    """fusion's own state entries: the learned offset, when on."""
    return ("kin_offset",) if config.settings(TABLE)["offset_memory"] > 0 else ()


def names(config):
    block = _monitors(config)
    return block.inputs, kinematic_dynamic.state_names(config, TABLE, block, extra(config)), OUTPUTS


def init(config, u0):
    return kinematic_dynamic.init(config, TABLE, _monitors(config), u0, extra(config))


def step(config, state, u):
    block = _monitors(config)
    return kinematic_dynamic.step(config, TABLE, block, state, u, lambda *args: _fuse(config, block, *args),
                                  extra(config))


def _fuse(config, block, x, updates, r_k, ay_f, status, u):
    s = config.settings(TABLE)
    T = config.sample_time
    kf, P = bicycle_kf.state(s, x)
    offset, learned = x.get("kin_offset", 0.0), {}     # beyond the paper: the kinematic offset
    if s["offset_memory"] > 0:
        learned["kin_offset"] = kinematic_dynamic.learned_offset(s, T, offset, ay_f, updates["ay_last"],
                                                                 updates["r_last"], u["vx"])
    xk, P, innovation, ay_model = kinematic_dynamic.kalman(config, TABLE, kf, P, x["delta_prev"],
                                                 x["vx_prev"], u, r_k,
                                                 ay_offset=s["offset_sensor_share"] * offset,
                                                 inputs_frozen=frozen.any_frozen(x, s, block.check_time(T),
                                                                                 KINEMATIC_INPUTS))
    monitor, judgement, _ = block.judge_model(x, innovation, T, u["ay"], ay_model,   # beyond the paper
                                              friction_scale=bicycle_kf.friction_scale(s, xk))
    status |= judgement
    vy_kin = (x["vy_kin"] + T * (x["ay_last"] - x["r_last"] * x["vx_prev"] - offset)
              + T * s["integral_gain"] * (x["vy"] - x["vy_kin"]))
    w = min(max(abs(ay_f) / (2 * s["threshold"]), 0.0), 1.0)
    if frozen.any_frozen(x, s, block.check_time(T), KINEMATIC_INPUTS):    # its inputs frozen: the KF alone
        vy_kin, w = xk[0], 0.0
    beta_kin = kinematic_dynamic.beta(config, TABLE, vy_kin, u["vx"])
    beta_kf = kinematic_dynamic.beta(config, TABLE, xk[0], u["vx"])
    beta = w * beta_kin + (1 - w) * beta_kf
    if s["disagreement_limit"] > 0 and w * abs(beta_kin - beta_kf) > s["disagreement_limit"]:
        status |= blocks.SCHEMES_DISAGREE            # beyond the paper: the schemes part
    new = {**x, **updates, **bicycle_kf.entries(s, xk, P), "vy_kin": vy_kin, "delta_prev": u["delta"],
           "vx_prev": u["vx"], "holding": 0.0, "mode": DYN, **monitor, **learned}
    return new, [beta, w * vy_kin + (1 - w) * xk[0], r_k, w, status]
