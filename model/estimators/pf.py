"""pf_improved / pf_adaptive: longitudinal and lateral speed from a particle filter on the
kinematic model, with (pf_improved) or without (pf_adaptive, the baseline of the paper's ref.
[17]) the proposal correction (seed 003).

docs/methods.md, seed 003, §2 with the §3/§5 defaults:

* particle state [v_x, v_y, a_x, a_y, r] plus its weight; a_x, a_y, r random walks, the speeds
  Euler-integrated from (5)-(6) with the particle's own trapezoidal a and r (15);
* proposal correction (14): each particle's a_x, a_y, r move by G (z - own value) before the
  random step (G = 0 for pf_adaptive);
* adaptive process noise (16), the same in both filters, from the innovation of the previous
  weighted estimate;
* Gaussian likelihood of z = [a_x, a_y, r] (13) (option D2: also the logged v_x), the paper's
  likelihood-only weights (D3; option: exact importance ratio); the weighted mean before
  resampling (D7) and N_eff; systematic resampling at every sample (D4; option: N_eff < N / 2).

The draws, the weights' normalisation, the estimate and the resampling are template C shared by
every particle filter (``model.estimator.Particles``); this module gives the per-particle
Functions. Weights are kept as log-scores relative to the best particle, so their sum is at least 1
and the spec's underflow guard cannot trigger.

Hold rule (model.guard, on the logged v_x like every estimator): an implausible input or low speed
holds the particles and the random stream (no draws), beta = 0; ``hold_reason`` is 2 for a low-speed
hold, 1 for an invalid input. The first sample after a low-speed hold draws a new particle set
from that sample (2.9), as the initialisation does. Active, an estimated v_x below vx_min gives
beta = 0 and LOW_SPEED (the spec's validity rule). Beyond the spec, a_y is corrected for body roll
with the vehicle's roll gradient, as seed 000's estimators do (0 = the literal (13)), and the
head keeps a bound of the never-measured v_y's error (``drift``: 3 sigma of the initial spread
at each draw, plus (drift_acceleration + |v_x| drift_yaw_rate) T per propagated sample), which
raises DEAD_RECKONING once it exceeds tan(drift_limit) |v_x|.
"""

from __future__ import annotations

import casadi as ca

from vsegen.model import signals, status
from vsegen.model.calibration import Parameters
from vsegen.model.estimator import INERTIAL_SIGMAS, RNG_WORDS, ROLL_GRADIENT, Definition, Estimator, Particles, Tunable
from vsegen.model.guard import first_sample, hold, input_guard, model_speed
from vsegen.model.layout import Layout
from vsegen.model.schema import (
    CAPS_ABOVE_FLOORS,
    LOW_SPEED_FIELDS,
    LOW_SPEED_RULES,
    ROLL_CORRECTION,
    SMALLEST_SIGMA,
    EstimatorSchema,
    Field,
    Rule,
    choice,
    diagonal,
    integer,
    nonnegative,
    positive,
)
from vsegen.model.sensors import roll_corrected
from vsegen.model.signals import Signal

SAMPLERS = {"ziggurat": "ziggurat normals (128 layers, 24-bit magnitudes)",
            "box_muller": "Box-Muller normals (cos branch)"}
IMPROVED = "pf_improved"
ADAPTIVE = "pf_adaptive"

PF_FIELDS: tuple[Field, ...] = (
    integer("particles", 2, 10000, "N, the particle count (fixed at generation time; the state "
            "holds 6 N reals)"),
    integer("seed", 0, 2 ** 32 - 1, "seed of the filter's PCG32 random stream"),
    choice("observation", ("inertial", "wheel_speed"), "z = [a_x, a_y, r] (the paper's (13)) or "
           "also the logged v_x (D2)"),
    choice("resampling", ("every_sample", "effective_size"), "systematic resampling at every "
           "sample (D4 default) or only when N_eff < N / 2"),
    choice("normals", ("ziggurat", "box_muller"), "the standard normal sampler: Marsaglia and "
           "Tsang's ziggurat (beyond the spec: one 32-bit draw and an integer comparison for "
           "97.2 % of the normals) or the spec's Box-Muller, cosine branch (D5: log, cos, sqrt "
           "and two uniforms per normal)", default="ziggurat"),
    diagonal("measurement_noise", 3, "[a_x, a_y, r]: m/s^2, m/s^2, rad/s", "R as standard "
             "deviations sigma_ax,m, sigma_ay,m, sigma_r,m (1 sigma)", minimum=SMALLEST_SIGMA),
    positive("wheel_speed_noise", "m/s", "sigma_vx,w of the logged v_x (observation = "
             "\"wheel_speed\" only)"),
    diagonal("initial_spread", 2, "[v_x, v_y]: m/s", "1-sigma spread of the initial particles' "
             "speeds (2.9)"),
    diagonal("process_noise", 3, "[a_x, a_y, r] per sample: m/s^2, m/s^2, rad/s", "sigma_ax,0, "
             "sigma_ay,0, sigma_r,0: random-walk step at rest (16)"),
    diagonal("process_noise_max", 3, "[a_x, a_y, r] per sample: m/s^2, m/s^2, rad/s", "caps "
             "sigma_ax,max, sigma_ay,max, sigma_r,max of the adapted random walk (16)"),
    diagonal("speed_noise", 2, "[v_x, v_y] per sample: m/s", "sigma_vx,0, sigma_vy,0 (16)"),
    nonnegative("adaptation_gain_acceleration", "-", "kappa_a of (16); 0 = no adaptation"),
    nonnegative("adaptation_gain_yaw_rate", "-", "kappa_r of (16); 0 = no adaptation"),
    nonnegative("drift_acceleration", "m/s^2", "beyond the paper: the part of v_y's error rate that "
                "does not scale with speed (a_y offset); with drift_yaw_rate the status bound of the "
                "integrated, never measured v_y (DEAD_RECKONING); both 0 = off", default=0.0),
    nonnegative("drift_yaw_rate", "rad/s", "beyond the paper: the yaw-rate error whose product with "
                "|v_x| adds to v_y's error rate (v_y' = a_y - r v_x)", default=0.0),
    positive("drift_limit", "rad", "beyond the paper: DEAD_RECKONING once the bound of v_y's error "
             "exceeds tan(drift_limit) |v_x|", default=0.0349),
    ROLL_CORRECTION,
    *LOW_SPEED_FIELDS,
)
"""Seed 003's particle filter: the adaptive PF of its ref. [17] (docs/methods.md, seed 003 §2,
§3, §5)."""


PF_RULES = (*LOW_SPEED_RULES, CAPS_ABOVE_FLOORS)
ADAPTIVE_SCHEMA = EstimatorSchema(fields=PF_FIELDS, rules=PF_RULES)
IMPROVED_SCHEMA = EstimatorSchema(
    fields=(*PF_FIELDS,
            diagonal("correction_gain", 3, "-, each at most 1", "G of the proposal correction "
                     "(14): the share of z - [a_x, a_y, r] of each particle it moves towards the "
                     "measurement per sample", zero_allowed=True),
            choice("weights", ("likelihood", "exact_importance"), "the paper's likelihood-only "
                   "weights (D3) or the exact importance ratio of the corrected proposal")),
    rules=(*PF_RULES, Rule("correction_gain", lambda t: "" if max(t["correction_gain"]) <= 1.0
                           else f"correction_gain = {list(t['correction_gain'])!r}: expected "
                                "every entry from 0 to 1", ("correction_gain", "<=", 1.0))))
KINEMATIC = (("vx", "m/s", "longitudinal speed"), ("vy", "m/s", "lateral speed"),
             ("ax", "m/s^2", "longitudinal acceleration"), ("ay", "m/s^2", "lateral acceleration"),
             ("r", "rad/s", "yaw rate"))
K_NAMES = tuple(name for name, _, _ in KINEMATIC)
MEASURED = ("ax", "ay", "r")
PARTICLE = Layout((*(Signal(n, u, d) for n, u, d in KINEMATIC),
                   Signal("weight", "-", "normalised weight (during a step: log-weight score)")))
INPUTS = Layout(signals.inputs("vx", "ax", "ay", "r"))
SHARED = ("mode", "vx", "ax", "ay", "r", "sigma_vx", "sigma_vy", "sigma_ax", "sigma_ay", "sigma_r",
          "status", "hold_reason")
"""The per-sample vector every particle sees: the mode (0 hold, 1 propagate, 2 spawn), the
measurement z (a_y roll-corrected) and the process-noise standard deviations (16); then, for
``finish``, the guard's status bits and the ``hold_reason`` value the head keeps if the sample holds."""
HOLD, PROPAGATE, SPAWN = 0, 1, 2
WEIGHT_FLOOR = 1e-30
"""Weights below this count as this in the log-score of ``resampling = "effective_size"``
(a particle that light is dead either way; the floor keeps the score finite in float too)."""


def layouts(count: int) -> tuple[Layout, Layout, Layout]:
    """(inputs, states, outputs) for ``count`` particles."""
    states = Layout((
        *(Signal(n, u, f"estimate of the {d} (weighted mean)") for n, u, d in KINEMATIC),
        signals.HOLD_REASON,
        Signal("drift", "m/s", "bound of the v_y error: 3 sigma of the initial spread, plus the drift "
                               "rate integrated since the particles were drawn"),
        *(Signal(f"rng_{i}", "-", f"PCG32 state bits {63 - 16 * i}..{48 - 16 * i}")
          for i in range(RNG_WORDS)),
        *(Signal(f"p{i}_{s.name}", s.unit, f"particle {i}: {s.doc}")
          for i in range(count) for s in PARTICLE.signals),
    ))
    outputs = Layout((
        Signal("beta", "rad", "sideslip angle atan2(v_y, v_x)"),
        Signal("vx", "m/s", "longitudinal speed"),
        Signal("vy", "m/s", "lateral speed"),
        Signal("n_eff", "-", "effective sample size 1 / sum w^2 before resampling"),
        Signal("sigma_ax", "m/s^2", "adapted random-walk step of a_x (16)"),
        Signal("sigma_ay", "m/s^2", "adapted random-walk step of a_y (16)"),
        Signal("sigma_r", "rad/s", "adapted random-walk step of r (16)"),
        signals.STATUS,
    ))
    return INPUTS, states, outputs


def build_improved(params: Parameters) -> Estimator:
    """The pf_improved estimator ([inputs], [estimator.pf_improved])."""
    return _build(params, IMPROVED)


def build_adaptive(params: Parameters) -> Estimator:
    """The pf_adaptive estimator ([inputs], [estimator.pf_adaptive])."""
    return _build(params, ADAPTIVE)


def _build(params: Parameters, name: str) -> Estimator:
    numeric = params.numeric.settings(name)
    count = numeric["particles"]
    inputs_layout, states, outputs = layouts(count)
    head = Layout(states.signals[:len(KINEMATIC) + 2])
    extra = params.inputs()
    extra_names = ["params"] * len(extra)

    def function(label, args, results, arg_names, result_names):
        return ca.Function(f"vse_{name}_kernel_{label}", [*args, *extra],
                           [ca.densify(ca.cse(r)) for r in results],
                           [*arg_names, *extra_names], result_names)

    u_sym, u = inputs_layout.symbols("input")
    head_sym, h = head.symbols("head")
    shared_sym, shared = Layout(tuple(Signal(n, "", "") for n in SHARED)).symbols("shared")
    particle_sym, particle = PARTICLE.symbols("particle")
    normals = ca.SX.sym("normals", len(KINEMATIC))
    summary = ca.SX.sym("summary", len(KINEMATIC) + 1)

    init_head, init_shared = _initial(params, name, u)
    prepared = _prepare(params, name, h, u)
    finish_head, finish_output = _finish(params, name, h, shared, summary, head, outputs)
    particles = Particles(
        init=function("init", [u_sym], [init_head, init_shared], ["input"], ["head", "shared"]),
        prepare=function("prepare", [head_sym, u_sym], [prepared], ["head", "input"], ["shared"]),
        spawn=function("spawn", [shared_sym, normals], [_spawn(params, name, shared, normals)],
                       ["shared", "normals"], ["particle"]),
        propagate=function("propagate", [shared_sym, particle_sym, normals],
                           [_propagate(params, name, shared, particle, normals)],
                           ["shared", "particle", "normals"], ["particle_next"]),
        finish=function("finish", [head_sym, shared_sym, summary],
                        [finish_head, finish_output], ["head", "shared", "summary"],
                        ["head_next", "output"]),
        count=count, seed=numeric["seed"], resampling=numeric["resampling"],
        sampler=numeric["normals"],
        head_size=len(head), particle=PARTICLE)
    variant = ("improved PF (proposal correction, seed 003)" if name == IMPROVED
               else "adaptive PF (the baseline of seed 003)")
    return Estimator(
        name, f"longitudinal and lateral speed and sideslip: {variant} on the kinematic model, "
              f"{count} particles", inputs_layout, states, outputs, particles.init, particles, params,
        {"particles": f"{count}, systematic resampling "
                      f"{'at every sample' if numeric['resampling'] == 'every_sample' else 'when N_eff < N/2'}",
         "random_stream": f"PCG32 (XSH RR), seed {numeric['seed']}; uniforms of "
                          "53 bits (double) or 24 bits (float); "
                          + SAMPLERS[numeric["normals"]],
         "observation": numeric["observation"]})


def _measured(params: Parameters, name: str, u) -> dict[str, ca.SX]:
    """z as the filter uses it: a_y without the gravity component of body roll."""
    roll_gradient = params.config.settings(name)["roll_gradient"]
    return {"ax": u["ax"], "ay": roll_corrected(u["ay"], roll_gradient), "r": u["r"]}


def _initial(params: Parameters, name: str, u) -> tuple[ca.SX, ca.SX]:
    """The head at the first sample and the shared vector of the initial spawn (2.9)."""
    config = params.config
    settings = config.settings(name)
    first, holding = first_sample(u, config.limits, settings["vx_min"], settings["vx_resume"])
    vx0 = model_speed(first["vx"], settings["vx_min"], config.limits["vx_max"])
    z = _measured(params, name, first)
    head = ca.vertcat(vx0, 0, z["ax"], z["ay"], z["r"], 2 * holding, initial_drift(settings))
    speed, accel = settings["speed_noise"], settings["process_noise"]
    sigma_a = ca.vertcat(*accel)
    shared = ca.vertcat(SPAWN, vx0, z["ax"], z["ay"], z["r"],
                        speed[0] + config.sample_time * sigma_a[0],
                        speed[1] + config.sample_time * sigma_a[1], sigma_a, 0, 2 * holding)
    return head, shared


def initial_drift(settings):
    """The v_y error bound when the particles are drawn: 3 sigma of their v_y spread (m/s)."""
    return 3 * settings["initial_spread"][1]


def _prepare(params: Parameters, name: str, h, u) -> ca.SX:
    """The shared vector of one sample: mode, z, the adapted sigmas (16), status, hold_reason."""
    config = params.config
    settings = config.settings(name)
    guard = input_guard(u, config.limits, settings["vx_min"], settings["vx_resume"],
                        h["hold_reason"] > 0.5)
    mode = ca.if_else(guard.active, ca.if_else(h["hold_reason"] > 1.5, SPAWN, PROPAGATE), HOLD)
    z = _measured(params, name, u)
    z = {n: hold(z[n], guard.active, h[n]) for n in MEASURED}   # held: innovation 0, sigma_0
    floor, cap = settings["process_noise"], settings["process_noise_max"]
    gains = (settings["adaptation_gain_acceleration"],) * 2 + (settings["adaptation_gain_yaw_rate"],)
    sigma = [ca.fmin(ca.fmax(floor[i] + gains[i] * ca.fabs(z[n] - h[n]), floor[i]), cap[i])
             for i, n in enumerate(MEASURED)]
    speed = settings["speed_noise"]
    T = config.sample_time
    held = ca.if_else(guard.low_speed, 2, ca.fmax(h["hold_reason"], 1))
    return ca.vertcat(mode, hold(u["vx"], guard.active, h["vx"]), z["ax"], z["ay"], z["r"],
                      speed[0] + T * sigma[0], speed[1] + T * sigma[1], *sigma, guard.status,
                      ca.if_else(guard.active, 0, held))


def _spawn(params: Parameters, name: str, shared, normals) -> ca.SX:
    """A particle of the initial set (2.9): the measurement plus N(0, diag(spread^2, R)); its
    log-weight score 0 (all equal)."""
    settings = params.config.settings(name)
    spread, noise = settings["initial_spread"], settings["measurement_noise"]
    return ca.vertcat(shared["vx"] + spread[0] * normals[0], spread[1] * normals[1],
                      *(shared[n] + noise[i] * normals[2 + i] for i, n in enumerate(MEASURED)),
                      0)


def _propagate(params: Parameters, name: str, shared, particle, normals) -> ca.SX:
    """One particle through the corrected transition (14)-(15) and its log-weight score."""
    config = params.config
    settings = config.settings(name)
    numeric = params.numeric.settings(name)
    T = config.sample_time
    gain = settings["correction_gain"] if name == IMPROVED else (0.0,) * len(MEASURED)
    old = {n: particle[n] for n in MEASURED}
    correction = {n: gain[i] * (shared[n] - old[n]) for i, n in enumerate(MEASURED)}
    new = {n: old[n] + correction[n] + shared[f"sigma_{n}"] * normals[2 + i]
           for i, n in enumerate(MEASURED)}
    ax, ay, r = ((old[n] + new[n]) / 2 for n in MEASURED)
    vx = particle["vx"] + T * (ax + r * particle["vy"]) + shared["sigma_vx"] * normals[0]
    vy = particle["vy"] + T * (ay - r * particle["vx"]) + shared["sigma_vy"] * normals[1]

    noise = settings["measurement_noise"]
    score = -0.5 * sum(((shared[n] - new[n]) / noise[i]) ** 2 for i, n in enumerate(MEASURED))
    if numeric["observation"] == "wheel_speed":
        score -= 0.5 * ((shared["vx"] - vx) / settings["wheel_speed_noise"]) ** 2
    if name == IMPROVED and numeric["weights"] == "exact_importance":
        # log N(x'; f, s^2) - log N(x'; f + c, s^2) with x' = f + c + s n, per corrected entry
        for i, n in enumerate(MEASURED):
            c, s = correction[n], shared[f"sigma_{n}"]
            score -= (c * c + 2 * c * s * normals[2 + i]) / (2 * s * s)
    if numeric["resampling"] == "effective_size":
        score += ca.log(ca.fmax(particle["weight"], WEIGHT_FLOOR))
    return ca.vertcat(vx, vy, new["ax"], new["ay"], new["r"], score)


def _finish(params: Parameters, name: str, h, shared, summary, head: Layout,
            outputs: Layout) -> tuple[ca.SX, ca.SX]:
    """The next head and the outputs from the weighted mean (17) and N_eff."""
    settings = params.config.settings(name)
    active = shared["mode"] > 0.5
    estimate = {n: ca.if_else(active, summary[i], h[n]) for i, n in enumerate(K_NAMES)}
    slow = ca.logic_and(active, estimate["vx"] < settings["vx_min"])
    # beyond the spec: the bound of the integrated v_y's error (v_y' = a_y - r v_x, never measured)
    rate = settings["drift_acceleration"] + ca.fabs(estimate["vx"]) * settings["drift_yaw_rate"]
    drift = ca.if_else(shared["mode"] > 1.5, initial_drift(settings),
                       ca.if_else(active, h["drift"] + params.config.sample_time * rate, h["drift"]))
    dead_reckoning = ca.logic_and(
        ca.logic_and(active, ca.logic_not(slow)),
        ca.logic_and(settings["drift_acceleration"] + settings["drift_yaw_rate"] > 0,
                     drift > ca.tan(settings["drift_limit"]) * ca.fabs(estimate["vx"])))
    output = outputs.pack({
        "beta": ca.if_else(ca.logic_and(active, ca.logic_not(slow)),
                           ca.atan2(estimate["vy"], estimate["vx"]), 0),
        "vx": estimate["vx"], "vy": estimate["vy"], "n_eff": summary[len(K_NAMES)],
        **{f"sigma_{n}": shared[f"sigma_{n}"] for n in MEASURED},
        "status": (shared["status"] + ca.if_else(slow, status.LOW_SPEED, 0)
                   + ca.if_else(dead_reckoning, status.DEAD_RECKONING, 0)),
    })
    return head.pack({**estimate, "hold_reason": shared["hold_reason"], "drift": drift}), output


_PF_TUNABLE = {"measurement_noise": Tunable(0.005, 2.0), "process_noise": Tunable(0.001, 1.0),
               "adaptation_gain_acceleration": Tunable(0.0, 5.0, log=False),
               "adaptation_gain_yaw_rate": Tunable(0.0, 5.0, log=False)}
_PF_DERIVED = {**ROLL_GRADIENT, **INERTIAL_SIGMAS}
_PF_STATUS = (status.LOW_SPEED, status.INVALID_INPUT, status.DEAD_RECKONING)
DEFINITIONS = (
    Definition(name=ADAPTIVE, build=build_adaptive, schema=ADAPTIVE_SCHEMA, tunable=_PF_TUNABLE,
               status_bits=_PF_STATUS, derived=_PF_DERIVED),
    Definition(name=IMPROVED, build=build_improved, schema=IMPROVED_SCHEMA,
               tunable={**_PF_TUNABLE, "correction_gain": Tunable(0.0, 1.0, log=False)},
               status_bits=_PF_STATUS, derived=_PF_DERIVED),
)
