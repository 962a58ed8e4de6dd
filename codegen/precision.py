"""Single precision for CasADi output: CasADi types its variables ``casadi_real`` but keeps double
literals (``3.``, ``8.99e-02``) and double math calls (``atan2``, ``fabs``, ...), which drag
soft-double code onto a single-precision FPU. :func:`to_single` rewrites both in the code lines
(comments and preprocessor lines untouched): literals get an ``f`` suffix, math calls their C99
``f`` variant. Tested by compiling with -Wdouble-promotion -Werror and by listing the undefined
symbols of Cortex-M4F objects (no ``__aeabi_d*``, no double libm function).
"""

from __future__ import annotations

import re

MATH_FUNCTIONS = ("acos", "asin", "atan", "atan2", "ceil", "copysign", "cos", "cosh", "erf", "exp",
                  "fabs", "floor", "fmax", "fmin", "fmod", "log", "pow", "sin", "sinh", "sqrt",
                  "tan", "tanh")
_CALL = re.compile(r"(?<![\w.])(" + "|".join(MATH_FUNCTIONS) + r")\(")
_LITERAL = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][+-]?\d+)?|\d+[eE][+-]?\d+|\.\d+(?:[eE][+-]?\d+)?)(?![\w.])")


def to_single(c_text: str) -> str:
    """``c_text`` with float literals and single-precision math calls in its code lines."""
    lines = []
    for line in c_text.splitlines(keepends=True):
        stripped = line.lstrip()
        if not stripped.startswith(("/*", "*", "//", "#")):
            line = _CALL.sub(r"\1f(", _LITERAL.sub(r"\1f", line))
        lines.append(line)
    return "".join(lines)


def literal(value: float, real: str) -> str:
    """A C literal of ``value`` for type ``real`` (shortest round-trip repr, ``f`` for float)."""
    text = repr(float(value))
    if "e" not in text and "." not in text:
        text += ".0"
    return text + ("f" if real == "float" else "")
