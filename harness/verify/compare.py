"""Numeric equivalence of two runs: the project's tolerances live here and only here.

Relative difference with a guard near zero: |a - b| / max(|a|, |b|, floor, g), where
g = PEAK_FRACTION x the signal's peak |value| over the run: a signal that passes through zero is not
held to relative accuracy below 1 % of its own range there. That matters for the open-loop
kinematic integrator, which integrates ulp-level input differences without contraction (measured:
6.7e-15 m/s on a 2 m/s signal after 493 integration steps). Integer outputs (status, mode) must
be identical. Any non-finite value in either run is a failure. ``vsegen verify`` also checks every
step from the same state (no accumulation at all).

* double C against the double reference: 1e-12 relative, floor 1e-3 (SI units);
* float C against the double reference (fed the same float-rounded inputs, which is all the float
  C can see): 1e-4 relative, floor 1 — i.e. 1e-4 absolute for values below 1 (beta within 1e-4 rad,
  the target of the production-C work).

Two refinements, both declared by the estimator's model, not chosen per run:

* a signal whose natural size is not O(1) in SI units (a yaw moment of 1e4 N*m, or an acceleration
  that is the balance of tyre forces of order g) has its floor multiplied by its
  ``Signal.scale``;
* an algorithm that amplifies rounding (``Estimator.rounding_gain``: the unscented transform's
  weights of +-1e6 at the paper's alpha = 0.001; ekf_rls's stiffness rate, a difference quotient
  over one sample; arx_dual_kf's random-walk parameters, which keep every step's rounding) has
  its double tolerance widened by what its reference cannot absorb: the unscented references
  compute in long double, the others in double (:func:`for_estimator`).
  Measured for ukf and aukf over the verification set: up to 1.1e-9 relative against a tolerance
  of 2.1e-8; the float check is unchanged and passes at up to 6.2e-5 (low-speed restart), 2.8e-5
  elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PEAK_FRACTION = 1e-2


@dataclass(frozen=True)
class Tolerance:
    relative: float
    floor: float


TOLERANCES = {"double": Tolerance(1e-12, 1e-3), "float": Tolerance(1e-4, 1.0)}


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


def peak_guard(run: np.ndarray) -> np.ndarray:
    """The PEAK_FRACTION x peak |value| guard of each column of ``run`` (rows: samples)."""
    return np.abs(run).max(axis=0, initial=0.0) * PEAK_FRACTION


def difference(name: str, a: np.ndarray, b: np.ndarray, tolerance: Tolerance,
               integer: bool = False, scale=1.0) -> Difference:
    """Worst absolute and guarded relative difference between runs ``a`` and ``b``; ``scale``
    (per column, or one number) multiplies the floor for signals whose natural size is not O(1)
    in SI units (``model.layout.Signal.scale``)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return Difference(name, np.inf, np.inf, tolerance.relative, integer)
    return Difference(name, float(np.abs(a - b).max(initial=0.0)),
                      float(relative_errors(a, b, tolerance, scale).max(initial=0.0)),
                      tolerance.relative, integer)


def relative_errors(a: np.ndarray, b: np.ndarray, tolerance: Tolerance, scale=1.0,
                    peak: np.ndarray | None = None) -> np.ndarray:
    """The guarded relative difference of every entry of two finite runs (rows: samples).
    ``peak`` (per column) replaces the runs' own PEAK_FRACTION x peak |value| guard, e.g. to
    compare single rows of a run whose peaks are known."""
    magnitude = np.maximum(np.abs(a), np.abs(b))
    if peak is None:
        peak = magnitude.max(axis=0, initial=0.0) * PEAK_FRACTION  # per column of a state matrix
    guard = np.maximum(np.maximum(magnitude, tolerance.floor * np.asarray(scale, float)), peak)
    return np.abs(a - b) / guard


REFERENCE_PRECISION = float(np.finfo(np.longdouble).eps / np.finfo(np.float64).eps)
"""Rounding unit of the long-double reference (the unscented filters') relative to double."""


def for_estimator(real: str, rounding_gain: float,
                  long_double_reference: bool = False) -> Tolerance:
    """The tolerance for code of type ``real`` of an estimator whose algorithm amplifies rounding
    by ``rounding_gain`` (``model.estimator.Estimator``). The double tolerance is widened by what
    the reference cannot absorb of that gain (never narrowed); the float tolerance lies far above
    and stays.

    * The unscented filters: the UT's sum of |weights|, 2e6 at the paper's alpha = 0.001, times the
      tyres' force-per-speed conditioning, about 20. Their reference computes in long double
      (``long_double_reference``), so what remains is gain x REFERENCE_PRECISION (about 2e4).
    * ekf_rls: its fusion weight differences the cornering stiffness over one sample (about 1e2);
      its reference computes in double, so the whole gain remains.
    * arx_dual_kf: its parameters are random walks that keep each step's rounding (10,
      ``model.estimators.arx_dual_kf.PARAMETER_WALK_GAIN``)."""
    base = TOLERANCES[real]
    if real == "double":
        remaining = rounding_gain * (REFERENCE_PRECISION if long_double_reference else 1.0)
        return Tolerance(base.relative * max(1.0, remaining), base.floor)
    return base


def as_seen_by(real: str, inputs: np.ndarray) -> np.ndarray:
    """The inputs as the C of type ``real`` receives them (rounded to float for float code)."""
    if real != "float":
        return inputs
    with np.errstate(over="ignore"):  # beyond float range becomes +-Inf, as in C (IEEE, Annex F)
        return inputs.astype(np.float32).astype(np.float64)
