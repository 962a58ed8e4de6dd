"""The ziggurat tables of the particle filters' normal sampler (G. Marsaglia, W. W. Tsang, "The
Ziggurat Method for Generating Random Variables", J. Stat. Softw. 5(8), 2000: 128 layers of equal
area v under the standard normal density's kernel f(x) = exp(-x^2 / 2), base layer's edge r).

Layer edges e_127 = r > e_126 > ... > e_1 > e_0 = 0, from e_(i-1) = sqrt(-2 ln(v / e_i + f(e_i))).
Layer i >= 1 spans heights f(e_i) .. f(e_(i-1)) and widths 0 .. e_i; layer 0 is the base strip of
width q = v / f(r) (the rectangle 0 .. r and the tail beyond r). One 32-bit draw b picks the layer
i = b & 127, the sign (bit 7) and a 24-bit magnitude m = b >> 8; x = m WIDTH[i]. It is accepted at
once when m < CORE[i] (x inside the part of the layer wholly under the curve: 97.2 % of draws, an
integer comparison, exact in any precision); else the tail (layer 0) or the wedge test of layer i:
FLOOR[i] + u HEIGHT[i] < exp(-x^2 / 2) with u uniform, redrawing b on rejection. The draw sequence
is written out in the template (particles.c.j2) and in the reference (harness.reference.pcg32).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

LAYERS = 128
EDGE = 3.442619855899
"""r, the base layer's edge (Marsaglia and Tsang's value for 128 layers)."""
AREA = 9.91256303526217e-3
"""v, each layer's area under f(x) = exp(-x^2 / 2)."""
MAGNITUDE_BITS = 24


@dataclass(frozen=True)
class Tables:
    """Per layer: ``core`` (integer bound of an at-once accepted magnitude), ``width`` (x per unit
    of magnitude), ``floor`` (f at the layer's outer edge) and ``height`` (the layer's height in
    f, 0 for the base layer, which has no wedge)."""

    core: tuple[int, ...]
    width: tuple[float, ...]
    floor: tuple[float, ...]
    height: tuple[float, ...]


def tables() -> Tables:
    """The 128-layer tables (double; a float build rounds each entry once)."""
    scale = float(1 << MAGNITUDE_BITS)
    base_width = AREA / math.exp(-0.5 * EDGE * EDGE)
    edges = [EDGE]
    for _ in range(LAYERS - 2):
        outer = edges[-1]
        edges.append(math.sqrt(-2.0 * math.log(AREA / outer + math.exp(-0.5 * outer * outer))))
    edges = [0.0, *reversed(edges)]               # e_0 = 0, e_1 .. e_127 = r
    floor = [1.0, *(math.exp(-0.5 * e * e) for e in edges[1:])]
    core = [math.floor(scale * EDGE / base_width), 0,
            *(math.floor(scale * edges[i - 1] / edges[i]) for i in range(2, LAYERS))]
    width = [base_width / scale, *(e / scale for e in edges[1:])]
    height = [0.0, *(floor[i - 1] - floor[i] for i in range(1, LAYERS))]
    return Tables(tuple(core), tuple(width), tuple(floor), tuple(height))
