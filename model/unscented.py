"""The scaled unscented transform, symbolic and loop-free (docs/methods.md, seed 002
§2.8, §2.11 and C5, C6).

* Weights (11): W_m0 = tau/(n+tau), W_c0 = W_m0 + 1 - alpha^2 + beta, W_i = 1/(2(n+tau)),
  tau = alpha^2 (n + kappa) - n.
* Sigma points (10) from the lower Cholesky factor of P + E, unrolled for a fixed n (straight-line
  C, no loops). The jitter E = diag(eps_i), eps_i = 1e-9 max(1, P_ii), is needed because the paper
  starts from P_0 = 0 (C5). It is per entry, not §2.11's 1e-9 max(1, max diag P) I: the state mixes
  units, and a yaw-moment variance of 1e10 (N*m)^2 would otherwise add 10 (m/s^2)^2 to an
  acceleration variance of 1e-3.
* Non-positive-definite P (the classic Sage-Husa failure): the factorisation is *rejected* when a
  pivot j falls below eps_j / 2; the covariance is then *repaired* to diag(max(P_ii, 0) + eps_i)
  (its correlations dropped, its variances kept) and the caller flags status COVARIANCE_REPAIRED.
* Statistics in increment form (C6): with D_i = F(chi_i) - F(chi_0) and e = W_i sum D_i,
      mean = F(chi_0) + e,
      cov  = W_i sum D_i D_i' + (beta - alpha^2) e e'.
  This is the printed sum_i W_c^i (chi_i - mean)(chi_i - mean)' rearranged (sum W_m = 1 and
  2n W_i - 2 + W_c0 = beta - alpha^2): no +-1e6 weight multiplies a difference of large values.
  The increments of a pair chi_0 +- s_i come as odd and even parts (``model.increments``),
  D = +-o + g, so e = 2 W_i sum g_i and W_i sum D D' = 2 W_i sum (o o' + g g').
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

JITTER = 1e-9
"""eps_i = JITTER max(1, P_ii), added to P_ii before the factorisation (§2.11 step 2, per entry)."""


@dataclass(frozen=True)
class Weights:
    """Weights of the scaled UT for an n-vector; ``spread`` = n + tau."""

    n: int
    alpha: float
    beta: float
    kappa: float

    @property
    def spread(self) -> float:
        return self.alpha ** 2 * (self.n + self.kappa)

    @property
    def mean0(self) -> float:
        return 1.0 - self.n / self.spread

    @property
    def cov0(self) -> float:
        return self.mean0 + 1.0 - self.alpha ** 2 + self.beta

    @property
    def other(self) -> float:
        return 1.0 / (2.0 * self.spread)

    @property
    def rounding_gain(self) -> float:
        """sum |W_m|: how much a weighted sum of the points amplifies their rounding."""
        return abs(self.mean0) + 2 * self.n * self.other


def cholesky_repaired(P: ca.SX) -> tuple[ca.SX, ca.SX]:
    """(L, repaired): the lower factor of P + E, E = diag(eps_i), eps_i = JITTER max(1, P_ii);
    or of the repaired covariance diag(max(P_ii, 0) + eps_i) when P + E is not positive definite
    (a pivot below eps_j / 2); ``repaired`` is 1 then, else 0."""
    n = P.shape[0]
    eps = [JITTER * ca.fmax(1, P[i, i]) for i in range(n)]
    L = ca.SX.zeros(n, n)
    rejected = ca.SX(0)
    for j in range(n):
        pivot = P[j, j] + eps[j] - sum((L[j, k] * L[j, k] for k in range(j)), ca.SX(0))
        rejected = ca.logic_or(rejected, pivot < eps[j] / 2)
        L[j, j] = ca.sqrt(ca.fmax(pivot, eps[j] / 2))
        for i in range(j + 1, n):
            L[i, j] = (P[i, j] - sum((L[i, k] * L[j, k] for k in range(j)), ca.SX(0))) / L[j, j]
    repaired = ca.diag(ca.vertcat(*[ca.sqrt(ca.fmax(P[i, i], 0) + eps[i]) for i in range(n)]))
    return ca.if_else(rejected, repaired, L), ca.if_else(rejected, 1, 0)


def sigma_offsets(L: ca.SX, weights: Weights) -> list[ca.SX]:
    """s_i = sqrt(n + tau) times column i of L: the sigma points are chi_0 +- s_i, i = 1..n."""
    scale = ca.sqrt(weights.spread)
    return [scale * L[:, i] for i in range(L.shape[1])]


def statistics(centre: ca.SX, pairs: list[tuple[ca.SX, ca.SX]], weights: Weights
               ) -> tuple[ca.SX, ca.SX]:
    """(mean, covariance) of the propagated points from F(chi_0) = ``centre`` and, per pair
    chi_0 +- s_i, the odd and even parts (o_i, g_i) of F(chi_0 +- s_i) - F(chi_0) = +-o_i + g_i:
    e = 2 W_i sum g_i, mean = centre + e, cov = 2 W_i sum (o_i o_i' + g_i g_i')
    + (beta - alpha^2) e e' (module docstring)."""
    w = 2 * weights.other
    e = w * sum((g for _, g in pairs[1:]), pairs[0][1])
    n = e.shape[0]
    spread = sum((ca.mtimes(o, o.T) + ca.mtimes(g, g.T) for o, g in pairs), ca.SX.zeros(n, n))
    return centre + e, w * spread + (weights.beta - weights.alpha ** 2) * ca.mtimes(e, e.T)
