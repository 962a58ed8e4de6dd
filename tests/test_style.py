"""The code style is checked, not discussed: ruff (configured in pyproject.toml) finds nothing."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess

import pytest
from locations import REPO


def test_ruff_is_clean():
    ruff = shutil.which("ruff")
    if ruff is None:
        if os.environ.get("CI"):
            pytest.fail("ruff is required in CI (pip install -e '.[test]' installs it)")
        pytest.skip("ruff not installed")
    result = subprocess.run([ruff, "check", "--no-cache", "."], cwd=REPO, capture_output=True,
                            text=True)
    assert result.returncode == 0, result.stdout + result.stderr


LONGEST_FUNCTION = 80
"""Lines a function of model/, codegen/ or harness/ may have at most: a longer one is split into its
sections (as the estimators' builders are: initialisation, prediction, update, monitors)."""


LONGEST_BUILDER = 60
"""Lines an estimator's builder (``build`` or ``_build`` in model/estimators/) may have at most: the
checks beyond the method come from its monitor block, each section of the method is a function."""


def long_functions(path, limit: int = LONGEST_FUNCTION, names: tuple[str, ...] = ()) -> list[str]:
    """``name (lines)`` of every function in ``path`` (of ``names``, if given) longer than ``limit``."""
    tree = ast.parse(path.read_text(), str(path))
    return [f"{node.name} ({node.end_lineno - node.lineno + 1})" for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and (not names or node.name in names)
            and node.end_lineno - node.lineno + 1 > limit]


def test_no_function_is_longer_than_80_lines():
    found = {str(path.relative_to(REPO)): long_functions(path)
             for folder in ("model", "codegen", "harness") for path in sorted((REPO / folder).rglob("*.py"))}
    assert {k: v for k, v in found.items() if v} == {}


def test_no_estimator_builder_is_longer_than_60_lines():
    found = {path.name: long_functions(path, LONGEST_BUILDER, ("build", "_build"))
             for path in sorted((REPO / "model" / "estimators").glob("*.py"))}
    assert {k: v for k, v in found.items() if v} == {}


def test_the_length_check_sees_a_long_function(tmp_path):
    path = tmp_path / "long.py"
    path.write_text("def short():\n    pass\n\n\ndef long():\n" + "    x = 1\n" * LONGEST_FUNCTION)
    assert long_functions(path) == [f"long ({LONGEST_FUNCTION + 1})"]
    assert long_functions(path, 60, ("short",)) == []
