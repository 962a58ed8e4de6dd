"""Reference pf_improved and pf_adaptive (docs/methods.md, seed 003 §2 with the
§3/§5 defaults): particle state [v_x, v_y, a_x, a_y, r], the corrected transition (14)-(15)
(G = 0: the adaptive PF of ref. [17]), adaptive process noise (16), Gaussian likelihood of (13)
(D2: also v_x), the weighted mean before resampling (17) and systematic resampling (D4), with the
random stream of D5 (``harness.reference.pcg32``) and the normal sampler the vehicle file names
(``harness.reference.normals``). NumPy only, vectorised over the particles.

Project rules as for every estimator: the hold rule on the logged v_x (hold the particles and the
stream; a new particle set on the first sample after a low-speed hold), a_y corrected for body
roll with the roll gradient, the weights normalised relative to the best particle.

The draws are consumed in the order the spec fixes: per particle its five normals in state order,
then one uniform for the resampling. Sums over the particles are taken in particle order, as the C
adds them: the adaptive PF's random walks never contract, so a last-bit difference in the estimate
(which sets the next sigma, (16)) would otherwise accumulate without bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from vsegen.harness.reference import blocks, normals
from vsegen.harness.reference.pcg32 import WORDS, Stream, libm

KINEMATIC = ("vx", "vy", "ax", "ay", "r")
PARTICLE = (*KINEMATIC, "weight")
INPUTS = ("vx", "ax", "ay", "r")
OUTPUTS = ("beta", "vx", "vy", "n_eff", "sigma_ax", "sigma_ay", "sigma_r", "status")
HEAD = (*KINEMATIC, "hold_reason", "drift")
WEIGHT_FLOOR = 1e-30
HOLD, PROPAGATE, SPAWN = 0, 1, 2


@dataclass(frozen=True)
class ParticleFilter:
    """The reference shape (``names``, ``init``, ``step``) of one of the two filters.
    ``uniform_bits``: 53 as the double C draws, 24 as the float C."""

    table: str
    improved: bool
    uniform_bits: int = 53

    def drawing(self, uniform_bits: int) -> ParticleFilter:
        """The same filter drawing uniforms of ``uniform_bits`` bits."""
        return replace(self, uniform_bits=uniform_bits)

    def names(self, config):
        n = config.settings(self.table)["particles"]
        particles = tuple(f"p{i}_{e}" for i in range(n) for e in PARTICLE)
        return INPUTS, (*HEAD, *(f"rng_{i}" for i in range(WORDS)), *particles), OUTPUTS

    def init(self, config, u0):
        s = config.settings(self.table)
        first, holding = blocks.first_sample(config.limits, dict(zip(INPUTS, u0)), s["vx_min"],
                                             s["vx_resume"])
        vx0 = min(max(first["vx"], s["vx_min"]), config.limits["vx_max"])
        z = self._measured(s, first)
        stream = Stream.seeded(s["seed"], s["seed"], self.uniform_bits)
        particles = self._spawn(s, vx0, z, _draws(s, stream))
        head = [vx0, 0.0, *z, 2.0 * holding, _initial_drift(s)]
        return np.concatenate([head, stream.words(), particles.ravel()])

    def step(self, config, state, u):
        new_state, output, _, _ = self._advance(config, state, u)
        return new_state, output

    def alternatives(self, config, state, u, margin: float, decision_margin: float) -> list[tuple]:
        """The decisions of the step from ``state`` that a float build (or another libm) may take
        the other way and still be right: ("resample", point, particle) for a resampling point
        and another particle whose cumulative-weight interval lies within ``margin`` of it, and
        ("draw", number) for a ziggurat wedge or tail test whose sides lie within
        ``decision_margin`` (relative) of each other."""
        _, _, near_points, decisions = self._advance(config, state, u, margin=margin,
                                                     decisions=normals.Decisions(decision_margin))
        return ([("resample", point, particle) for point, particle in near_points]
                + [("draw", number) for number in decisions.near])

    def step_flipped(self, config, state, u, flips: tuple[tuple, ...]):
        """The step from ``state`` with decisions of :meth:`alternatives` taken the other way
        (resampling points at different points; at most one draw, as a flipped draw renumbers
        the draws after it)."""
        points = tuple(flip[1:] for flip in flips if flip[0] == "resample")
        draws = [flip[1] for flip in flips if flip[0] == "draw"]
        decisions = normals.Decisions(flip=draws[0] if draws else None)
        new_state, output, _, _ = self._advance(config, state, u, flip=points, decisions=decisions)
        return new_state, output

    def _advance(self, config, state, u, margin: float = 0.0, flip: tuple = (),
                 decisions: normals.Decisions | None = None):
        s = config.settings(self.table)
        n = s["particles"]
        head = dict(zip(HEAD, state[:len(HEAD)]))
        stream = Stream.from_words(state[len(HEAD):len(HEAD) + WORDS], s["seed"], self.uniform_bits)
        decisions = decisions if decisions is not None else normals.Decisions()
        particles = np.array(state[len(HEAD) + WORDS:], dtype=float).reshape(n, len(PARTICLE))
        inputs = dict(zip(INPUTS, u))
        active, code, _ = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                           head["hold_reason"] > 0.5)
        mode = (SPAWN if head["hold_reason"] > 1.5 else PROPAGATE) if active else HOLD
        estimate = np.array([head[k] for k in KINEMATIC])
        z = self._measured(s, inputs) if active else estimate[2:]
        sigma = self._sigmas(s, z, estimate[2:])
        T = config.sample_time
        sigma_v = np.array(s["speed_noise"]) + T * sigma[:2]
        vx_measured = inputs["vx"] if active else head["vx"]
        if mode == SPAWN:
            particles = self._spawn(s, vx_measured, z, _draws(s, stream, decisions))
        elif mode == PROPAGATE:
            particles = self._propagate(s, T, particles, z, vx_measured, sigma, sigma_v,
                                        _draws(s, stream, decisions))
        weights = particles[:, -1]
        n_eff = 1.0 / _total(weights * weights)
        if mode != HOLD:
            estimate = _total(weights[:, None] * particles[:, :len(KINEMATIC)])
        hold_reason = 0.0 if active else (2.0 if code & blocks.LOW_SPEED else max(head["hold_reason"], 1.0))
        slow = active and estimate[0] < s["vx_min"]
        beta = float(np.arctan2(estimate[1], estimate[0])) if active and not slow else 0.0
        # the bound of the integrated v_y's error (beyond the spec)
        if mode == SPAWN:
            drift = _initial_drift(s)
        elif mode == PROPAGATE:
            drift = head["drift"] + T * (s["drift_acceleration"] + abs(estimate[0]) * s["drift_yaw_rate"])
        else:
            drift = head["drift"]
        if (active and not slow and s["drift_acceleration"] + s["drift_yaw_rate"] > 0
                and drift > np.tan(s["drift_limit"]) * abs(estimate[0])):
            code |= blocks.DEAD_RECKONING
        output = [beta, estimate[0], estimate[1], n_eff, *sigma,
                  float(code | (blocks.LOW_SPEED if slow else 0))]
        near: list[tuple[int, int]] = []
        if mode == PROPAGATE and (s["resampling"] == "every_sample" or n_eff < n / 2):
            particles, near = _resample(particles, stream.uniforms(1)[0], margin, flip)
        new_state = np.concatenate([estimate, [hold_reason, drift], stream.words(), particles.ravel()])
        return new_state, np.array(output, dtype=float), near, decisions

    # ---- blocks ---------------------------------------------------------------------------------

    @staticmethod
    def _measured(s, inputs) -> np.ndarray:
        """z = [a_x, a_y, r], a_y without the gravity component of body roll."""
        return np.array([inputs["ax"], blocks.roll_corrected(inputs["ay"], s["roll_gradient"]),
                         inputs["r"]], dtype=float)

    @staticmethod
    def _sigmas(s, z, previous) -> np.ndarray:
        """(16): random-walk steps of a_x, a_y, r from the innovation of the last estimate."""
        floor, cap = np.array(s["process_noise"]), np.array(s["process_noise_max"])
        gains = np.array([s["adaptation_gain_acceleration"]] * 2 + [s["adaptation_gain_yaw_rate"]])
        return np.clip(floor + gains * np.abs(z - previous), floor, cap)

    @staticmethod
    def _spawn(s, vx, z, draws) -> np.ndarray:
        """(2.9): the measurement plus N(0, diag(spread^2, R)) per particle, weights 1/N."""
        n = s["particles"]
        centre = np.array([vx, 0.0, *z])
        spread = np.array([*s["initial_spread"], *s["measurement_noise"]])
        return np.hstack([centre + spread * draws, np.full((n, 1), 1.0 / n)])

    def _propagate(self, s, T, particles, z, vx_measured, sigma, sigma_v, draws) -> np.ndarray:
        """(14)-(15) for every particle, then the normalised weights."""
        vx, vy, old, weight = particles[:, 0], particles[:, 1], particles[:, 2:5], particles[:, 5]
        gain = np.array(s["correction_gain"]) if self.improved else np.zeros(3)
        correction = gain * (z - old)
        new = old + correction + sigma * draws[:, 2:]
        mean = (old + new) / 2
        ax, ay, r = mean[:, 0], mean[:, 1], mean[:, 2]
        vx_new = vx + T * (ax + r * vy) + sigma_v[0] * draws[:, 0]
        vy_new = vy + T * (ay - r * vx) + sigma_v[1] * draws[:, 1]
        log_weight = -0.5 * np.sum(((z - new) / np.array(s["measurement_noise"])) ** 2, axis=1)
        if s["observation"] == "wheel_speed":
            log_weight -= 0.5 * ((vx_measured - vx_new) / s["wheel_speed_noise"]) ** 2
        if self.improved and s["weights"] == "exact_importance":
            # prior over proposal density of the corrected entries, N(f, s^2) / N(f + c, s^2)
            shift = new - old
            log_weight += np.sum(((shift - correction) ** 2 - shift ** 2) / (2 * sigma ** 2), axis=1)
        if s["resampling"] == "effective_size":
            log_weight += libm(math.log, np.maximum(weight, WEIGHT_FLOOR))
        likelihood = libm(math.exp, log_weight - log_weight.max())
        return np.column_stack([vx_new, vy_new, new, likelihood / _total(likelihood)])


def _draws(s, stream: Stream, decisions: normals.Decisions | None = None) -> np.ndarray:
    """Every particle's five normals, particle by particle, in state order (D5)."""
    n = s["particles"]
    if s["normals"] == "box_muller":
        draws = normals.box_muller(stream, n * len(KINEMATIC))
    else:
        draws = normals.ziggurat(stream, n * len(KINEMATIC), decisions)
    return draws.reshape(n, len(KINEMATIC))


def _initial_drift(s) -> float:
    """The v_y error bound when particles are drawn: 3 sigma of their v_y spread (m/s)."""
    return 3.0 * s["initial_spread"][1]


def _total(terms: np.ndarray) -> np.ndarray:
    """The sum over particles (axis 0) in particle order, as the C adds."""
    return np.cumsum(terms, axis=0)[-1]


def _resample(particles: np.ndarray, u: float, margin: float = 0.0,
              flip: tuple[tuple[int, int], ...] = ()) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Systematic resampling (D4): point j = (u + j) / N selects the first particle whose
    cumulative weight exceeds it (the last one of positive weight when rounding leaves the point
    beyond the total). Each selected particle keeps its slot; its extra copies fill, in particle
    order, the slots of the particles not selected. Weights become 1 / N.

    Also returns (point, particle) for every other particle of positive weight whose interval
    [c_(i-1), c_i) lies within ``margin`` of a point; each (point, particle) of ``flip`` makes
    that point select that particle (see ``ParticleFilter.step_flipped``)."""
    n = len(particles)
    weights = particles[:, -1]
    points = (u + np.arange(n)) / n
    cumulative = np.cumsum(weights)
    chosen = np.searchsorted(cumulative, points, side="right")
    chosen[chosen >= n] = np.flatnonzero(weights > 0)[-1]
    near = []
    if margin > 0:
        low = np.searchsorted(cumulative, points - margin, side="right")
        high = np.minimum(np.searchsorted(cumulative, points + margin, side="right"), n - 1)
        near = [(j, i) for j in np.flatnonzero(high > low) for i in range(low[j], high[j] + 1)
                if i != chosen[j] and weights[i] > 0]
    for point, particle in flip:
        chosen[point] = particle
    copies = np.bincount(chosen, minlength=n)
    order = np.arange(n)
    order[copies == 0] = np.repeat(np.arange(n), np.maximum(copies - 1, 0))
    result = particles[order].copy()
    result[:, -1] = 1.0 / n
    return result, near
