"""Coverage: the decisions of a symbolic step and the ways they are taken, gcov's statements and
branches of the generated C (gcovr); `vsegen verify --coverage`'s report is tested with verify's
other reports (tests/test_verify_report.py)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from vsegen.harness.sim.scenarios import SCORED_SET, VERIFICATION_SET, Case
from vsegen.harness.verify import code_coverage, coverage, decision_sites, model_coverage
from vsegen.harness.verify.equivalence import case_inputs
from vsegen.model import signals
from vsegen.model.estimators import build, build_fresh
from vsegen.model.guard import model_speed


def test_decisions_are_found_and_counted_both_ways():
    x = ca.SX.sym("x", 2)
    flag = ca.SX.sym("flag")
    out = ca.if_else(x[0] < x[1], ca.fmax(x[0], 1.0), 2 * x[1]) + ca.if_else(flag, x[0], 0.0)
    step = ca.Function("step", [x, flag], [out])
    found = model_coverage.decisions(step)
    assert sorted(d.kind for d in found) == ["comparison", "if_else", "max"]     # no '!' of the comparison
    states = np.array([[0.0, 1.0], [2.0, 1.0], [3.0, 5.0]])
    flags = np.array([[1.0], [1.0], [1.0]])
    counts = model_coverage.count(step, [(states, flags)])
    by_kind = {d.kind: (counts.true[i], counts.false[i]) for i, d in enumerate(counts.decisions)}
    assert by_kind == {"comparison": (2, 1), "max": (2, 1), "if_else": (3, 0)}
    assert [(d.kind, way) for d, way in counts.one_way()] == [("if_else", True)] and counts.both_ways == 2


def test_a_calibratable_kit_runs_every_template_statement_and_branch(config, tmp_path):
    estimator = build("kf2dof", config, "calibratable")
    inputs = [case_inputs(config, estimator, case, 1, "float") for case in VERIFICATION_SET]
    files = {f.file: f for f in code_coverage.measure(config, "kf2dof", "float", "calibratable", inputs, tmp_path)}
    api, kernel = files["vse_kf2dof.c"], files["vse_kf2dof_kernel.c"]
    assert api.kind == "template" and kernel.kind == "kernel"
    assert (api.lines_run, api.branches_taken) == (api.lines, api.branches) and api.branches > 150
    assert kernel.lines_run == kernel.lines and 0 < kernel.branches_taken < kernel.branches
    baked = {f.file: f for f in code_coverage.measure(config, "kf2dof", "float", "baked", inputs[:1], tmp_path / "b")}
    assert baked["vse_kf2dof_kernel.c"].branches_taken < kernel.branches_taken        # one scenario takes fewer


def test_a_decision_is_named_by_the_model_line_that_built_it_through_calls_and_substitutions():
    z = ca.SX.sym("z")
    with decision_sites.traced() as sites:
        x = ca.SX.sym("x")
        clamp = ca.Function("clamp", [x], [model_speed(x, 3.0, 90.0)])
        called = clamp(2 * z)
        step = ca.Function("step", [z], [ca.substitute(called, z, z + 1)])
    found = model_coverage.decisions(step, sites)
    assert [d.kind for d in found] == ["max", "min"]
    assert all(d.site.startswith("guard.py:") and d.site.endswith(" model_speed") for d in found)
    outside = ca.Function("outside", [z], [ca.fmax(z, 1)])        # not built by the model: no site
    assert model_coverage.decisions(outside, sites)[0].site is None


@pytest.mark.parametrize("name", ["kf2dof", "switching", "ukf"])
def test_a_traced_build_is_the_same_step_with_every_decision_named(config, name):
    with decision_sites.traced() as sites:
        traced = build_fresh(name, config)
    plain = build_fresh(name, config)
    assert traced.step.n_instructions() == plain.step.n_instructions()
    found = model_coverage.decisions(traced.step, sites)
    assert [d.expression for d in found] == [d.expression for d in model_coverage.decisions(plain.step)]
    untraced = [d for d in found if d.site is None]
    assert len(untraced) <= len(found) // 100, [d.expression for d in untraced]


def test_injected_state_faults_reach_the_covariance_repair_and_justifications_name_sites(config):
    estimator = build("ukf", config)
    inputs = case_inputs(config, estimator, VERIFICATION_SET[0], 1, "double")[:200]
    state, states = np.array(estimator.init.call([inputs[0]])[0]).ravel(), []
    for row in inputs:
        states.append(state)
        state = np.array(estimator.step.call([state, row])[0]).ravel()
    model = coverage.model_of(config, "ukf", [(np.array(states), inputs)])
    repaired = {d.site for d in model.by_faults_only() if "cholesky_repaired" in (d.site or "")}
    assert repaired and not any("cholesky_repaired" in (d.site or "") for d, *_ in model.one_way())
    why = {d.site: reason for d, _, reason in model.one_way()}
    assert any("adhesion" in (site or "") and reason for site, reason in why.items())
    clamp = next(d for d, *_ in model.one_way() if "model_speed" in (d.site or "") and d.kind == "min")
    assert coverage.justification(clamp, True, "ukf") and not coverage.justification(clamp, False, "ukf")


def test_input_extremes_takes_every_input_past_its_limit_once_and_is_verified_not_scored(config):
    case = Case.of("input_extremes")
    assert case in VERIFICATION_SET and case not in SCORED_SET
    log = case.simulate(config, 1.0 / config.sample_time)
    for entry in signals.INPUTS:
        beyond = np.abs(log.columns[entry.name]) > config.limits[entry.limit_key]
        assert np.count_nonzero(beyond) == 1, entry.name
    assert np.all(log.columns["ay"][: int(0.9 / config.sample_time)] == 0.0)      # noise-free, no excitation


@pytest.mark.slow
def test_every_model_decision_is_taken_both_ways_or_justified(config, tmp_path):
    """docs/coverage.md's target, the model half, for every estimator of the default vehicle."""
    for name in config.estimators:
        result = coverage.measure(config, name, [], tmp_path)
        if result.model is not None:
            assert not [(d.site, d.kind, way) for d, way, why in result.model.one_way() if not why], name
