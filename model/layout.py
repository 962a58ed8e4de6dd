"""Named layouts of flat vectors (state, input, output) and the signal descriptions behind them."""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca


@dataclass(frozen=True)
class Signal:
    """One entry of a flat vector: name (a log column for inputs), unit, meaning, C type kind."""

    name: str
    unit: str
    doc: str
    integer: bool = False
    scale: float = 1.0
    """Magnitude (in ``unit``) at which rounding of this entry is judged: the equivalence check's
    floor is multiplied by it. 1 for the O(1) SI signals; e.g. about 1e4 for a car's yaw moment in
    N*m, whose rounding comes from force moments of that size."""


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
