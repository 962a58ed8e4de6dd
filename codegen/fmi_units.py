"""The SI base-unit exponents of a vsegen unit, for an FMU's <UnitDefinitions>.

The signal catalogue and the vehicle-file schema write units as "m/s^2", "kg*m^2",
"(rad/s^2)^2*s" or "rad/(m/s^2)": products ('*'), quotients ('/', binding its next factor only),
integer powers ('^') and parentheses over the symbols of :data:`SYMBOLS` and "1". Anything else
(a dimensionless "-", or prose such as "SI units squared") has no base units: the FMU variable then
carries no unit and its description says it in words.
"""

from __future__ import annotations

import re

SYMBOLS: dict[str, dict[str, int]] = {
    "kg": {"kg": 1},
    "m": {"m": 1},
    "s": {"s": 1},
    "rad": {"rad": 1},
    "N": {"kg": 1, "m": 1, "s": -2},
}
"""The unit symbols vsegen writes, as exponents of the FMI base units (kg, m, s, rad)."""

_TOKEN = re.compile(r"\s*(\d+|[A-Za-z]+|[()*/^-])")


def base_units(unit: str) -> dict[str, int] | None:
    """The exponents of ``unit`` over the FMI base units, e.g. "N/rad" -> {"kg": 1, "m": 1, "s": -2,
    "rad": -1}; None if ``unit`` is not an expression of :data:`SYMBOLS` (prose, "-")."""
    tokens = _tokens(unit)
    if not tokens:
        return None
    parser = _Parser(tokens)
    try:
        exponents = parser.product()
    except ValueError:
        return None
    return exponents if parser.done() else None


def _tokens(unit: str) -> list[str] | None:
    tokens, position = [], 0
    while position < len(unit.rstrip()):
        match = _TOKEN.match(unit, position)
        if not match:
            return None
        tokens.append(match.group(1))
        position = match.end()
    return tokens


class _Parser:
    """Recursive descent over: product := power (('*' | '/') power)*; power := atom ['^' ['-'] int];
    atom := symbol | '1' | '(' product ')'."""

    def __init__(self, tokens: list[str]):
        self.tokens = tokens
        self.at = 0

    def done(self) -> bool:
        return self.at == len(self.tokens)

    def _next(self) -> str | None:
        return self.tokens[self.at] if self.at < len(self.tokens) else None

    def _take(self) -> str:
        token = self._next()
        if token is None:
            raise ValueError("unexpected end")
        self.at += 1
        return token

    def product(self) -> dict[str, int]:
        result = self.power()
        while self._next() in ("*", "/"):
            sign = 1 if self._take() == "*" else -1
            result = _combine(result, self.power(), sign)
        return result

    def power(self) -> dict[str, int]:
        base = self.atom()
        if self._next() != "^":
            return base
        self._take()
        sign = -1 if self._next() == "-" and self._take() else 1
        exponent = self._take()
        if not exponent.isdigit():
            raise ValueError(f"exponent {exponent!r}")
        return {k: v * sign * int(exponent) for k, v in base.items()}

    def atom(self) -> dict[str, int]:
        token = self._take()
        if token == "(":
            inner = self.product()
            if self._take() != ")":
                raise ValueError("unbalanced parenthesis")
            return inner
        if token == "1":
            return {}
        if token in SYMBOLS:
            return dict(SYMBOLS[token])
        raise ValueError(f"symbol {token!r}")


def _combine(left: dict[str, int], right: dict[str, int], sign: int) -> dict[str, int]:
    combined = dict(left)
    for key, value in right.items():
        combined[key] = combined.get(key, 0) + sign * value
    return {k: v for k, v in combined.items() if v != 0}
