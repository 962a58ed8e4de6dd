"""Seed 003's particle filters: the random stream (PCG32, uniforms, ziggurat and Box-Muller normals)
in C and NumPy, the per-particle kernels (kinematics signs, proposal correction, adaptive noise
(16), weights), the systematic resampling rule, the hold rule, the resampling modes and observation options, and the
C against the reference in double (every step and every trajectory) and float (every step, flips
explained) on every verification scenario."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.reference import REFERENCES, normals
from vsegen.harness.reference.loop import run_reference
from vsegen.harness.reference.particle import _resample
from vsegen.harness.reference.pcg32 import MASK, MULTIPLIER, Stream
from vsegen.harness.sim.scenarios import VERIFICATION_SET, Case
from vsegen.harness.verify import equivalence as verify
from vsegen.harness.verify.equivalence import _flip_sets, prepared, verify_estimator
from vsegen.model import status
from vsegen.model import ziggurat as zig
from vsegen.model.estimators import build, pf
from vsegen.model.params import ParameterError

NAMES = (pf.IMPROVED, pf.ADAPTIVE)
TABLE = f"estimator.{pf.IMPROVED}"
HOLDING = len(pf.K_NAMES)
"""Index of ``holding`` in the state; ``drift`` follows it, then the stream."""
HEAD = HOLDING + 2
PARTICLES_AT = HEAD + 4
SIGMAS = slice(pf.SHARED.index("sigma_ax"), pf.SHARED.index("sigma_r") + 1)


def particles_of(state, count):
    return np.asarray(state)[PARTICLES_AT:].reshape(count, len(pf.PARTICLE))


# ---- random stream ----------------------------------------------------------------------------

def test_stream_reproduces_the_published_pcg32_demo():
    """pcg32-demo (pcg-random.org's minimal C library), seeded with pcg32_srandom_r(42, 54)."""
    stream = Stream.seeded(42, 54)
    assert [hex(int(x)) for x in stream.outputs(6)] == [
        "0xa15c02b7", "0x7b47f409", "0xba1d3330", "0x83d2f293", "0xbfa4784b", "0xcbed606e"]


def test_jumped_blocks_equal_the_lcg_one_step_at_a_time():
    stream = Stream.seeded(7, 7)
    state, increment = stream.state, stream.increment
    block = stream.outputs(1000)
    for k in (0, 1, 499, 999):
        s = state
        for _ in range(k):
            s = (s * MULTIPLIER + increment) & MASK
        x = (((s >> 18) ^ s) >> 27) & 0xFFFFFFFF
        rotation = s >> 59
        assert int(block[k]) == ((x >> rotation) | (x << ((32 - rotation) & 31))) & 0xFFFFFFFF
    for _ in range(1000):
        state = (state * MULTIPLIER + increment) & MASK
    assert stream.state == state


SAMPLERS = {"box_muller": normals.box_muller, "ziggurat": normals.ziggurat}


@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("bits", [53, 24])
def test_normals_are_standard_normal(sampler, bits):
    draws = SAMPLERS[sampler](Stream.seeded(3, 3, bits), 200_000)
    assert stats.kstest(draws, "norm").pvalue > 1e-3
    beyond = np.abs(draws) > zig.EDGE                 # the ziggurat's tail: 0.058 %, 115 expected
    assert stats.binomtest(int(beyond.sum()), len(draws), 2 * stats.norm.sf(zig.EDGE)).pvalue > 1e-3
    uniforms = Stream.seeded(3, 3, bits).uniforms(100_000)
    assert uniforms.min() >= 0.0 and uniforms.max() < 1.0
    assert np.all(uniforms * 2.0 ** bits == np.floor(uniforms * 2.0 ** bits))  # bits of resolution


def test_ziggurat_tables_of_the_generator_and_the_reference_agree_and_hold():
    """The C's tables (model.ziggurat) equal the reference's own; every layer has the area v under
    exp(-x^2/2); a magnitude below CORE lies under the curve over the layer's whole height, the
    next one beyond the layer above's edge."""
    tables = zig.tables()
    assert np.array_equal(np.array(tables.core, dtype=np.uint64), normals.CORE)
    for ours, theirs in ((tables.width, normals.WIDTH), (tables.floor, normals.FLOOR),
                         (tables.height, normals.HEIGHT)):
        assert np.array_equal(ours, theirs)
    edges = np.array(tables.width) * 2.0 ** zig.MAGNITUDE_BITS
    areas = edges[1:] * np.array(tables.height[1:])
    assert np.allclose(areas, zig.AREA, rtol=1e-8)
    base = edges[0] * tables.floor[-1]          # the base strip: rectangle plus tail
    assert base == pytest.approx(zig.EDGE * tables.floor[-1] + math.sqrt(math.pi / 2)
                                 * math.erfc(zig.EDGE / math.sqrt(2)), rel=1e-8)
    for i in range(2, zig.LAYERS):
        assert tables.core[i] * tables.width[i] <= edges[i - 1] < (tables.core[i] + 1) * tables.width[i]
    assert np.mean(np.array(tables.core) / 2.0 ** 24) == pytest.approx(0.972, abs=5e-4)


def test_a_near_decision_is_recorded_and_can_be_flipped():
    decisions = normals.Decisions(margin=1e-6, flip=1)
    assert decisions.take(1.0, 2.0) is True                      # 0: far, kept
    assert decisions.take(1.0, 2.0) is False                     # 1: flipped
    assert decisions.take(1.0, 1.0 + 1e-7) is True               # 2: near
    assert decisions.near == [2]


@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("real", ["double", "float"])
def test_c_init_leaves_the_stream_where_the_reference_does(variant, sampler, real):
    """The C seeds pcg32_srandom_r(seed, seed) and draws 5 normals per particle with the
    vehicle file's sampler, as many 32-bit outputs as the reference's draws take (two uniforms
    of two outputs each per Box-Muller normal in double, of one in float; one output for most
    ziggurat normals, more beyond a core)."""
    config = variant(TABLE, normals=sampler)
    est, c = compile_estimator(config, pf.IMPROVED, real)
    _, states = c.run(np.array([[20.0, 0.0, 0.0, 0.0]]))
    settings = config.settings(pf.IMPROVED)
    stream = Stream.seeded(settings["seed"], settings["seed"], 53 if real == "double" else 24)
    SAMPLERS[sampler](stream, 5 * settings["particles"])
    assert states[0, HEAD:PARTICLES_AT].tolist() == stream.words()


@pytest.mark.parametrize("real", ["double", "float"])
def test_c_spawns_from_the_reference_ziggurat_normals(config, real):
    """The initial particles are the measurement plus spread x normal: their deviations give
    the C's normals back, equal to the reference's (float: its float arithmetic) to rounding."""
    est, c = compile_estimator(config, pf.IMPROVED, real)
    _, states = c.run(np.array([[20.0, 0.0, 0.0, 0.0]]))
    settings = config.settings(pf.IMPROVED)
    n = settings["particles"]
    draws = normals.ziggurat(Stream.seeded(settings["seed"], settings["seed"],
                                           53 if real == "double" else 24), 5 * n).reshape(n, 5)
    spread = np.array([*settings["initial_spread"], *settings["measurement_noise"]])
    spawned = particles_of(states[0], n)[:, :5] - np.array([20.0, 0.0, 0.0, 0.0, 0.0])
    rounding = 1e-13 if real == "double" else 1e-5     # of 20 m/s, subtracted again
    assert np.allclose(spawned, spread * draws, rtol=0.0, atol=rounding)


# ---- per-particle kernels ---------------------------------------------------------------------

def shared(config, name, ax, ay, r, vx=20.0, sigmas=(0.2, 0.2, 0.01)):
    T = config.sample_time
    speed = config.settings(name)["speed_noise"]
    return [pf.PROPAGATE, vx, ax, ay, r, speed[0] + T * sigmas[0], speed[1] + T * sigmas[1],
            *sigmas, 0.0, 0.0]                                  # status, holding


@pytest.mark.parametrize("name, gain", [(pf.IMPROVED, 0.5), (pf.ADAPTIVE, 0.0)])
def test_propagation_signs_and_correction(config, name, gain):
    """(14)-(15) with zero noise: a, r move by G (z - own value); the speeds follow (5)-(6), ISO
    signs (a left turn, r > 0, turns v_x into negative v_y)."""
    propagate = build(name, config).structure.propagate
    T = config.sample_time
    particle = [20.0, 0.0, 0.0, 0.0, 0.5, 1.0 / 200]
    new = np.array(propagate(shared(config, name, 1.0, 2.0, 0.5), particle, [0.0] * 5)).ravel()
    ax, ay, r = gain * 1.0, gain * 2.0, 0.5
    assert new[2:5] == pytest.approx([ax, ay, r], abs=1e-15)
    assert new[0] == pytest.approx(20.0 + T * (ax / 2 + 0.5 * 0.0), rel=1e-15)
    assert new[1] == pytest.approx(T * (ay / 2 - 0.5 * 20.0), rel=1e-15)
    sigma = config.settings(name)["measurement_noise"]
    expected = -0.5 * sum(((z - h) / s) ** 2 for z, h, s in zip((1.0, 2.0, 0.5), (ax, ay, r), sigma))
    assert new[5] == pytest.approx(expected, rel=1e-14)


def test_exact_importance_weight_is_the_density_ratio(variant):
    """log p(x'|x) - log q(x'|x, z) over the corrected entries, added to the likelihood."""
    config = variant(TABLE, weights="exact_importance")
    plain = variant(TABLE)
    normals = [0.3, -0.2, 0.7, -1.1, 0.4]
    sigmas = (0.5, 0.8, 0.03)
    s = shared(config, pf.IMPROVED, 1.0, 2.0, 0.3, sigmas=sigmas)
    particle = [20.0, 0.1, 0.2, -0.5, 0.1, 1.0 / 200]
    exact = float(build(pf.IMPROVED, config).structure.propagate(s, particle, normals)[5])
    likelihood = float(build(pf.IMPROVED, plain).structure.propagate(s, particle, normals)[5])
    ratio = 0.0
    for old, z, sigma, n in zip(particle[2:5], (1.0, 2.0, 0.3), sigmas, normals[2:]):
        correction = 0.5 * (z - old)
        new = old + correction + sigma * n
        ratio += stats.norm.logpdf(new, old, sigma) - stats.norm.logpdf(new, old + correction, sigma)
    assert exact - likelihood == pytest.approx(ratio, rel=1e-12)


def test_adaptive_noise_follows_16(config):
    """sigma = clamp(sigma_0 + kappa |z - previous estimate|, sigma_0, sigma_max); the speeds'
    sigma_v = sigma_v0 + T sigma_a."""
    prepare = build(pf.IMPROVED, config).structure.prepare
    s = config.settings(pf.IMPROVED)
    head = [20.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.15]
    small = np.array(prepare(head, [20.0, 1.0, 0.0, 0.02])).ravel()
    assert small[0] == pf.PROPAGATE
    assert small[SIGMAS] == pytest.approx([0.2 + 0.5 * 1.0, 0.2, 0.01 + 0.5 * 0.02], rel=1e-15)
    assert small[5] == pytest.approx(s["speed_noise"][0] + config.sample_time * 0.7, rel=1e-15)
    large = np.array(prepare(head, [20.0, 25.0, -25.0, 2.0])).ravel()
    assert large[SIGMAS] == pytest.approx(s["process_noise_max"], rel=1e-15)


def test_roll_correction_of_the_lateral_acceleration(config):
    prepare = build(pf.IMPROVED, config).structure.prepare
    z = np.array(prepare([20.0, 0, 0, 0, 0, 0, 0.15], [20.0, 0.0, 5.0, 0.0])).ravel()
    assert z[3] == pytest.approx(5.0 / (1 + 9.81 * config.settings(pf.IMPROVED)["roll_gradient"]))


# ---- resampling -------------------------------------------------------------------------------

def test_systematic_resampling_rule():
    """Each particle is copied floor(N w) or ceil(N w) times, never at weight 0; a copied particle
    keeps its slot; the extra copies fill the empty slots in particle order; weights 1/N."""
    rng = np.random.default_rng(5)
    n = 50
    for _ in range(20):
        weights = rng.exponential(size=n) ** 3
        weights[rng.choice(n, 10, replace=False)] = 0.0
        weights /= weights.sum()
        particles = np.column_stack([np.arange(n, dtype=float), weights])
        result, _ = _resample(particles, rng.uniform())
        source = result[:, 0].astype(int)
        copies = np.bincount(source, minlength=n)
        assert np.all((copies == np.floor(n * weights)) | (copies == np.ceil(n * weights)))
        assert np.all(copies[weights == 0] == 0)
        kept = copies > 0
        assert np.all(source[kept] == np.flatnonzero(kept))
        extra = np.repeat(np.arange(n), np.maximum(copies - 1, 0))
        assert np.array_equal(source[~kept], extra)
        assert np.all(result[:, 1] == 1.0 / n)


def test_points_near_a_cumulative_weight_and_their_alternatives():
    """The alternatives a float build may take: every other particle of positive weight within
    the margin of a point, also across a weight too small for float (particle 3)."""
    weights = np.array([0.25, 0.0, 0.25 + 1e-9, 1e-12, 0.5 - 1e-9 - 1e-12])
    particles = np.column_stack([np.arange(5.0), weights])
    result, near = _resample(particles, 0.0, margin=1e-6)     # points 0, .2, .4, .6, .8
    assert result[:, 0].tolist() == [0.0, 0.0, 2.0, 4.0, 4.0] and near == []
    _, near = _resample(particles, 0.25, margin=1e-6)         # point 1 = 0.25 = c_0
    assert near == [(1, 0)]                                   # not the empty particle 1
    _, near = _resample(particles, 0.5, margin=1e-6)          # point 2 = 0.5 ~ c_2 ~ c_3
    assert near == [(2, 3), (2, 4)]
    flipped, _ = _resample(particles, 0.5, flip=((2, 4),))
    assert sorted(flipped[:, 0].tolist()) == [0.0, 2.0, 4.0, 4.0, 4.0]


def test_a_flip_set_is_one_decision_or_two_resampling_points():
    alternatives = [("resample", 3, 7), ("resample", 3, 8), ("resample", 9, 1), ("draw", 4)]
    assert list(_flip_sets(alternatives)) == [
        (("resample", 3, 7),), (("resample", 3, 8),), (("resample", 9, 1),), (("draw", 4),),
        (("resample", 3, 7), ("resample", 9, 1)), (("resample", 3, 8), ("resample", 9, 1))]


def test_verify_explains_a_ziggurat_decision_taken_the_other_way(config, monkeypatch):
    """A run that took one wedge or tail decision the other way (as a float libm's expf or logf
    rounding the other way would) is explained by that flip when the decision was near, and fails
    when the margin says it was not."""
    name = pf.IMPROVED
    estimator, reference, _, tolerance = prepared(config, name, "float", "baked")
    inputs = Case.of("dlc", speed_kmh=80.0).simulate(config, 100.0, 1).matrix(
        estimator.inputs.names)[:40]
    states, outputs, k = [reference.init(config, inputs[0])], [], 20
    for i, row in enumerate(inputs):
        if i == k:          # the "C" takes a draw decision the other way
            draw = next(a for a in reference.alternatives(config, states[-1], row, 0.0, 0.5)
                        if a[0] == "draw")
            state, output = reference.step_flipped(config, states[-1], row, (draw,))
        else:
            state, output = reference.step(config, states[-1], row)
        states.append(state)
        outputs.append(output)
    states, outputs = np.array(states), np.array(outputs)
    case = Case.of("dlc", speed_kmh=80.0)
    monkeypatch.setattr(verify, "DECISION_MARGIN", 0.5)
    result = verify.against_reference(config, name, case.label, "float", "baked", inputs, outputs, states)
    assert result.ok and result.flips == 1, result
    monkeypatch.setattr(verify, "DECISION_MARGIN", 1e-12)
    result = verify.against_reference(config, name, case.label, "float", "baked", inputs, outputs, states)
    assert not result.ok


@pytest.mark.parametrize("real", ["double", pytest.param("float", marks=pytest.mark.slow)])
def test_the_spec_box_muller_normals_verify(variant, real):
    config = variant(TABLE, normals="box_muller")
    (result,) = verify_estimator(config, pf.IMPROVED, cases=(Case.of("dlc", speed_kmh=120.0),),
                                 real=real)
    assert result.ok, result
    assert real == "float" or result.flips == 0


def test_effective_size_mode_resamples_only_below_half(variant):
    config = variant(TABLE, resampling="effective_size")
    est, c = compile_estimator(config, pf.IMPROVED)
    log = Case.of("dlc", speed_kmh=120.0).simulate(config, 100.0, 1)
    outputs, states = c.run(log.matrix(est.inputs.names))
    n = config.settings(pf.IMPROVED)["particles"]
    n_eff = outputs[:, est.outputs.index("n_eff")]
    uniform = np.array([np.all(particles_of(s, n)[:, -1] == 1.0 / n) for s in states[1:]])
    assert np.array_equal(uniform, n_eff < n / 2)
    assert 0 < np.sum(n_eff < n / 2) < len(n_eff)
    (result,) = verify_estimator(config, pf.IMPROVED, cases=(Case.of("dlc", speed_kmh=120.0),))
    assert result.ok, result


# ---- hold rule --------------------------------------------------------------------------------

def test_invalid_input_holds_particles_and_stream(config):
    est, c = compile_estimator(config, pf.IMPROVED)
    _, states = c.run(np.tile([25.0, 0.3, 1.0, 0.1], (50, 1)))
    state, output = c.step(states[-1], np.array([25.0, np.nan, 1.0, 0.1]))
    assert int(output[est.outputs.index("status")]) == status.INVALID_INPUT
    assert output[0] == 0.0
    assert np.array_equal(state[:HOLDING], states[-1][:HOLDING])
    assert state[HOLDING] == 1.0                                    # holding: invalid input
    assert np.array_equal(state[HOLDING + 1:], states[-1][HOLDING + 1:])  # drift bound, stream, particles kept


def test_low_speed_hold_then_a_new_particle_set(config):
    est, c = compile_estimator(config, pf.IMPROVED)
    n = config.settings(pf.IMPROVED)["particles"]
    inputs = np.vstack([np.tile([25.0, 0.0, 0.0, 0.0], (50, 1)),
                        np.tile([2.0, 0.0, 0.0, 0.0], (20, 1)),       # below vx_min: hold
                        np.tile([12.0, 0.0, 0.0, 0.0], (5, 1))])      # resume at 12 m/s
    outputs, states = c.run(inputs)
    code = outputs[:, est.outputs.index("status")].astype(int)
    assert np.all(code[50:70] == status.LOW_SPEED)
    assert np.array_equal(states[70][HEAD:], states[51][HEAD:])       # held, no draws
    resumed = particles_of(states[71], n)
    assert resumed[:, 0].mean() == pytest.approx(12.0, abs=0.05)     # drawn around the log's v_x
    assert not np.array_equal(states[71][HEAD:PARTICLES_AT], states[70][HEAD:PARTICLES_AT])
    assert code[70] == 0 and outputs[70, 1] == pytest.approx(12.0, abs=0.05)


# ---- options ----------------------------------------------------------------------------------

def test_wheel_speed_observation_bounds_the_speed(variant):
    """D2: with the logged v_x in z the speed no longer drifts over a long run."""
    case = Case.of("continuous_dlc")
    errors = {}
    for observation in ("inertial", "wheel_speed"):
        config = variant(TABLE, observation=observation)
        est, c = compile_estimator(config, pf.IMPROVED)
        log = case.simulate(config, 100.0, 1)
        outputs, _ = c.run(log.matrix(est.inputs.names))
        errors[observation] = np.mean(np.abs(outputs[:, 1] - log["vx_ref"]))
    assert errors["wheel_speed"] < 0.1 < errors["inertial"]


@pytest.mark.parametrize("old, new, fragments", [
    ("particles = 200", "particles = 1", ["particles = 1", "whole number from 2 to 10000"]),
    ("particles = 200", "particles = 200.5", ["particles = 200.5", "whole number"]),
    ("seed = 1", "seed = -3", ["seed = -3", "whole number from 0"]),
    ("correction_gain = [0.5, 0.5, 0.5]", "correction_gain = [0.5, 1.5, 0.5]",
     ["correction_gain", "from 0 to 1"]),
    ("process_noise_max = [2.0, 2.0, 0.1]", "process_noise_max = [2.0, 0.1, 0.1]",
     ["process_noise_max", "above its process_noise"]),
    ('weights = "likelihood"', 'weights = "bayes"', ["weights = 'bayes'", '"exact_importance"']),
])
def test_bad_settings_give_one_clear_line(vehicle_text, tmp_path, old, new, fragments):
    start = vehicle_text.index("[estimator.pf_improved]")
    text = vehicle_text[:start] + vehicle_text[start:].replace(old, new, 1)
    assert text != vehicle_text
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ParameterError) as error:
        load_vehicle(path)
    message = str(error.value)
    assert "\n" not in message and message.startswith(str(path))
    for fragment in fragments:
        assert fragment in message, message


# ---- equivalence ------------------------------------------------------------------------------

@pytest.mark.slow   # the default suite checks the double C on every scenario in test_equivalence
@pytest.mark.parametrize("name", NAMES)
def test_double_c_equals_the_reference_every_step_and_trajectory(config, name):
    results = verify_estimator(config, name, real="double")
    assert [r.case for r in results] == [c.label for c in VERIFICATION_SET]
    for result in results:
        assert result.ok and result.flips == 0, result


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_float_c_equals_the_reference_every_step_flips_explained(config, name):
    results = verify_estimator(config, name, real="float")
    for result in results:
        assert result.ok, result
        # a coincidence of rounding: about 2 N^2 x (float error of a cumulative weight, ~1e-7)
        # per step, 1 % at N = 200 (measured 0.2 % to 1.2 %)
        assert result.flips < 0.05 * result.samples, result


def test_verify_catches_a_wrong_correction_gain(variant):
    """The C generated with G = 0.5 against a reference that believes G = 0.51: fails."""
    config = variant(TABLE)
    wrong = variant(TABLE, correction_gain=[0.51, 0.5, 0.5])
    est, c = compile_estimator(config, pf.IMPROVED)
    inputs = Case.of("dlc", speed_kmh=80.0).simulate(config, 100.0, 1).matrix(est.inputs.names)
    _, c_states = c.run(inputs)
    _, r_states = run_reference(REFERENCES[pf.IMPROVED], wrong, inputs)
    assert np.max(np.abs(c_states - r_states)) > 1e-6


def test_the_beta_output_and_the_speed_rule(config):
    est, c = compile_estimator(config, pf.IMPROVED)
    outputs, states = c.run(np.tile([20.0, 0.0, 0.0, 0.0], (10, 1)))
    state = states[-1].copy()
    state[0] = 2.0                       # particles say 20 m/s; the head is overwritten anyway
    _, output = c.step(state, np.array([20.0, 0.0, 0.0, 0.0]))
    assert output[0] == pytest.approx(math.atan2(output[2], output[1]), abs=1e-15)
    particles = particles_of(state, config.settings(pf.IMPROVED)["particles"])
    particles[:, 0] = 1.0                # every particle below vx_min: beta := 0, LOW_SPEED
    state[PARTICLES_AT:] = particles.ravel()
    _, output = c.step(state, np.array([20.0, 0.0, 0.0, 0.0]))
    assert output[0] == 0.0 and int(output[-1]) == status.LOW_SPEED


def test_speeds_are_scored_against_the_truth(config):
    """``vsegen score`` reports v_x as well as v_y and beta for an estimator that gives them."""
    from vsegen.harness.host.run_log import run_estimator
    from vsegen.harness.score.metrics import score

    log = Case.of("dlc", speed_kmh=80.0).simulate(config, 100.0, 1)
    scores = {s.signal: s for s in score(log, run_estimator(config, pf.IMPROVED, log))}
    assert set(scores) == {"beta", "vx", "vy"}
    expected = np.sqrt(np.mean((run_estimator(config, pf.IMPROVED, log)["vx"] - log["vx_ref"]) ** 2))
    assert scores["vx"].rmse == pytest.approx(expected, rel=1e-12)
