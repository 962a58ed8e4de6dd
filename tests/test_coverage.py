"""Coverage: the decisions of a symbolic step and the ways they are taken, gcov's statements and
branches of the generated C (gcovr); `vsegen verify --coverage`'s report is tested with verify's
other reports (tests/test_verify_report.py)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.verify import code_coverage, model_coverage
from vsegen.harness.verify.equivalence import case_inputs
from vsegen.model.estimators import build


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
