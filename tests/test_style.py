"""The code style is checked, not discussed: ruff (configured in pyproject.toml) finds nothing."""

from __future__ import annotations

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
