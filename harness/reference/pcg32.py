"""The particle filters' random stream, from its published definition (NumPy, vectorised).

PCG32 (M. E. O'Neill, "PCG: A Family of Simple Fast Space-Efficient Statistically Good Algorithms
for Random Number Generation", 2014; pcg-random.org's ``pcg32_random_r``): a 64-bit LCG
s' = a s + c (mod 2^64), a = 6364136223846793005, c = 2 seq + 1, whose output from the old state
is the XSH RR permutation: x = ((s >> 18) ^ s) >> 27 (32 bits), rotated right by s >> 59.
Seeding ``pcg32_srandom_r(init, seq)``: s = 0, step, s += init, step.

On top (docs/methods.md, seed 003 D5): uniforms in [0, 1) of 53 bits from two outputs
((x1 >> 5) 2^26 + (x2 >> 6)) 2^-53, or of 24 bits from one, (x >> 8) 2^-24 (the float C).
Normal draws from the stream: ``harness.reference.normals``.

A block of n outputs is computed at once by jumping ahead: s_j = a^j s + c (a^(j-1) + ... + 1),
with the powers tabulated once (uint64 arithmetic wraps modulo 2^64, as the LCG needs).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

MULTIPLIER = 6364136223846793005
MASK = (1 << 64) - 1
WORD_BITS = 16
WORDS = 4


def _jumps(increment: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(a^j, c (a^(j-1) + ... + 1)) mod 2^64 for j = 0 .. n (at least), as uint64."""
    return _jump_table(increment, max(1024, 1 << (n - 1).bit_length()))


@lru_cache(maxsize=8)
def _jump_table(increment: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    factors, offsets = [1], [0]
    for _ in range(n):
        factors.append(factors[-1] * MULTIPLIER & MASK)
        offsets.append((offsets[-1] * MULTIPLIER + increment) & MASK)
    return np.array(factors, dtype=np.uint64), np.array(offsets, dtype=np.uint64)


class Stream:
    """One PCG32 stream with increment 2 ``sequence`` + 1."""

    def __init__(self, state: int, sequence: int, uniform_bits: int = 53):
        if uniform_bits not in (24, 53):
            raise ValueError(f"uniform_bits {uniform_bits}: expected 24 or 53")
        self.state = state & MASK
        self.increment = (2 * sequence + 1) & MASK
        self.uniform_bits = uniform_bits

    @classmethod
    def seeded(cls, initial: int, sequence: int, uniform_bits: int = 53) -> Stream:
        """``pcg32_srandom_r(initial, sequence)``."""
        stream = cls(0, sequence, uniform_bits)
        stream.outputs(1)
        stream.state = (stream.state + initial) & MASK
        stream.outputs(1)
        return stream

    @classmethod
    def from_words(cls, words, sequence: int, uniform_bits: int = 53) -> Stream:
        """The stream whose state is stored as 16-bit words, most significant first."""
        state = 0
        for word in words:
            state = (state << WORD_BITS) | int(word)
        return cls(state, sequence, uniform_bits)

    def words(self) -> list[float]:
        """The state as 16-bit words, most significant first."""
        return [float((self.state >> (WORD_BITS * (WORDS - 1 - i))) & 0xFFFF) for i in range(WORDS)]

    def outputs(self, n: int) -> np.ndarray:
        """The next ``n`` 32-bit outputs (uint64 values)."""
        factors, offsets = _jumps(self.increment, max(n, 1))
        with np.errstate(over="ignore"):
            states = factors[:n] * np.uint64(self.state) + offsets[:n]
        self.state = (int(factors[n]) * self.state + int(offsets[n])) & MASK
        shifted = ((states >> np.uint64(18)) ^ states) >> np.uint64(27) & np.uint64(0xFFFFFFFF)
        rotation = states >> np.uint64(59)
        left = (np.uint64(32) - rotation) & np.uint64(31)
        return ((shifted >> rotation) | (shifted << left)) & np.uint64(0xFFFFFFFF)

    def peek(self, n: int) -> np.ndarray:
        """The next ``n`` outputs, leaving the stream where it is."""
        state = self.state
        outputs = self.outputs(n)
        self.state = state
        return outputs

    def uniforms(self, n: int) -> np.ndarray:
        """``n`` uniforms in [0, 1)."""
        return uniforms_from(self.outputs(OUTPUTS_PER_UNIFORM[self.uniform_bits] * n), self.uniform_bits)


OUTPUTS_PER_UNIFORM = {24: 1, 53: 2}


def uniforms_from(outputs: np.ndarray, uniform_bits: int) -> np.ndarray:
    """Uniforms in [0, 1) of ``uniform_bits`` bits from consecutive 32-bit ``outputs``: (x >> 8)
    2^-24 from one, or ((x1 >> 5) 2^26 + (x2 >> 6)) 2^-53 from two."""
    outputs = np.asarray(outputs, dtype=np.uint64)
    if uniform_bits == 24:
        return (outputs >> np.uint64(8)).astype(float) * 2.0 ** -24
    pairs = outputs.reshape(-1, 2)
    high = (pairs[:, 0] >> np.uint64(5)).astype(float)
    low = (pairs[:, 1] >> np.uint64(6)).astype(float)
    return (high * 67108864.0 + low) * 2.0 ** -53


def libm(function, x: np.ndarray) -> np.ndarray:
    """``function`` of the C library (Python's ``math``) on every entry of ``x``. NumPy's own
    vectorised log and exp differ from the C library's in the last bit for some arguments (measured:
    0.4 % of logs, 5 % of exps); the C calls the C library, so the reference does too, and its
    draws are the C's bit for bit."""
    return np.fromiter(map(function, x), dtype=float, count=len(x))
