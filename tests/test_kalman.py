"""Kalman-filter blocks: packing, prediction, Joseph-form update."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from vsegen.model import kalman

RNG = np.random.default_rng(7)


def spd(n):
    M = RNG.normal(size=(n, n))
    return M @ M.T + n * np.eye(n)


def evaluate(fn_builder, *values):
    values = [np.asarray(v).reshape(len(v), -1) for v in values]
    symbols = [ca.SX.sym(f"s{i}", *v.shape) for i, v in enumerate(values)]
    outputs = fn_builder(*symbols)
    fn = ca.Function("f", symbols, list(outputs))
    return [np.array(o) for o in fn.call(values)]


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_pack_unpack_roundtrip(n):
    P = spd(n)
    packed, = evaluate(lambda p: [kalman.pack_symmetric(p)], P)
    assert packed.size == kalman.packed_size(n)
    restored, = evaluate(lambda v: [kalman.unpack_symmetric(v, n)], packed)
    np.testing.assert_array_equal(restored, P)
    assert len(kalman.packed_names("P", tuple("abcd"[:n]))) == kalman.packed_size(n)


def test_predict():
    x, P, Phi, Gamma, u, Q = RNG.normal(size=(2, 1)), spd(2), RNG.normal(size=(2, 2)), \
        RNG.normal(size=(2, 1)), RNG.normal(size=(1, 1)), spd(2)
    xp, Pp = evaluate(kalman.predict, x, P, Phi, Gamma, u, Q)
    np.testing.assert_allclose(xp, Phi @ x + Gamma @ u, rtol=1e-14)
    np.testing.assert_allclose(Pp, Phi @ P @ Phi.T + Q, rtol=1e-14)


@pytest.mark.parametrize("n,m", [(2, 2), (3, 1), (4, 2)])
def test_joseph_update_equals_textbook_optimal_update(n, m):
    x, P, z, C, D, u, R = (RNG.normal(size=(n, 1)), spd(n), RNG.normal(size=(m, 1)),
                           RNG.normal(size=(m, n)), RNG.normal(size=(m, 1)), RNG.normal(size=(1, 1)),
                           spd(m))
    x_new, P_new, nu = evaluate(kalman.update_joseph, x, P, z, C, D, u, R)
    S = C @ P @ C.T + R
    K = P @ C.T @ np.linalg.inv(S)
    np.testing.assert_allclose(nu, z - C @ x - D @ u, rtol=1e-12)
    np.testing.assert_allclose(x_new, x + K @ (z - C @ x - D @ u), rtol=1e-10)
    np.testing.assert_allclose(P_new, (np.eye(n) - K @ C) @ P, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(P_new, P_new.T, rtol=1e-12)
    assert np.linalg.eigvalsh(P_new).min() > 0
    assert np.trace(P_new) < np.trace(P)  # a measurement never adds uncertainty
