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


def test_kf2dof_dynamic_update_is_a_named_function(config):
    """The 2-DOF KF step exists as a named Function and matches the reference's blocks."""
    from vsegen.harness.reference import blocks
    from vsegen.model.calibration import baked
    from vsegen.model.estimators.kf2dof import dynamic_update

    fn = dynamic_update(baked(config))
    assert fn.name_in() == ["x", "P", "delta_prev", "vx_prev", "delta", "vx", "ay", "r_meas"]
    assert fn.name_out() == ["x_next", "P_next", "beta", "innovation"]
    s = config.settings("kf2dof")
    x, P = np.array([0.1, 0.05]), np.array([[0.02, 0.001], [0.001, 0.003]])
    out = fn(x=x, P=[P[0, 0], P[0, 1], P[1, 1]], delta_prev=0.01, vx_prev=20.0, delta=0.012,
             vx=20.5, ay=1.0, r_meas=0.06)
    A, B, _, _ = blocks.bicycle(config.vehicle, 20.0)
    Phi, Gamma = blocks.discretise("zoh", A, B, config.sample_time)
    xp, Pp = blocks.kf_predict(x, P, Phi, Gamma, np.array([0.01]),
                               np.array(s["process_noise"]) * config.sample_time)
    _, _, C, D = blocks.bicycle(config.vehicle, 20.5)
    xe, Pe = blocks.kf_update(xp, Pp, np.array([1.0, 0.06]), C, D, np.array([0.012]),
                              np.array(s["measurement_noise"]))
    np.testing.assert_allclose(np.array(out["x_next"]).ravel(), xe, rtol=1e-13)
    np.testing.assert_allclose(np.array(out["P_next"]).ravel(), [Pe[0, 0], Pe[0, 1], Pe[1, 1]], rtol=1e-12)
    assert float(out["beta"]) == pytest.approx(np.arctan2(xe[0], 20.5), rel=1e-13)
