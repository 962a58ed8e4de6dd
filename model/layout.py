"""Named layouts of flat vectors (state, input, output) and the signal descriptions behind them."""

from __future__ import annotations

import re
from dataclasses import dataclass

import casadi as ca

from vsegen.model.kalman import packed_names
from vsegen.model.signals import Signal


def unit_product(a: str, b: str) -> str:
    """The unit of a product of quantities in units ``a`` and ``b``, e.g. ``(m/s)^2``,
    ``rad^2``, ``(m/s)*(rad/s)``."""
    def factor(unit: str) -> str:
        return unit if re.fullmatch(r"[A-Za-z]+", unit) else f"({unit})"
    return f"{factor(a)}^2" if a == b else f"{factor(a)}*{factor(b)}"


def covariance_signals(prefix: str, states: tuple[Signal, ...], names: tuple[str, ...] | None = None,
                       doc: str = "covariance entry (upper triangle, row by row)") -> tuple[Signal, ...]:
    """The stored entries of the covariance of ``states``, named as ``model.kalman.packed_names``
    gives them (``names`` instead of the states' names if given), each in the product of its two
    states' units and judged at the product of their scales."""
    entries = packed_names(prefix, names or tuple(s.name for s in states))
    pairs = [(a, b) for i, a in enumerate(states) for b in states[i:]]
    return tuple(Signal(name, unit_product(a.unit, b.unit), doc, scale=a.scale * b.scale)
                 for name, (a, b) in zip(entries, pairs, strict=True))


@dataclass(frozen=True)
class Layout:
    """The ordered entries of a flat vector."""

    signals: tuple[Signal, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.signals)

    @property
    def scales(self) -> tuple[float, ...]:
        return tuple(s.scale for s in self.signals)

    def __len__(self) -> int:
        return len(self.signals)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def symbols(self, label: str) -> tuple[ca.SX, dict[str, ca.SX]]:
        """A symbolic vector named ``label`` and its entries by name."""
        vector = ca.SX.sym(label, len(self))
        return vector, {name: vector[i] for i, name in enumerate(self.names)}

    def pack(self, values: dict[str, ca.SX]) -> ca.SX:
        """The flat vector from entries by name (every name exactly once)."""
        missing = set(self.names) - set(values)
        extra = set(values) - set(self.names)
        if missing or extra:
            raise ValueError(f"layout mismatch: missing {sorted(missing)}, extra {sorted(extra)}")
        return ca.vertcat(*[values[name] for name in self.names])
