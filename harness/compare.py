"""Numeric equivalence of two runs: the project's tolerance lives here and only here.

Relative difference with a guard near zero (design.md): |a - b| / max(|a|, |b|, FLOOR). Integer
outputs (status, mode) must be identical. Any non-finite value in either run is a failure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RELATIVE_TOLERANCE = {"double": 1e-12}
"""Largest accepted relative difference between generated C and the NumPy reference."""
FLOOR = 1e-3
"""Guard of the relative difference (SI units): values below it are compared absolutely, at
RELATIVE_TOLERANCE x FLOOR."""


@dataclass(frozen=True)
class Difference:
    """Worst case of one signal over a run."""

    name: str
    max_abs: float
    max_rel: float
    tolerance: float
    integer: bool

    @property
    def ok(self) -> bool:
        if not (np.isfinite(self.max_abs) and np.isfinite(self.max_rel)):
            return False
        return self.max_abs == 0.0 if self.integer else self.max_rel <= self.tolerance


def difference(name: str, a: np.ndarray, b: np.ndarray, tolerance: float,
               integer: bool = False) -> Difference:
    """Worst absolute and guarded relative difference between runs ``a`` and ``b``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return Difference(name, np.inf, np.inf, tolerance, integer)
    delta = np.abs(a - b)
    scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), FLOOR)
    return Difference(name, float(delta.max(initial=0.0)), float((delta / scale).max(initial=0.0)),
                      tolerance, integer)
