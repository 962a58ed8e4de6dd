"""Fuzzing: 10^6 adversarial steps per estimator and precision under ASan/UBSan, property tests on
the reference (hypothesis), and proof that the fuzzer catches planted bugs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from locations import DEFAULT_VEHICLE

from vsegen.codegen.generate import render
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.reference import blocks
from vsegen.harness.reference import kf2dof as reference
from vsegen.harness.verify.fuzz import fuzz_estimator
from vsegen.model.estimators import DEFINITIONS

STEPS = 1_000_000
HEAVY = ("ukf", "aukf", "pf_adaptive", "pf_improved")
"""Estimators whose million sanitised steps take 4-6 s each: fuzzed in the slow suite."""


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in HEAVY else n for n in DEFINITIONS])
@pytest.mark.parametrize("real", ["double", "float"])
def test_a_million_adversarial_steps(config, name, real):
    report = fuzz_estimator(config, name, real, STEPS, seed=7)
    assert report.ok, report.message
    assert report.steps == STEPS and 0 < report.rejected < STEPS


def test_fuzzer_catches_a_wrong_status(config):
    files = render(config, "kf2dof")
    files["vse_kf2dof.c"] = files["vse_kf2dof.c"].replace("out->status = (int)y[3];",
                                                          "out->status = 0;")
    report = fuzz_estimator(config, "kf2dof", "double", 10_000, files=files)
    assert not report.ok and "INVALID_INPUT" in report.message


def test_fuzzer_catches_memory_errors(config):
    files = render(config, "kf2dof")
    files["vse_kf2dof.c"] = files["vse_kf2dof.c"].replace(
        "    out->beta = y[0];", "    out->beta = y[(int)state->x[7] + 4];")
    report = fuzz_estimator(config, "kf2dof", "double", 10_000, files=files)
    assert not report.ok and "Sanitizer" in report.message


special = st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, 1e300, -1e300, 5e-324])
value = st.one_of(st.floats(-100, 100, allow_nan=False), special)
sample = st.tuples(st.floats(-0.2, 0.2) | special, st.floats(-5, 60) | special,
                   value, st.floats(-1, 1) | special)


@settings(max_examples=200, deadline=None)
@given(st.lists(sample, min_size=1, max_size=60))
def test_reference_invariants(config, rows):
    state = reference.init(config, rows[0])
    for row in rows:
        state, output = reference.step(config, state, row)
        assert np.all(np.isfinite(state)) and np.all(np.isfinite(output))
        p11, p12, p22 = state[2:5]
        assert p11 > 0 and p22 > 0 and p11 * p22 - p12 * p12 >= -1e-15 * p11 * p22
        rejected = not all(blocks.plausible(config.limits, n, v) for n, v in zip(reference.INPUTS, row))
        assert bool(int(output[3]) & blocks.INVALID_INPUT) == rejected


CALIBRATABLE_FORMS = [(name, real) for name, real, params in load_vehicle(DEFAULT_VEHICLE).codegen["forms"]
                      if params == "calibratable"]
"""The calibratable forms the default vehicle declares (kf2dof and pf_improved, double and float)."""


@pytest.mark.parametrize("name,real", CALIBRATABLE_FORMS)
def test_a_million_steps_with_a_fuzzed_calibration(config, name, real):
    """The calibratable forms with their calibration struct fuzzed as well (NaN, +-Inf, 1e38, huge,
    tiny, negative and rescaled values, then mended): never a non-finite state, a failing
    calibration always holds with INVALID_CALIBRATION, a passing one never does."""
    report = fuzz_estimator(config, name, real, STEPS, seed=7, params="calibratable")
    assert report.ok, report.message
    assert report.steps == STEPS
