"""Sections of the generated reports (docs/benchmarks.md): each written by its own command and
kept when another command rewrites the rest."""

from __future__ import annotations

from pathlib import Path


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
