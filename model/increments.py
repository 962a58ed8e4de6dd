"""Pair arithmetic: a function at x + s and x - s, split so that nothing cancels.

With the paper's UT spread (alpha = 0.001, docs/methods.md, seed 002 C6) the sigma
points x +- s differ from the centre x by about 2.4e-3 standard deviations, and the UT weights are
about +-1e6. The mean needs F(x + s) + F(x - s) - 2 F(x), a second-order quantity: computed from
the values F(x +- s), the rounding of F (a yaw moment of thousands of N*m) is multiplied by 1e6 -
tenths of a m/s on the speed in float32, 1e-9 relative in double.

A :class:`Pair` holds a value's base b = F(x), its odd part o and its even part e, with
F(x +- s) = b +- o + e. Each operation returns the parts of its result from identities in which
every term is of the order of the part it contributes to, e.g. for a product
(a +- p + f)(b +- q + g) = ab +- (aq + pb + pg + fq) + (ag + fb + pq + fg). So an even part is
computed from second-order terms only, to its own relative precision. A function written with
+, -, *, / and the :func:`sqrt`, :func:`fmax`, :func:`fmin` below runs unchanged on plain CasADi
values (the centre) and on pairs (a pair of sigma points).

Where an ``fmax``/``fmin`` switches branch inside x +- s, the parts come from the two values
directly; the function is continuous there, so the parts stay of the order of the step.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

TINY = 1e-30
"""Guard of sqrt's parts when all its arguments are zero (then the parts are 0)."""


@dataclass(frozen=True)
class Pair:
    """F(x +- s) = base +- odd + even."""

    base: ca.SX
    odd: ca.SX
    even: ca.SX

    def at(self, sign: int) -> ca.SX:
        """The value at x + s (sign 1) or x - s (sign -1)."""
        return self.base + sign * self.odd + self.even

    def __add__(self, other: Value) -> Pair:
        other = lift(other)
        return Pair(self.base + other.base, self.odd + other.odd, self.even + other.even)

    __radd__ = __add__

    def __neg__(self) -> Pair:
        return Pair(-self.base, -self.odd, -self.even)

    def __sub__(self, other: Value) -> Pair:
        return self + (-lift(other))

    def __rsub__(self, other: Value) -> Pair:
        return lift(other) + (-self)

    def __mul__(self, other: Value) -> Pair:
        other = lift(other)
        a, p, f = self.base, self.odd, self.even
        b, q, g = other.base, other.odd, other.even
        return Pair(a * b, a * q + p * b + p * g + f * q, a * g + f * b + p * q + f * g)

    __rmul__ = __mul__

    def __truediv__(self, other: Value) -> Pair:
        """(a +- p + f)/(b +- q + g) - a/b = (+-P + E)/(b +- q + g) with P = (p b - a q)/b,
        E = (f b - a g)/b; then odd = (P (b + g) - E q)/D and even = (E (b + g) - P q)/D with
        D = (b + q + g)(b - q + g)."""
        other = lift(other)
        a, p, f = self.base, self.odd, self.even
        b, q, g = other.base, other.odd, other.even
        P, E = (p * b - a * q) / b, (f * b - a * g) / b
        D = other.at(1) * other.at(-1)
        return Pair(a / b, (P * (b + g) - E * q) / D, (E * (b + g) - P * q) / D)

    def __rtruediv__(self, other: Value) -> Pair:
        return lift(other) / self


Value = Pair | ca.SX | float


def lift(value: Value) -> Pair:
    """A plain value as a :class:`Pair` with no odd or even part."""
    return value if isinstance(value, Pair) else Pair(ca.SX(value), ca.SX(0), ca.SX(0))


def sqrt(x: Value) -> Value:
    """sqrt: with r = sqrt(b), r+- = sqrt(x +- s), d+- = (+-p + f)/(r+- + r) are the increments;
    odd = (d+ - d-)/2, even = (d+ + d-)/2 with d+ - d- and d+ + d- written without cancellation
    (r- - r+ = -2p / (r+ + r-))."""
    if not isinstance(x, Pair):
        return ca.sqrt(x)
    root = ca.sqrt(x.base)
    plus, minus = ca.sqrt(x.at(1)), ca.sqrt(x.at(-1))
    s_plus, s_minus = ca.fmax(plus + root, TINY), ca.fmax(minus + root, TINY)
    # 1/s+ + 1/s- and 1/s+ - 1/s- (= (s- - s+)/(s+ s-), s- - s+ = minus - plus)
    total = (s_plus + s_minus) / (s_plus * s_minus)
    gap = (-2 * x.odd / ca.fmax(plus + minus, TINY)) / (s_plus * s_minus)
    p, f = x.odd, x.even
    return Pair(root, (p * total + f * gap) / 2, (p * gap + f * total) / 2)


def fmax(x: Value, y: Value) -> Value:
    """max(x, y): the parts of the branch taken at the centre and both points, else (a switch
    inside the pair) the parts of the two values."""
    if not isinstance(x, Pair) and not isinstance(y, Pair):
        return ca.fmax(x, y)
    x, y = lift(x), lift(y)
    base = ca.fmax(x.base, y.base)
    x_all = ca.logic_and(x.base >= y.base,
                         ca.logic_and(x.at(1) >= y.at(1), x.at(-1) >= y.at(-1)))
    y_all = ca.logic_and(x.base < y.base, ca.logic_and(x.at(1) < y.at(1), x.at(-1) < y.at(-1)))
    up = ca.fmax(x.at(1), y.at(1)) - base
    down = ca.fmax(x.at(-1), y.at(-1)) - base
    odd = ca.if_else(x_all, x.odd, ca.if_else(y_all, y.odd, (up - down) / 2))
    even = ca.if_else(x_all, x.even, ca.if_else(y_all, y.even, (up + down) / 2))
    return Pair(base, odd, even)


def fmin(x: Value, y: Value) -> Value:
    """min(x, y) = -max(-x, -y)."""
    return -fmax(-x, -y)
