"""Signs and numbers of the 2-DOF model: the worked example of docs/methods.md ("Signs and the bicycle model")."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from vsegen.harness.reference import blocks
from vsegen.model.bicycle import bicycle_matrices, stability_factor, state_matrix_norm_bound

EXAMPLE = {  # placeholder stiffnesses of the spec's worked example
    "mass": 1412.0, "yaw_inertia": 1964.4, "cg_to_front_axle": 1.015, "cg_to_rear_axle": 1.895,
    "cornering_stiffness_front": 1.2e5, "cornering_stiffness_rear": 1.0e5,
}
VX = 100.0 / 3.0  # 120 km/h


def numeric(vehicle, vx):
    return [np.array(ca.DM(m)) for m in bicycle_matrices(vehicle, vx)]


def test_worked_example_matrices():
    A, B, C, D = numeric(EXAMPLE, VX)
    np.testing.assert_allclose(A, [[-4.674221, -31.894948], [1.033903, -7.372167]], atol=1e-5)
    np.testing.assert_allclose(B.ravel(), [84.985836, 62.003665], atol=1e-5)
    np.testing.assert_allclose(C, [[-4.674221, 1.438385], [0, 1]], atol=1e-5)
    np.testing.assert_allclose(D.ravel(), [84.985836, 0], atol=1e-5)
    eig = np.linalg.eigvals(A)
    np.testing.assert_allclose(sorted(eig.imag), [-5.5818, 5.5818], atol=1e-4)
    np.testing.assert_allclose(eig.real, [-6.0232, -6.0232], atol=1e-4)


def test_worked_example_steady_state_and_stability_factor():
    A, B, C, D = numeric(EXAMPLE, VX)
    assert stability_factor(EXAMPLE) == pytest.approx(9.4071e-4, rel=1e-4)
    x = -np.linalg.solve(A, B).ravel()  # steady state per rad of steer
    ay = (C @ x + D.ravel())[0]
    assert x[1] == pytest.approx(5.6007, rel=1e-4)       # r/delta = vx / (l (1 + Ks vx^2))
    assert ay == pytest.approx(186.69, rel=1e-4)
    assert x[0] / VX == pytest.approx(-0.6011, abs=1e-4)  # linear beta per rad of steer
    l = 2.91
    assert x[1] == pytest.approx(VX / (l * (1 + stability_factor(EXAMPLE) * VX**2)), rel=1e-9)


def test_left_steer_turns_left():
    """Positive delta (left) gives positive yaw rate and positive lateral acceleration."""
    A, B, C, D = numeric(EXAMPLE, 20.0)
    x = -np.linalg.solve(A, B).ravel() * 0.01
    assert x[1] > 0
    assert (C @ x + D.ravel() * 0.01)[0] > 0


@pytest.mark.parametrize("vx", [3.0, 5.0, 20.0, 50.0])
def test_model_agrees_with_reference_model(vx):
    for model_matrix, reference_matrix in zip(numeric(EXAMPLE, vx), blocks.bicycle(EXAMPLE, vx)):
        np.testing.assert_allclose(model_matrix, reference_matrix, rtol=1e-14, atol=0)


def test_norm_bound_bounds_the_state_matrix():
    bound = state_matrix_norm_bound(EXAMPLE, 3.0, 90.0)
    for vx in np.linspace(3.0, 90.0, 400):
        assert np.abs(numeric(EXAMPLE, vx)[0]).sum(axis=1).max() <= bound
