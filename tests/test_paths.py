"""Every repository path named in the code, the docs and the vehicle files exists: a module, a doc
or a folder that moves takes its mentions with it."""

from __future__ import annotations

import re
import subprocess

from locations import REPO

TOP_FOLDERS = ("harness", "codegen", "model", "bench", "tests", "docs", "generated", "vehicles", "scripts", "data",
               "examples")
PATH = re.compile(r"(?<![\w/.-])((?:" + "|".join(TOP_FOLDERS) + r")/[A-Za-z0-9_./-]*[A-Za-z0-9_])(?=([*<{]?))")
USER_PROJECT = {"vehicles/car.toml", "vehicles/bad.toml", "generated/car"}
"""Paths of a user's project (the starter's car, an example of a mistake), not of this repository."""
SUFFIXES = (".py", ".md", ".toml", ".j2", ".c", ".h", ".cfg", ".ld")


def named_paths() -> dict[str, set[str]]:
    """{path named: the files naming it} over every tracked text file but generated/."""
    tracked = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    named: dict[str, set[str]] = {}
    for file in tracked:
        if not file.endswith(SUFFIXES) or file.startswith("generated/"):
            continue
        for match in PATH.finditer((REPO / file).read_text(errors="replace")):
            if match.group(2):           # a pattern (step_*.c.j2, table3_<car>.md, {name})
                continue
            named.setdefault(match.group(1).rstrip("."), set()).add(file)
    return named


def test_every_repository_path_named_exists():
    missing = {path: sorted(files) for path, files in named_paths().items()
               if path not in USER_PROJECT and not (REPO / path).exists()}
    assert missing == {}


def test_the_check_finds_a_path_that_moved():
    moved = "harness" + "/compare.py"             # written in two parts, so that this file does not name it
    assert "harness/verify/compare.py" in named_paths()
    assert not (REPO / moved).exists() and PATH.search(f"see {moved}.").group(1) == moved
