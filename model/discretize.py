"""Discretisation of linear continuous-time models x' = A x + B u at sample time T.

Three methods, all symbolic (A may depend on SX parameters such as vx):

* ``euler``:  Phi = I + A T, Gamma = B T.
* ``tustin``: Phi = (I - A T/2)^-1 (I + A T/2), Gamma = (I - A T/2)^-1 B T  (bilinear, as
  ``scipy.signal.cont2discrete(..., method="bilinear")``).
* ``zoh``:    exact zero-order hold Phi = e^(A T), Gamma = (integral_0^T e^(A s) ds) B, evaluated by a
  Taylor series with scaling and squaring whose truncation error is bounded (see :func:`plan_zoh`).

With the input held over the sample (ZOH), x_k+1 = Phi x_k + Gamma u_k.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

ZOH_SCALED_NORM = 0.5
"""Scaling target: ||A T / 2^s|| <= this before the series is summed."""
ZOH_REMAINDER = 1e-17
"""Target bound of the Taylor remainder of one scaled series."""


@dataclass(frozen=True)
class ZohPlan:
    """How the exact-ZOH series is evaluated and how accurate it is.

    Attributes:
        terms: N, the highest power of the Taylor series of phi_1(X) = sum X^k/(k+1)!.
        squarings: s, the number of doublings after summing at T/2^s.
        error_bound: upper bound of ||Phi_series - e^(A T)||_inf (absolute) for any A with
            ||A||_inf <= the norm bound the plan was made for.
    """

    terms: int
    squarings: int
    error_bound: float


MAX_EXPONENT = 700.0
"""Above e^700 the error bound is reported as infinite (a double overflows near e^709)."""


def plan_zoh(norm_bound: float, sample_time: float) -> ZohPlan:
    """Choose series length and squarings for ||A|| <= ``norm_bound`` (1/s) at ``sample_time`` (s).

    With theta = ||A|| T, s = ceil(log2(theta/0.5)) squarings make theta_s = theta/2^s <= 0.5. The
    Taylor remainder of e^Y, ||Y|| <= theta_s, after N terms is
    rho <= theta_s^(N+1)/(N+1)! / (1 - theta_s/(N+2)), and s squarings give
    ||(e^Y + E)^(2^s) - e^(A T)|| <= e^theta ((1 + rho)^(2^s) - 1).
    """
    theta = norm_bound * sample_time
    squarings = max(0, math.ceil(math.log2(theta / ZOH_SCALED_NORM))) if theta > 0 else 0
    theta_s = theta / 2**squarings
    terms = 4
    while _remainder(theta_s, terms) > ZOH_REMAINDER:
        terms += 1
    rho = _remainder(theta_s, terms)
    growth = 2**squarings * math.log1p(rho)
    bound = math.exp(theta) * math.expm1(growth) if theta + growth < MAX_EXPONENT else math.inf
    return ZohPlan(terms, squarings, bound)


def _remainder(theta: float, terms: int) -> float:
    return theta ** (terms + 1) / math.factorial(terms + 1) / (1.0 - theta / (terms + 2))


def euler(A: ca.SX, B: ca.SX, T: float) -> tuple[ca.SX, ca.SX]:
    """Forward Euler: Phi = I + A T, Gamma = B T."""
    return ca.SX.eye(A.shape[0]) + A * T, B * T


def tustin(A: ca.SX, B: ca.SX, T: float) -> tuple[ca.SX, ca.SX]:
    """Bilinear (Tustin) transform, the state-space form scipy uses."""
    eye = ca.SX.eye(A.shape[0])
    inv_left = ca.inv(eye - A * (T / 2))
    return ca.mtimes(inv_left, eye + A * (T / 2)), ca.mtimes(inv_left, B * T)


def zoh(A: ca.SX, B: ca.SX, T: float, plan: ZohPlan) -> tuple[ca.SX, ca.SX]:
    """Exact zero-order hold by the series of ``plan``.

    psi = sum_k X^k/(k+1)! (Horner; for a 2x2 A in scalars, :func:`_series_2x2`), X = A h,
    h = T/2^s; Phi_h = I + X psi, Gamma_h = h psi B; then s doublings Gamma_2h = Phi_h Gamma_h +
    Gamma_h, Phi_2h = Phi_h^2.
    """
    eye = ca.SX.eye(A.shape[0])
    h = T / 2**plan.squarings
    X = A * h
    if A.shape == (2, 2):
        psi, phi = _series_2x2(X, plan.terms)
    else:
        psi = eye
        for k in range(plan.terms, 0, -1):
            psi = eye + ca.mtimes(X, psi) * (1.0 / (k + 1))  # a product: cheaper than a division
        phi = eye + ca.mtimes(X, psi)
    gamma = ca.mtimes(psi, B) * h
    for _ in range(plan.squarings):
        gamma = ca.mtimes(phi, gamma) + gamma
        phi = ca.mtimes(phi, phi)
    return phi, gamma


def _series_2x2(X: ca.SX, terms: int) -> tuple[ca.SX, ca.SX]:
    """(psi, I + X psi) of :func:`zoh`'s series for a 2x2 ``X``, in scalars: by Cayley-Hamilton
    X^2 = t X - d I (t = trace, d = determinant), so every term of the Horner recurrence is
    a I + b X, and X (a I + b X) = -b d I + (a + b t) X. The same series, about a third of the
    operations of the matrix products."""
    trace = X[0, 0] + X[1, 1]
    det = X[0, 0] * X[1, 1] - X[0, 1] * X[1, 0]
    a, b = ca.SX(1), ca.SX(0)
    for k in range(terms, 0, -1):
        c = 1.0 / (k + 1)
        a, b = 1 - c * b * det, c * (a + b * trace)
    eye = ca.SX.eye(2)
    return a * eye + b * X, (1 - b * det) * eye + (a + b * trace) * X


def discretise(method: str, A: ca.SX, B: ca.SX, T: float, zoh_plan: ZohPlan | None = None):
    """Phi, Gamma by ``method`` ("euler", "tustin" or "zoh"; "zoh" needs ``zoh_plan``)."""
    if method == "euler":
        return euler(A, B, T)
    if method == "tustin":
        return tustin(A, B, T)
    if method == "zoh":
        if zoh_plan is None:
            raise ValueError("zoh discretisation needs a ZohPlan (see plan_zoh)")
        return zoh(A, B, T, zoh_plan)
    raise ValueError(f"unknown discretisation {method!r}")
