"""Discretisation against python-control and SciPy, and the ZOH series' error bound."""

from __future__ import annotations

import casadi as ca
import control
import numpy as np
import pytest
import scipy.signal

from vsegen.model import discretize
from vsegen.model.bicycle import bicycle_matrices, state_matrix_norm_bound

SPEEDS = [5.0, 10.0, 20.0, 33.3, 50.0]
SAMPLE_TIMES = [0.01, 0.001]
METHODS = {"euler": "euler", "tustin": "bilinear", "zoh": "zoh"}


def symbolic_discretisation(vehicle, method, T, vx_min=3.0, vx_max=90.0):
    """Phi(vx), Gamma(vx) from model.discretize as a numeric function of vx."""
    vx = ca.SX.sym("vx")
    A, B, _, _ = bicycle_matrices(vehicle, vx)
    plan = discretize.plan_zoh(state_matrix_norm_bound(vehicle, vx_min, vx_max), T)
    Phi, Gamma = discretize.discretise(method, A, B, T, plan)
    return ca.Function("d", [vx], [Phi, Gamma])


@pytest.mark.parametrize("T", SAMPLE_TIMES)
@pytest.mark.parametrize("method", METHODS)
def test_matches_control_and_scipy(config, method, T):
    fn = symbolic_discretisation(config.vehicle, method, T)
    for vx in SPEEDS:
        Phi, Gamma = (np.array(m) for m in fn(vx))
        A, B, C, D = (np.array(ca.DM(m)) for m in bicycle_matrices(config.vehicle, vx))
        sys_d = control.sample_system(control.ss(A, B, C, D), T, method=METHODS[method])
        Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, C, D), T, method=METHODS[method])
        for expected in ((sys_d.A, sys_d.B), (Ad, Bd)):
            np.testing.assert_allclose(Phi, expected[0], rtol=0, atol=1e-12 * np.abs(expected[0]).max())
            np.testing.assert_allclose(Gamma, expected[1], rtol=0, atol=1e-12 * np.abs(expected[1]).max())


def test_worked_example_zoh():
    example = {"mass": 1412.0, "yaw_inertia": 1964.4, "cg_to_front_axle": 1.015,
               "cg_to_rear_axle": 1.895, "cornering_stiffness_front": 1.2e5,
               "cornering_stiffness_rear": 1.0e5}
    Phi, Gamma = (np.array(m) for m in symbolic_discretisation(example, "zoh", 0.01)(100.0 / 3.0))
    np.testing.assert_allclose(Phi, [[0.952774, -0.300150], [0.009730, 0.927385]], atol=1e-6)
    np.testing.assert_allclose(Gamma.ravel(), [0.734881, 0.601628], atol=1e-6)


def test_zoh_plan_bound_holds_at_the_extremes(config):
    """The stated bound holds where ||A T|| is largest (lowest and highest speed)."""
    T = 0.01
    plan = discretize.plan_zoh(state_matrix_norm_bound(config.vehicle, 3.0, 90.0), T)
    assert plan.error_bound < 1e-15
    fn = symbolic_discretisation(config.vehicle, "zoh", T)
    for vx in (3.0, 90.0):
        A, B, C, D = (np.array(ca.DM(m)) for m in bicycle_matrices(config.vehicle, vx))
        Ad, *_ = scipy.signal.cont2discrete((A, B, C, D), T, method="zoh")
        assert np.abs(np.array(fn(vx)[0]) - Ad).sum(axis=1).max() <= plan.error_bound + 1e-14


def test_zoh_plan_scales_large_norms():
    plan = discretize.plan_zoh(400.0, 0.01)  # ||A T|| = 4
    assert plan.squarings == 3
    assert plan.error_bound < 1e-14
    with pytest.raises(ValueError):
        discretize.discretise("zoh", ca.SX.eye(2), ca.SX.ones(2, 1), 0.01)
