"""Machine-readable results of the checking commands (generate --check, size, misra, campaign; verify
and pil have theirs in their own tests): JUnit XML read back by junitparser, an outside judge, with
a test case per thing checked and a failure where it failed, and the same records as JSON; tables
that honour COLUMNS and never cut a number."""

from __future__ import annotations

import json
import os
import shutil

import pytest
import xmlschema
from junit_reports import read_junit
from junitparser import Failure, Properties
from locations import DEFAULT_VEHICLE, REPO

from vsegen.harness.logs.table import write_log
from vsegen.harness.project.results import Check, as_junit
from vsegen.harness.sim.scenarios import Case


def cases(path):
    return {(suite.name, case.name): case for suite in read_junit(path) for case in suite}


def figures(case) -> dict[str, str]:
    return {p.name: p.value for p in next(case.iterchildren(Properties))}


def test_generate_check_reports_a_stale_folder_as_a_failure(tmp_path, vsegen):
    junit = tmp_path / "generate.xml"
    project = tmp_path / "project"
    (project / "vehicles").mkdir(parents=True)
    shutil.copy(DEFAULT_VEHICLE, project / "vehicles")
    shutil.copytree(REPO / "generated" / "c_class" / "kf2dof", project / "generated" / "c_class" / "kf2dof")
    kernel = project / "generated" / "c_class" / "kf2dof" / "vse_kf2dof_kernel.c"
    kernel.write_text(kernel.read_text().replace("casadi_real", "double", 1))
    result = vsegen.process("generate", "--check", "--estimator", "kf2dof", "--junit", str(junit), cwd=project)
    assert result.exit_code == 1
    found = cases(junit)
    assert all(not case.is_passed for case in found.values())    # the kit edited, its other forms missing
    (failure,) = found[("c_class.kf2dof.double-baked", "generated/c_class/kf2dof")].result
    assert isinstance(failure, Failure) and failure.type == "stale generated code"
    assert "1 file(s) differ" in failure.message and "vsegen generate --vehicle" in failure.message


def test_misra_reports_each_rule_against_its_baseline_and_each_kit(tmp_path, vsegen):
    junit, data = tmp_path / "misra.xml", tmp_path / "misra.json"
    result = vsegen.process("misra", "--out", str(tmp_path / "misra.md"), "--junit", str(junit), "--json", str(data))
    assert result.exit_code == 0, result.stderr
    found = cases(junit)
    rules = {name: case for (suite, name), case in found.items() if suite == "rules"}
    kits = {name for (suite, name), _ in found.items() if suite == "kits"}
    baseline = json.loads((REPO / "harness" / "target" / "misra_baseline.json").read_text())
    assert set(rules) == set(baseline) and all(case.is_passed for case in rules.values())
    assert all(int(figures(case)["findings"]) <= int(figures(case)["baseline"]) for case in rules.values())
    assert "c_class/kf2dof (double, baked)" in kits
    assert json.loads(data.read_text())["checks_failed"] == 0


def test_size_reports_each_cross_build(tmp_path, vsegen):
    junit = tmp_path / "size.xml"
    result = vsegen.process("size", "--estimator", "kf2dof", "--junit", str(junit))
    assert result.exit_code == 0, result.stderr
    found = cases(junit)
    assert sorted(suite for suite, _ in found) == ["c_class.kf2dof.double-baked", "c_class.kf2dof.double-calibratable",
                                                   "c_class.kf2dof.float-baked", "c_class.kf2dof.float-calibratable"]
    m4f = figures(found[("c_class.kf2dof.float-baked", "cross-build for cortex-m4f")])
    assert 1000 < int(m4f["text_bytes"]) < 16384 and 0 < int(m4f["stack_step_bytes"]) < 1024


def test_a_failed_check_is_a_failure_and_the_document_validates(tmp_path):
    checks = [Check("s", "fine", {"x": 1.5, "nan": float("nan")}), Check("s", "broken", {}, "too big", "budget")]
    path = tmp_path / "r.xml"
    path.write_text(as_junit("t", checks))
    xml = read_junit(path)
    assert (xml.tests, xml.failures) == (2, 1)
    broken = cases(path)[("s", "broken")]
    (failure,) = broken.result
    assert (failure.message, failure.type) == ("too big", "budget")
    assert figures(cases(path)[("s", "fine")]) == {"x": "1.5", "nan": "nan"}


def test_the_schema_refuses_a_report_that_ci_readers_would_misread(tmp_path):
    good = as_junit("t", [Check("s", "fine", {"x": 1.5}), Check("s", "broken", {}, "too big", "budget")])
    for broken in (good.replace(' classname="s"', "", 1),             # a test case without its class
                   good.replace('failures="1"', 'failures="one"', 1),  # a count that is no number
                   good.replace("<properties>", "<properties>\n<oops/>", 1)):
        path = tmp_path / "broken.xml"
        path.write_text(broken)
        with pytest.raises(xmlschema.XMLSchemaValidationError):
            read_junit(path)


def test_tables_honour_columns_and_never_cut_a_number(tmp_path, vsegen, config):
    log, est = tmp_path / "log.csv", tmp_path / "est.csv"
    write_log(Case.of("dlc").simulate(config, 100.0, 1), log)
    assert vsegen("run", "--log", log, "--estimator", "kf2dof", "--out", est).exit_code == 0
    for columns in ("60", "200"):
        result = vsegen.process("score", "--log", str(log), "--est", str(est), env={**os.environ, "COLUMNS": columns})
        assert result.exit_code == 0, result.stderr
        row = next(line for line in result.stdout.splitlines() if "beta (deg)" in line)
        assert "…" not in result.stdout and len(row.split("│")) == 7        # every cell on the row, none cut
        assert max(len(line) for line in result.stdout.splitlines()) <= max(int(columns), len(row))
