"""MISRA C:2012 findings of generated code (cppcheck's MISRA addon), their justifications, and the
baseline the count must not exceed.

What the templates and shims control is fixed (see codegen/kernel.py and the templates); what
remains comes from CasADi's code generator or from public-API declarations, and each rule left has
a justification below. ``vsegen misra`` writes the deviation report (docs/misra.md) and, with
``--update-baseline``, the baseline; the tests fail when a count grows or a rule has no
justification. The kernel source is checked in its double, baked form (:func:`estimator_findings`).

cppcheck needs minutes for the big kernels, so the findings of every folder scanned by ``vsegen
misra --update-baseline`` are recorded with the SHA-256 of what was scanned (the cppcheck version,
the file names and their text; ``misra_findings.json``): a folder whose code has not changed since
is not scanned again, and any change is (:func:`findings`).
"""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import tempfile
from collections import Counter
from functools import lru_cache
from importlib import metadata
from pathlib import Path

import casadi

from vsegen.codegen.generate import EXAMPLE

BASELINE = Path(__file__).resolve().with_name("misra_baseline.json")
RECORD = Path(__file__).resolve().with_name("misra_findings.json")
"""The findings of the folders scanned at the last baseline update, by the SHA-256 of their code."""

JUSTIFICATIONS = {
    "misra-c2012-2.4": "The anonymous enum of state indices in the public header is for the "
                       "application; the library itself does not use it.",
    "misra-c2012-2.5": "Public macros (status bits, sample time, vector sizes, parameter hash) are "
                       "declared for the application and are not used inside the library.",
    "misra-c2012-10.5": "CasADi's straight-line code keeps a comparison's 0/1 in a casadi_real "
                        "temporary; codegen/kernel.py writes that conversion as a cast (rule 10.3, "
                        "required, is then met; the machine code is the same, tested).",
    "misra-c2012-12.3": "CasADi declares its temporaries in one declaration (casadi_real a0, a1, ...), "
                        "which the checker reports as a comma operator; none is evaluated.",
    "misra-c2012-20.10": "CasADi's symbol-prefix macro (CASADI_PREFIX) pastes tokens with ##; its "
                         "expansion is fixed and reviewed (the prefixed names in the kernel).",
}
ADVISORY = frozenset(JUSTIFICATIONS)
"""The rules with findings left, all advisory in MISRA C:2012 (2.4, 2.5, 10.5, 12.3, 20.10): a
finding of any other rule (a required one, e.g. 10.3) fails `vsegen misra` whatever the baseline."""
_FINDING = re.compile(r"^(?P<file>[^:]+):\d+:\d+: (?P<rule>[\w.-]+)$")


@lru_cache(maxsize=1)
def _cppcheck_version() -> str:
    return subprocess.run(["cppcheck", "--version"], capture_output=True, text=True).stdout.strip()


@lru_cache(maxsize=1)
def _recorded() -> dict:
    return json.loads(RECORD.read_text()) if RECORD.is_file() else {}


def code_key(files: dict[str, str]) -> str:
    """SHA-256 of what :func:`findings` scans of ``files``, with the cppcheck version."""
    digest = hashlib.sha256(_cppcheck_version().encode())
    for name in sorted(n for n in files if n.endswith((".c", ".h")) and n != EXAMPLE):
        digest.update(b"\0" + name.encode() + b"\0" + files[name].encode())
    return digest.hexdigest()


def findings(files: dict[str, str]) -> Counter:
    """Counter of (file, rule) for the library files of one generated folder: as recorded for
    this code (:data:`RECORD`), or from cppcheck."""
    recorded = _recorded().get(code_key(files))
    if recorded is not None:
        return Counter({(file, rule): count for file, rule, count in recorded})
    return scan(files)


def scan(files: dict[str, str]) -> Counter:
    """Counter of (file, rule) for the library files of one generated folder, from cppcheck."""
    names = sorted(n for n in files if n.endswith((".c", ".h")) and n != EXAMPLE)
    with tempfile.TemporaryDirectory(prefix="vsegen-misra-") as tmp:
        for name in names:
            (Path(tmp) / name).write_text(files[name])
        result = subprocess.run(
            ["cppcheck", "--addon=misra", "--std=c99", "--quiet",
             "--template={file}:{line}:{column}: {id}", *names],
            cwd=tmp, capture_output=True, text=True)
    counts: Counter = Counter()
    for line in (result.stdout + result.stderr).splitlines():
        match = _FINDING.match(line.strip())
        if match:
            counts[(match["file"], match["rule"])] += 1
    return counts


VARIANTS = (("double", "baked"), ("double", "calibratable"), ("float", "baked"),
            ("float", "calibratable"))
"""Every generated form of an estimator; the first is the one whose kernel source is checked."""


def estimator_findings(config, name: str, fresh: bool = False) -> list[tuple[str, Counter, str]]:
    """(form, findings, code key) for every form of estimator ``name``: all library files of the
    first form, and the template files (with the kernel's header) of the others. The kernel
    sources of the other forms differ only in literal types and the parameter vector, and cppcheck
    needs minutes for each of the unscented filters' kernels. ``fresh``: scan even recorded code."""
    from vsegen.codegen.generate import render

    results = []
    for index, (real, params) in enumerate(VARIANTS):
        files = render(config, name, real, params)
        if index:
            files = {n: t for n, t in files.items() if n != f"vse_{name}_kernel.c"}
        results.append((f"{real}, {params}", scan(files) if fresh else findings(files), code_key(files)))
    return results


def distinct_code(estimators: list[tuple]) -> list[tuple]:
    """The (config, name) pairs whose code can differ in structure: the first of each estimator
    and set of choice settings (strings, e.g. discretisation or longitudinal_force). Two vehicles
    with the same choices generate the same statements with other numbers, which MISRA does not
    judge differently; checking both only doubled the scan."""
    seen, kept = set(), []
    for config, name in estimators:
        choices = tuple(sorted((k, v) for k, v in config.settings(name).items() if isinstance(v, str)))
        if (name, choices) not in seen:
            seen.add((name, choices))
            kept.append((config, name))
    return kept


def all_findings(estimators: list[tuple], fresh: bool = False) -> list[list[tuple[str, Counter, str]]]:
    """:func:`estimator_findings` of every (config, name) pair, spread over worker processes
    (cppcheck runs one process per folder)."""
    from vsegen.harness.jobs.pool import ProcessPool

    with ProcessPool() as workers:
        return workers.map(estimator_findings, [(*pair, fresh) for pair in estimators])


def write_record(results: list[list[tuple[str, Counter, str]]]) -> None:
    """Record the findings of every scanned folder by its code key (:data:`RECORD`)."""
    record = {key: sorted([file, rule, count] for (file, rule), count in counts.items())
              for forms in results for _, counts, key in forms}
    RECORD.write_text(json.dumps(dict(sorted(record.items())), indent=1) + "\n")


def by_rule(counts: Counter) -> dict[str, int]:
    """Total per rule, sorted by rule."""
    totals: Counter = Counter()
    for (_, rule), count in counts.items():
        totals[rule] += count
    return dict(sorted(totals.items()))


def in_source_checkout() -> bool:
    """Whether the baseline belongs to a vsegen source checkout (it may be updated there only)."""
    return (BASELINE.parents[2] / "pyproject.toml").is_file()


def load_baseline() -> dict[str, int]:
    return json.loads(BASELINE.read_text())


def write_baseline(per_rule: dict[str, int]) -> None:
    BASELINE.write_text(json.dumps(per_rule, indent=2, sort_keys=True) + "\n")


def regressions(per_rule: dict[str, int], baseline: dict[str, int]) -> list[str]:
    """Rules whose count grew past the baseline, or that are not advisory (a required rule, or one
    without a justification): none of those may have a finding."""
    problems = [f"{rule}: {count} findings, baseline {baseline.get(rule, 0)}"
                for rule, count in per_rule.items() if count > baseline.get(rule, 0)]
    problems += [f"{rule}: {per_rule[rule]} findings of a required rule (or one not known to be advisory): "
                 f"none may remain" for rule in per_rule if rule not in ADVISORY]
    return problems


def provenance(project_root: Path, command: str = "vsegen misra", tool: str = "cppcheck") -> str:
    """What wrote a report: ``command``, the project's git commit (when it is a checkout) and the
    versions of vsegen, CasADi and ``tool`` (the checker the report rests on)."""
    def output(*command: str) -> str:
        try:
            done = subprocess.run(command, cwd=project_root, capture_output=True, text=True)
        except OSError:
            return ""
        return done.stdout.strip() if done.returncode == 0 else ""

    commit = output("git", "rev-parse", "--short=10", "HEAD")
    changed = commit and output("git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)docs")
    at = f" at commit {commit}{' plus uncommitted changes' if changed else ''}" if commit else ""
    return (f"Written by `{command}`{at} (vsegen {metadata.version('vsegen')}, CasADi {casadi.__version__}, "
            f"{output(tool, '--version').splitlines()[0] if output(tool, '--version') else tool})")


def report(sections: list[tuple[str, Counter]], written_by: str) -> str:
    """The deviation report (Markdown): per generated folder, per file and rule, the count and
    the justification; ``written_by`` is its first line (:func:`provenance`)."""
    lines = ["# MISRA C:2012 deviation report", "",
             f"{written_by}: cppcheck's MISRA addon on every generated library file (the host example "
             "is not checked). No required rule has a finding; every remaining finding is of an advisory "
             "rule and listed with its justification; the count per rule may not grow past vsegen's "
             "baseline (`harness/target/misra_baseline.json`, checked by the tests).", ""]
    for title, counts in sections:
        lines += [f"## {title}", "", "| file | rule | count | justification |", "|---|---|---|---|"]
        for (file, rule), count in sorted(counts.items()):
            lines.append(f"| `{file}` | {rule.removeprefix('misra-c2012-')} | {count} | "
                         f"{JUSTIFICATIONS.get(rule, '**not justified**')} |")
        lines += ["", f"Total: {sum(counts.values())} findings, of which "
                      f"{sum(c for (f, _), c in counts.items() if '_kernel' not in f)} in template "
                      "code.", ""]
    return "\n".join(lines)
