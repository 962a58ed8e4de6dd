"""Kalman-filter building blocks (symbolic, any state and measurement size).

Covariances are stored in state vectors as their upper triangle, row by row (P11, P12, ..., P22,
...), so they are symmetric by construction; :func:`pack_symmetric` and :func:`unpack_symmetric`
convert. The measurement update uses the Joseph form, which keeps P symmetric positive
(semi-)definite for any gain and in rounding.
"""

from __future__ import annotations

import casadi as ca


def packed_size(n: int) -> int:
    """Number of stored entries of a symmetric n x n matrix."""
    return n * (n + 1) // 2


def packed_names(prefix: str, names: tuple[str, ...]) -> tuple[str, ...]:
    """Names of the packed entries, e.g. ``P_vy_vy, P_vy_r, P_r_r``."""
    return tuple(f"{prefix}_{names[i]}_{names[j]}" for i in range(len(names))
                 for j in range(i, len(names)))


def pack_symmetric(P: ca.SX) -> ca.SX:
    """Upper triangle of P, row by row, as a column."""
    n = P.shape[0]
    return ca.vertcat(*[P[i, j] for i in range(n) for j in range(i, n)])


def unpack_symmetric(packed: ca.SX, n: int) -> ca.SX:
    """The symmetric n x n matrix whose upper triangle is ``packed``."""
    P = ca.SX.zeros(n, n)
    index = 0
    for i in range(n):
        for j in range(i, n):
            P[i, j] = packed[index]
            P[j, i] = packed[index]
            index += 1
    return P


def predict(x: ca.SX, P: ca.SX, Phi: ca.SX, Gamma: ca.SX, u: ca.SX, Qd: ca.SX):
    """Time update: x- = Phi x + Gamma u, P- = Phi P Phi' + Qd."""
    x_pred = ca.mtimes(Phi, x) + ca.mtimes(Gamma, u)
    P_pred = ca.mtimes([Phi, P, Phi.T]) + Qd
    return x_pred, P_pred


def ekf_predict(x_pred: ca.SX, P: ca.SX, F: ca.SX, Qd: ca.SX):
    """EKF time update: the caller's nonlinear x- = f_d(x, u), and P- = F P F' + Qd with F the
    Jacobian of f_d at the previous estimate."""
    return x_pred, ca.mtimes([F, P, F.T]) + Qd


def update_joseph(x: ca.SX, P: ca.SX, z: ca.SX, C: ca.SX, D: ca.SX, u: ca.SX, R: ca.SX):
    """Measurement update of z = C x + D u + v, v ~ N(0, R), with the Joseph-form covariance.

    Returns (x+, P+, innovation) with the innovation nu = z - C x - D u (see :func:`correct`).
    """
    innovation = z - ca.mtimes(C, x) - ca.mtimes(D, u)
    x_new, P_new = correct(x, P, innovation, C, R)
    return x_new, P_new, innovation


def correct(x: ca.SX, P: ca.SX, innovation: ca.SX, H: ca.SX, R: ca.SX):
    """Measurement update from the ``innovation`` z - h(x) of a measurement whose Jacobian in x is
    ``H`` (the linear C, or an EKF's linearisation), noise covariance ``R``, Joseph form:
    S = H P H' + R,  K = P H' S^-1,  x+ = x + K nu,  P+ = (I - K H) P (I - K H)' + K R K'."""
    S = ca.mtimes([H, P, H.T]) + R
    K = ca.mtimes([P, H.T, ca.inv(S)])
    x_new = x + ca.mtimes(K, innovation)
    I_KH = ca.SX.eye(P.shape[0]) - ca.mtimes(K, H)
    P_new = ca.mtimes([I_KH, P, I_KH.T]) + ca.mtimes([K, R, K.T])
    return x_new, P_new
