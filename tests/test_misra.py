"""MISRA C:2012 (cppcheck addon): no regression past the baseline, every rule justified, our
template source clean."""

from __future__ import annotations

import os
import shutil
from collections import Counter

import pytest

from vsegen.codegen.generate import render
from vsegen.harness.target import misra


@pytest.fixture(scope="module")
def counts(config):
    if shutil.which("cppcheck") is None:
        if os.environ.get("CI"):
            pytest.fail("cppcheck is required in CI (scripts/setup.sh installs it)")
        pytest.skip("cppcheck not installed")
    total = Counter()
    names = list(config.estimators)
    for name, forms in zip(names, misra.all_findings([(config, name) for name in names])):
        for form, found, _ in forms:
            dirty = [(f, rule) for f, rule in found if not f.startswith(f"vse_{name}_kernel")
                     and rule != "misra-c2012-2.5" and rule != "misra-c2012-2.4"]
            assert not dirty, f"template code of {name} ({form}) not clean: {dirty}"
            total.update(found)
    return total


@pytest.mark.slow
def test_no_rule_grows_past_the_baseline_and_no_required_rule_has_a_finding(counts):
    assert misra.regressions(misra.by_rule(counts), misra.load_baseline()) == []


def test_the_check_can_fail():
    baseline = {"misra-c2012-10.5": 3}
    assert misra.regressions({"misra-c2012-10.5": 4}, baseline)
    assert misra.regressions({"misra-c2012-99.9": 1}, {"misra-c2012-99.9": 5})  # not known to be advisory
    assert misra.regressions({"misra-c2012-10.3": 1}, {"misra-c2012-10.3": 5})  # required: none may remain
    assert misra.regressions({"misra-c2012-10.5": 3}, baseline) == []


def test_checker_finds_a_planted_violation(config):
    if shutil.which("cppcheck") is None:
        pytest.skip("cppcheck not installed")
    files = render(config, "kf2dof")
    files["vse_kf2dof.c"] = files["vse_kf2dof.c"].replace(
        "    pack_input(in, u);\n", "    pack_input(in, u);\n    goto done;\ndone:\n", 1)
    found = misra.findings(files)
    assert any(f == "vse_kf2dof.c" and rule == "misra-c2012-15.1" for f, rule in found)


def test_recorded_code_is_not_scanned_again_and_changed_code_is(config, monkeypatch):
    """The baseline update records each folder's findings by the SHA-256 of its code: the shipped
    code is recorded, so CI need not run cppcheck for minutes; a changed file is scanned."""
    if shutil.which("cppcheck") is None:
        pytest.skip("cppcheck not installed")
    files = render(config, "kf2dof", "double", "baked")
    planted = Counter({("vse_kf2dof.h", "misra-c2012-99.9"): 1})
    monkeypatch.setattr(misra, "scan", lambda _: planted)
    assert misra.findings(files) != planted
    changed = {**files, "vse_kf2dof.h": files["vse_kf2dof.h"] + "\n/* edited */\n"}
    assert misra.findings(changed) == planted
