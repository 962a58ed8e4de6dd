"""kf2dof: its Kalman step as a named Function matching the reference's blocks, and the low-speed and
invalid-input rule (identical in generated C and the reference, never non-finite)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.reference import kf2dof as reference
from vsegen.model import status

NAN, INF = math.nan, math.inf
GOOD = [0.02, 25.0, 1.5, 0.1]  # delta, vx, ay, r


@pytest.fixture(scope="module")
def compiled(config):
    return compile_estimator(config, "kf2dof")[1]


@pytest.fixture(scope="module")
def running_state(config):
    """A state after a few normal steps (holding = 0)."""
    state = reference.init(config, GOOD)
    for _ in range(5):
        state, _ = reference.step(config, state, GOOD)
    assert _holding(config, state) == 0.0
    return state


def _holding(config, state) -> float:
    """The state's ``holding`` entry (the input checks' entries come after it)."""
    return state[reference.names(config)[1].index("holding")]


def both(compiled, config, state, u):
    c_state, c_out = compiled.step(state, np.array(u, float))
    r_state, r_out = reference.step(config, np.array(state), u)
    np.testing.assert_array_equal(c_out[3], r_out[3])
    np.testing.assert_allclose(c_state, r_state, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(c_out, r_out, rtol=1e-12, atol=1e-15)
    assert np.all(np.isfinite(c_state)) and np.all(np.isfinite(c_out))
    return c_state, c_out


BAD_INPUTS = [
    (0, NAN), (0, INF), (0, -INF), (0, 1.5),      # delta beyond 1 rad
    (1, NAN), (1, INF), (1, 1e6), (1, -INF),      # vx
    (2, NAN), (2, -INF), (2, 1e300),              # ay
    (3, NAN), (3, INF), (3, -40.0),               # r
]


@pytest.mark.parametrize("index,value", BAD_INPUTS)
def test_invalid_input_holds(compiled, config, running_state, index, value):
    u = list(GOOD)
    u[index] = value
    state, out = both(compiled, config, running_state, u)
    assert int(out[3]) & status.INVALID_INPUT
    assert out[0] == 0.0 and out[1] == 0.0 and out[2] == running_state[1]  # beta, vy, held r
    P0 = config.settings("kf2dof")["initial_covariance"]
    assert list(state[2:5]) == [P0[0][0], P0[0][1], P0[1][1]]
    # the rejected input is not stored, the others are
    previous = {0: 5, 1: 6}
    for i, slot in previous.items():
        assert state[slot] == (running_state[slot] if i == index else GOOD[i])
    assert _holding(config, state) == 1.0


@pytest.mark.parametrize("vx", [2.99, 1.0, 0.0, -0.0, -5.0, -89.0])
def test_low_speed_holds(compiled, config, running_state, vx):
    state, out = both(compiled, config, running_state, [0.02, vx, 1.5, 0.1])
    assert int(out[3]) == status.LOW_SPEED
    assert out[0] == 0.0 and state[0] == 0.0 and _holding(config, state) == 1.0


def test_hysteresis_and_resume(compiled, config, running_state):
    state, _ = both(compiled, config, running_state, [0.0, 2.0, 0.0, 0.0])
    state, out = both(compiled, config, state, [0.0, 3.2, 0.0, 0.0])  # above vx_min, below resume
    assert int(out[3]) == status.LOW_SPEED
    state, out = both(compiled, config, state, [0.0, 3.5, 0.0, 0.0])  # resume
    assert int(out[3]) == status.OK and _holding(config, state) == 0.0
    state, out = both(compiled, config, state, [0.0, 3.2, 0.0, 0.0])  # running: only vx_min counts
    assert int(out[3]) == status.OK


def test_both_bits_when_speed_low_and_input_invalid(compiled, config, running_state):
    _, out = both(compiled, config, running_state, [0.0, 1.0, NAN, 0.0])
    assert int(out[3]) == status.LOW_SPEED | status.INVALID_INPUT


@pytest.mark.parametrize("first", [GOOD, [NAN, NAN, NAN, NAN], [0.0, 1.0, 0.0, 0.0], [0, INF, 0, 5.0]])
def test_init_accepts_anything(compiled, config, first):
    c_states = compiled.run(np.array([first, GOOD], float))[1]
    r_state = reference.init(config, first)
    np.testing.assert_array_equal(c_states[0], r_state)
    assert np.all(np.isfinite(c_states))


def test_random_garbage_never_leaves_a_non_finite_state(compiled, config):
    rng = np.random.default_rng(3)
    choices = np.array([NAN, INF, -INF, 0.0, -0.0, 1e-300, 1e300, 3.0, 3.5, 25.0, -1.0, 0.5])
    inputs = rng.choice(choices, size=(5000, 4))
    inputs[::3, 1] = rng.uniform(-5, 60, size=inputs[::3].shape[0])
    outputs, states = compiled.run(inputs)
    assert np.all(np.isfinite(outputs)) and np.all(np.isfinite(states))
    P = states[:, 2:5]
    assert np.all(P[:, 0] > 0) and np.all(P[:, 2] > 0) and np.all(P[:, 0] * P[:, 2] - P[:, 1] ** 2 > 0)


def test_kf2dof_dynamic_update_is_a_named_function(config):
    """The 2-DOF KF step exists as a named Function and matches the reference's blocks."""
    from vsegen.harness.reference import blocks
    from vsegen.model.calibration import baked
    from vsegen.model.estimators.kf2dof import dynamic_update

    fn = dynamic_update(baked(config))
    assert fn.name_in() == ["x", "P", "delta_prev", "vx_prev", "delta", "vx", "ay", "r_meas"]
    assert fn.name_out() == ["x_next", "P_next", "beta", "innovation", "ay_model"]
    s = config.settings("kf2dof")
    x, P = np.array([0.1, 0.05]), np.array([[0.02, 0.001], [0.001, 0.003]])
    out = fn(x=x, P=[P[0, 0], P[0, 1], P[1, 1]], delta_prev=0.01, vx_prev=20.0, delta=0.012,
             vx=20.5, ay=1.0, r_meas=0.06)
    A, B, _, _ = blocks.bicycle(config.vehicle, 20.0)
    Phi, Gamma = blocks.discretise("zoh", A, B, config.sample_time)
    growth = 1 + (1.0 / s["process_noise_load"]) ** 2 if s["process_noise_load"] > 0 else 1.0   # a_y = 1 m/s^2
    xp, Pp = blocks.kf_predict(x, P, Phi, Gamma, np.array([0.01]),
                               np.array(s["process_noise"]) * config.sample_time * growth)
    _, _, C, D = blocks.bicycle(config.vehicle, 20.5)
    xe, Pe = blocks.kf_update(xp, Pp, np.array([1.0, 0.06]), C, D, np.array([0.012]),
                              np.array(s["measurement_noise"]))
    np.testing.assert_allclose(np.array(out["x_next"]).ravel(), xe, rtol=1e-13)
    np.testing.assert_allclose(np.array(out["P_next"]).ravel(), [Pe[0, 0], Pe[0, 1], Pe[1, 1]], rtol=1e-12)
    np.testing.assert_allclose(float(out["ay_model"]), (C @ xp + D.ravel() * 0.012)[0], rtol=1e-12)  # the prior's a_y
    assert float(out["beta"]) == pytest.approx(np.arctan2(xe[0], 20.5), rel=1e-13)


def _vy_variance_after_a_step(fn, ay: float, **params) -> float:
    """P_vy after one step of the KF Function ``fn`` from x = 0, P = 0 (so P- = Q_d) at a_y = ``ay``
    (straight ahead at 20 m/s): it grows with Q_d's v_y entry."""
    return float(fn(x=[0, 0], P=[0, 0, 0], delta_prev=0, vx_prev=20.0, delta=0, vx=20.0, ay=ay, r_meas=0,
                    **params)["P_next"][0])


@pytest.mark.parametrize("load", [0.0, 2.0])
def test_process_noise_grows_with_the_lateral_acceleration(config, load):
    """Q_d = Q_c T (1 + (a_y / process_noise_load)^2): the model's at a_y = 0, twice it at a_y =
    the load, a_y's sign alike, no further growth beyond 6 m/s^2; constant where the load is 0. The
    model's Function and the reference's agree, and the generated step's prediction uses it."""
    from vsegen.harness.reference.bicycle_kf import process_noise as reference_noise
    from vsegen.model.calibration import baked
    from vsegen.model.estimators.kf2dof import dynamic_update

    config = config.with_settings("kf2dof", process_noise_load=load)
    s, T = config.settings("kf2dof"), config.sample_time
    base = np.array(s["process_noise"]) * T
    ceiling = 1 + (6.0 / load) ** 2 if load else 1.0
    for ay, growth in ((0.0, 1.0), (load, 2.0), (-load, 2.0), (3.0, 1 + (3.0 / load) ** 2 if load else 1.0),
                       (6.0, ceiling), (9.81, ceiling), (-45.0, ceiling)):
        np.testing.assert_allclose(reference_noise(s, ay, T), base * (growth if load else 1.0), rtol=1e-15)
    fn = dynamic_update(baked(config))
    straight, cornering, at_ceiling, beyond = (_vy_variance_after_a_step(fn, ay) for ay in (0.0, 3.0, 6.0, 9.81))
    if load:
        assert straight < cornering < at_ceiling == pytest.approx(beyond, rel=1e-12)
    else:
        assert straight == pytest.approx(cornering, rel=1e-12) and at_ceiling == pytest.approx(beyond, rel=1e-12)


def test_a_tiny_calibrated_load_counts_as_the_floor_and_zero_as_constant(config):
    """A calibration may carry a load of 1e-300 (the fuzzer's) or 0: the first grows Q_c as a load
    of 0.1 m/s^2 does, finite; the second gives the constant Q_c back, in the model and the reference."""
    from vsegen.harness.reference.bicycle_kf import process_noise as reference_noise
    from vsegen.model.calibration import calibratable
    from vsegen.model.estimators.kf2dof import dynamic_update

    params = calibratable(config, "kf2dof")
    fn = dynamic_update(params)
    s, T = config.settings("kf2dof"), config.sample_time
    values = dict(zip(params.names, params.values))

    def after_a_step(load, ay):
        p = [load if name == "process_noise_load" else values[name] for name in params.names]
        return _vy_variance_after_a_step(fn, ay, params=p)

    assert np.isfinite(after_a_step(1e-300, 3.0))
    assert after_a_step(1e-300, 3.0) == pytest.approx(after_a_step(0.1, 3.0), rel=1e-12)
    assert after_a_step(0.1, 3.0) > after_a_step(0.1, 0.0)
    assert after_a_step(0.0, 3.0) == pytest.approx(after_a_step(0.0, 0.0), rel=1e-12)
    for load, growth in ((1e-300, 1 + (3.0 / 0.1) ** 2), (0.0, 1.0)):
        np.testing.assert_allclose(reference_noise({**s, "process_noise_load": load}, 3.0, T),
                                   np.array(s["process_noise"]) * T * growth, rtol=1e-12)
