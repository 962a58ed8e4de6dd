"""Results for machines: JUnit XML (the test report every CI renders) and JSON, written the same way
by every checking command (verify, pil, size, misra, generate --check, campaign).

A result is a list of :class:`Check`: one JUnit test case each, grouped into test suites by
``suite`` (e.g. ``c_class.kf2dof.double-baked``), its figures as properties (and as the fields of its
JSON record), a failure with a one-line message when it failed.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from vsegen.harness.project.files import write_text_atomic

Figure = str | int | float | bool | None


@dataclass(frozen=True)
class Check:
    """One checked thing: a test case."""

    suite: str
    name: str
    figures: Mapping[str, Figure] = field(default_factory=dict)
    """What was measured and what it was judged against (JUnit properties, JSON fields)."""
    failure: str | None = None
    """Why it failed (one line); None: it passed."""
    kind: str = "check"
    """The failure's type (e.g. "tolerance", "stale generated code")."""

    @property
    def ok(self) -> bool:
        return self.failure is None


def as_junit(title: str, checks: Sequence[Check]) -> str:
    """``checks`` as JUnit XML: a test suite per ``suite`` in order, a test case per check (class
    name the suite), its figures as properties, a failure element where it failed."""
    root = ET.Element("testsuites", name=title, tests=str(len(checks)),
                      failures=str(sum(not c.ok for c in checks)))
    for suite_name in dict.fromkeys(c.suite for c in checks):
        mine = [c for c in checks if c.suite == suite_name]
        suite = ET.SubElement(root, "testsuite", name=suite_name, tests=str(len(mine)),
                              failures=str(sum(not c.ok for c in mine)), errors="0", skipped="0")
        for check in mine:
            case = ET.SubElement(suite, "testcase", name=check.name, classname=suite_name)
            if check.figures:
                properties = ET.SubElement(case, "properties")
                for name, value in check.figures.items():
                    ET.SubElement(properties, "property", name=name, value=_text(value))
            if not check.ok:
                ET.SubElement(case, "failure", message=check.failure, type=check.kind)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def as_json(title: str, checks: Sequence[Check], summary: Mapping[str, Figure] | None = None) -> str:
    """``checks`` as one JSON document: the title, ``summary``, the verdict and a record per check."""
    return json.dumps({"title": title, **(summary or {}), "checks_run": len(checks),
                       "checks_failed": sum(not c.ok for c in checks), "ok": all(c.ok for c in checks),
                       "checks": [{"suite": c.suite, "name": c.name, "ok": c.ok, "failure": c.failure,
                                   **{k: _json(v) for k, v in c.figures.items()}} for c in checks]},
                      indent=1) + "\n"


def write_results(junit: Path | None, json_path: Path | None, title: str, checks: Sequence[Check],
          summary: Mapping[str, Figure] | None = None) -> None:
    """Write the JUnit XML to ``junit`` and the JSON to ``json_path`` (each if given), atomically."""
    if junit is not None:
        write_text_atomic(junit, as_junit(title, checks))
    if json_path is not None:
        write_text_atomic(json_path, as_json(title, checks, summary))


def _text(value: Figure) -> str:
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    return "" if value is None else str(value)


def _json(value: Figure) -> Figure:
    """A number for JSON; 'inf' or 'nan' as strings (JSON has no such numbers)."""
    return str(value) if isinstance(value, float) and not math.isfinite(value) else value
