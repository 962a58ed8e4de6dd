"""Prefilter coefficients against SciPy, the median network, the reliability check."""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest
import scipy.signal

from vsegen.model import filters


@pytest.mark.parametrize("T", [0.01, 0.001])
@pytest.mark.parametrize("design", ["printed", "bessel"])
def test_prefilter_coefficients_match_scipy(design, T):
    num, den = filters.printed_prefilter() if design == "printed" else filters.bessel_prefilter(100.0)
    if design == "bessel":
        b, a = scipy.signal.bessel(2, 100.0, analog=True, norm="phase")
        np.testing.assert_allclose(num, [b[-1]], rtol=1e-12)
        np.testing.assert_allclose(den, a, rtol=1e-12)
    f = filters.tustin_biquad(num, den, T)
    bz, az = scipy.signal.bilinear(num, den, fs=1.0 / T)
    np.testing.assert_allclose([f.n0, f.n1, f.n2], bz / az[0], rtol=1e-12)
    np.testing.assert_allclose([1.0, f.d1, f.d2], az / az[0], rtol=1e-12)
    assert f.dc_gain == pytest.approx(1.0, rel=1e-12)


def test_printed_prefilter_matches_the_spec_table():
    f = filters.tustin_biquad(*filters.printed_prefilter(), 0.01)
    np.testing.assert_allclose([f.n0, f.n1, f.n2, f.d1, f.d2],
                               [1 / 9, 2 / 9, 1 / 9, -2 / 3, 1 / 9], rtol=1e-12)
    f = filters.tustin_biquad(*filters.printed_prefilter(), 0.001)
    np.testing.assert_allclose([f.n0, f.n1, f.n2, f.d1, f.d2],
                               [0.00226757, 0.00453515, 0.00226757, -1.80952381, 0.81859410], atol=1e-8)


def test_median_window_lengths():
    assert filters.median_window(100.0, 0.05) == 5
    assert filters.median_window(1000.0, 0.05) == 51


@pytest.mark.parametrize("n", [1, 3, 5, 7])
def test_median_network(n):
    x = ca.SX.sym("x", n)
    fn = ca.Function("m", [x], [filters.median([x[i] for i in range(n)])])
    rng = np.random.default_rng(n)
    for _ in range(50):
        values = rng.normal(size=n)
        assert float(fn(values)) == np.median(values)
    if n <= 5:
        for perm in itertools.permutations(range(n)):
            assert float(fn(np.array(perm, float))) == (n - 1) / 2
    with pytest.raises(ValueError):
        filters.median([x[0], x[0]])


def test_reliability_check_rejects_and_times_out():
    m, ref, last, count = ca.SX.sym("m"), ca.SX.sym("ref"), ca.SX.sym("last"), ca.SX.sym("count")
    c = filters.reliability_check(m, ref, 0.2, last, count, timeout_steps=3)
    fn = ca.Function("c", [m, ref, last, count], [c.value, c.last, c.rejections, c.forced])
    def run(*args):
        return [float(v) for v in fn(*args)]
    assert run(0.1, 0.0, 0.05, 0) == [0.1, 0.1, 0.0, 0.0]        # inside: accept
    assert run(0.84, 0.1, 0.05, 0) == [0.05, 0.05, 1.0, 0.0]     # outlier: hold last
    assert run(0.84, 0.1, 0.05, 1) == [0.05, 0.05, 2.0, 0.0]
    assert run(0.84, 0.1, 0.05, 2) == [0.84, 0.84, 0.0, 1.0]     # third rejection: time-out
