"""Standard normal draws from a PCG32 stream, as the particle filters' C draws them (NumPy).

Two samplers (the vehicle file's ``normals`` setting):

* ``box_muller``, the spec's D5: sqrt(-2 ln(1 - u1)) cos(2 pi u2), two uniforms per normal;
* ``ziggurat`` (G. Marsaglia, W. W. Tsang, J. Stat. Softw. 5(8), 2000; 128 layers; tables
  computed here from the published recurrence, independently of the generator's): one 32-bit
  output b per draw in 97.2 % of the draws. Layer i = b & 127, the sign is bit 7, the magnitude
  m = b >> 8 (24 bits), x = m WIDTH[i]; accepted at once when m < CORE[i]. Otherwise: layer 0
  draws from the tail, a = -ln(1 - u1) / r, c = -ln(1 - u2), until c + c >= a a, then x = r + a;
  a layer i > 0 accepts x when FLOOR[i] + u HEIGHT[i] < exp(-x x / 2) and else draws b anew.

The float C computes in float: the reference then rounds each operation to float as IEEE single
does (NumPy float32), and exp and ln as the correctly rounded value of the double result. A
float libm's expf/logf may round the other way (they are not correctly rounded), which can flip a
wedge or tail decision that lies within an ulp: every decision closer than a margin is recorded
(``Decisions``) so a verification can try the other outcome, as it does for resampling.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vsegen.harness.reference.pcg32 import OUTPUTS_PER_UNIFORM, Stream, libm, uniforms_from

LAYERS = 128
EDGE = 3.442619855899
AREA = 9.91256303526217e-3
MAGNITUDE_BITS = 24


def _tables() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(CORE, WIDTH, FLOOR, HEIGHT) from Marsaglia and Tsang's recurrence: layer edges
    x_127 = r, x_(i-1) = sqrt(-2 ln(v / x_i + exp(-x_i^2 / 2))), x_0 = 0; the base layer's width
    v / exp(-r^2 / 2)."""
    scale = float(1 << MAGNITUDE_BITS)
    x = np.zeros(LAYERS)
    x[-1] = EDGE
    for i in range(LAYERS - 1, 1, -1):
        x[i - 1] = math.sqrt(-2.0 * math.log(AREA / x[i] + math.exp(-0.5 * x[i] * x[i])))
    base = AREA / math.exp(-0.5 * EDGE * EDGE)
    floor = np.array([1.0] + [math.exp(-0.5 * float(v) * float(v)) for v in x[1:]])
    core = np.array([math.floor(scale * EDGE / base), 0]
                    + [math.floor(scale * float(x[i - 1]) / float(x[i])) for i in range(2, LAYERS)],
                    dtype=np.uint64)
    width = np.concatenate([[base / scale], x[1:] / scale])
    height = np.concatenate([[0.0], floor[:-1] - floor[1:]])
    return core, width, floor, height


CORE, WIDTH, FLOOR, HEIGHT = _tables()


@dataclass
class Decisions:
    """The ziggurat's wedge and tail decisions of one run of draws, numbered in draw order:
    ``near`` collects those whose two sides lie within ``margin`` (relative) of each other;
    ``flip`` (a number) takes the other outcome of that decision."""

    margin: float = 0.0
    flip: int | None = None
    near: list[int] = field(default_factory=list)
    count: int = 0

    def take(self, smaller: float, larger: float) -> bool:
        """The outcome of ``smaller < larger``, recorded and possibly flipped."""
        number, self.count = self.count, self.count + 1
        if abs(larger - smaller) <= self.margin * abs(larger):
            self.near.append(number)
        return (smaller < larger) != (number == self.flip)


def box_muller(stream: Stream, n: int) -> np.ndarray:
    """``n`` normals by the cosine branch of Box-Muller, two uniforms each, in order."""
    u = stream.uniforms(2 * n).reshape(n, 2)
    return np.sqrt(-2.0 * libm(math.log, 1.0 - u[:, 0])) * libm(math.cos, 2.0 * np.pi * u[:, 1])


def ziggurat(stream: Stream, n: int, decisions: Decisions | None = None) -> np.ndarray:
    """``n`` normals by the ziggurat, in order: the stream's next outputs are read as a block, the
    at-once accepted draws computed together, the others one at a time."""
    decisions = decisions if decisions is not None else Decisions()
    arithmetic = _Arithmetic(single=stream.uniform_bits == 24)
    words = _Words(stream, n + n // 8 + 64)
    out = np.empty(n)
    filled = 0
    while filled < n:
        if words.at == len(words.block):
            words.refill()
        layer = (words.block & np.uint64(LAYERS - 1)).astype(np.intp)
        starts_beyond = np.flatnonzero((words.block >> np.uint64(8)) >= CORE[layer])
        cores, block = arithmetic.signed_core(words.block, layer), words.block
        while filled < n and words.at < len(block) and words.block is block:
            beyond = starts_beyond[np.searchsorted(starts_beyond, words.at):]
            run = min((int(beyond[0]) if len(beyond) else len(words.block)) - words.at, n - filled)
            out[filled:filled + run] = cores[words.at:words.at + run]
            words.at += run
            filled += run
            if filled < n and words.at < len(words.block):
                out[filled] = _beyond_core(words, arithmetic, decisions)
                filled += 1
    words.release()
    return out


class _Words:
    """The stream's next outputs, read a block at a time; ``release`` leaves the stream after
    the ones taken."""

    def __init__(self, stream: Stream, size: int):
        self.stream, self.size = stream, size
        self.block, self.at = stream.peek(size), 0

    def refill(self) -> None:
        self.release()
        self.block, self.at = self.stream.peek(self.size), 0

    def release(self) -> None:
        self.stream.outputs(self.at)
        self.at = 0

    def next(self) -> int:
        if self.at == len(self.block):
            self.refill()
        self.at += 1
        return int(self.block[self.at - 1])

    def uniform(self) -> float:
        """As ``Stream.uniforms``: 24 bits of one output or 53 bits of two."""
        bits = self.stream.uniform_bits
        return float(uniforms_from([self.next() for _ in range(OUTPUTS_PER_UNIFORM[bits])], bits)[0])


@dataclass(frozen=True)
class _Arithmetic:
    """The C's arithmetic: double, or (``single``) every operation rounded to float."""

    single: bool

    def real(self, value):
        return np.float32(value) if self.single else float(value)

    def exp(self, value):
        return self.real(math.exp(float(value)))

    def log(self, value):
        return self.real(math.log(float(value)))

    def signed_core(self, bits: np.ndarray, layer: np.ndarray) -> np.ndarray:
        """m WIDTH[i] with the sign of bit 7, for the draws ``bits`` of layers ``layer``."""
        magnitude = bits >> np.uint64(8)
        dtype = np.float32 if self.single else np.float64
        x = magnitude.astype(dtype) * WIDTH.astype(dtype)[layer]
        return np.where((bits >> np.uint64(7)) & np.uint64(1), -x, x).astype(float)


def _beyond_core(words: _Words, a: _Arithmetic, decisions: Decisions) -> float:
    """One draw that starts outside a layer's core: the tail, or wedge tests until accepted."""
    while True:
        bits = words.next()
        layer, negative, magnitude = bits & (LAYERS - 1), (bits >> 7) & 1, bits >> 8
        x = a.real(magnitude) * a.real(WIDTH[layer])
        if magnitude >= int(CORE[layer]):
            if layer == 0:
                x = _tail(words, a, decisions)
            else:
                y = a.real(FLOOR[layer]) + a.real(words.uniform()) * a.real(HEIGHT[layer])
                if not decisions.take(y, a.exp(a.real(-0.5) * x * x)):
                    continue
        return -float(x) if negative else float(x)


def _tail(words: _Words, a: _Arithmetic, decisions: Decisions):
    """Marsaglia's tail beyond r: a = -ln(1 - u1) / r, c = -ln(1 - u2) until c + c >= a a."""
    one, edge = a.real(1.0), a.real(EDGE)
    while True:
        excess = -a.log(one - a.real(words.uniform())) / edge
        c = -a.log(one - a.real(words.uniform()))
        if not decisions.take(c + c, excess * excess):
            return edge + excess
