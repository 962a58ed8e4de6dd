"""The generated reports: where each says what produced it, and sections (docs/benchmarks.md)
each written by its own command and kept when another command rewrites the rest."""

from __future__ import annotations

import argparse
import subprocess
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import casadi

from bench import REPO


def provenance(command: str) -> str:
    """'Written by `command` at commit abc1234 (vsegen 0.1.0, CasADi 3.8.2)': the command and the
    commit a report's numbers come from, noting changes to the code not yet committed (the reports
    under docs/ themselves do not count)."""
    commit = _git("rev-parse", "--short=10", "HEAD") or "(not a git checkout)"
    changed = _git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)docs")
    return (f"Written by `{command}` at commit {commit}{' plus uncommitted changes' if changed else ''} "
            f"(vsegen {metadata.version('vsegen')}, CasADi {casadi.__version__})")


def _git(*args: str) -> str:
    done = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else ""


def section_of(document: str, heading: str) -> list[str]:
    """The lines of ``document``'s section ``heading`` (a '## ' line) up to the next '## '
    heading or the end; empty if it has none."""
    lines = document.rstrip("\n").split("\n")
    if heading not in lines:
        return []
    start = lines.index(heading)
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    return lines[start:end]


def with_section(document: str, body: list[str]) -> str:
    """``document`` with the section headed ``body[0]`` replaced by ``body``, or ``body``
    appended."""
    lines = document.rstrip("\n").split("\n") if document else []
    old = section_of(document, body[0])
    if old:
        start = lines.index(body[0])
        lines[start:start + len(old)] = body + ([""] if start + len(old) < len(lines) else [])
    else:
        lines += ([""] if lines else []) + body
    return "\n".join(lines).rstrip("\n") + "\n"


def write_section(report: Path, body: list[str]) -> None:
    """Replace (or append) the section ``body`` in the report file ``report``, then print it."""
    previous = report.read_text() if report.exists() else ""
    report.write_text(with_section(previous, body))
    print("\n".join(body))


def write_cluster_report(description: str, out: Path, report: Callable[[str | None], list[str]],
                         argv: list[str] | None = None) -> None:
    """The command line of a report whose runs go to a Dask cluster: parse ``--scheduler``, write
    ``report(scheduler)``'s lines to ``out`` and say so."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--scheduler", default=None, help="'local' (default), 'serial' or a Dask "
                        "scheduler address")
    args = parser.parse_args(argv)
    out.write_text("\n".join(report(args.scheduler)) + "\n")
    print(f"wrote {out}")
