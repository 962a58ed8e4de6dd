"""`vsegen verify --coverage`: model and code coverage of each verified estimator over the
verification scenarios, and its report (docs/coverage.md).

Model coverage (``model_coverage``) is measured once per estimator on its double baked step, from
the states of its double baked C; code coverage (``code_coverage``) once per form verified. What
is not covered both ways is listed; an entry of :data:`JUSTIFIED` that matches it says why it
cannot or need not be (a decision that no plausible input reaches), else it is marked
**not justified**.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.sim.scenarios import VERIFICATION_SET, Case
from vsegen.harness.verify import code_coverage, model_coverage
from vsegen.harness.verify.equivalence import case_inputs
from vsegen.model.estimator import Particles
from vsegen.model.params import VehicleConfig

JUSTIFIED: tuple[tuple[str, str, str], ...] = (
    ("*", r"fmin\(fmax\(state_\d+,3\),90\)$|@1=90, @2=\(fabs\(input_1\)<=@1\), @3=3, fmin\(fmax\(.*,@3\),@1\)$",
     "the speed clamp's upper bound: v_x is held at its last plausible value, and a plausible v_x is "
     "at most vx_max (90 m/s), so the clamp never returns 90 from above"),
)
"""(estimator or "*", a regular expression on the decision's expression, why it is taken one way only)."""


@dataclass
class EstimatorCoverage:
    """The coverage of one estimator of one vehicle."""

    vehicle: str
    name: str
    model: model_coverage.Counts | None
    """None for a particle filter (its step is not one SX function)."""
    code: dict[str, list[code_coverage.FileCoverage]] = field(default_factory=dict)
    """By form ("double-baked")."""
    sources: dict[str, dict[str, list[str]]] = field(default_factory=dict)
    """The measured sources' lines, by form and file."""


def measure(config: VehicleConfig, name: str, forms: list[tuple[str, str]], folder: Path,
            cases: tuple[Case, ...] = VERIFICATION_SET, seed: int = 1) -> EstimatorCoverage:
    """Model coverage of ``name`` and code coverage of each of its ``forms`` (real, params), built
    under ``folder``."""
    estimator, compiled = compile_estimator(config, name, "double", "baked")
    model = None
    if not isinstance(estimator.structure, Particles):
        runs = []
        for case in cases:
            inputs = case_inputs(config, estimator, case, seed, "double")
            runs.append((compiled.run(inputs)[1][:-1], inputs))
        model = model_coverage.count(estimator.step, runs)
    result = EstimatorCoverage(config.name, name, model)
    for real, params in forms:
        form = f"{real}-{params}"
        inputs = [case_inputs(config, estimator, case, seed, real) for case in cases]
        where = folder / config.name / name / form
        result.code[form] = code_coverage.measure(config, name, real, params, inputs, where)
        result.sources[form] = {f.file: (where / f.file).read_text().splitlines() for f in result.code[form]}
    return result


def justification(name: str, decision: model_coverage.Decision) -> str | None:
    """Why ``decision`` of estimator ``name`` is taken one way only, if :data:`JUSTIFIED` says."""
    return next((why for who, pattern, why in JUSTIFIED
                 if who in ("*", name) and re.search(pattern, decision.expression)), None)


def markdown(results: list[EstimatorCoverage], written_by: str) -> str:
    """docs/coverage.md: a summary table, then per estimator what is not covered and why."""
    lines = ["# Coverage of the models and of the generated C", "",
             f"{written_by}. Over the {len(VERIFICATION_SET)} verification scenarios (seed 1); a calibratable "
             "form also runs a few samples with each calibration entry a check reads set to NaN (and, for the "
             "state-matrix norm, as an oversteering car and with a yaw inertia 1000 times too small). Model: "
             "every decision of the CasADi step (comparisons, logic, min/max, if_else on a flag) counted true "
             "and false, evaluated from the C's states. Code: gcc --coverage -O0 and gcovr; statements are "
             "lines with code; the kernel is CasADi's straight-line output (its branches are the model's "
             "decisions, compiled), the template vsegen's API and checks.", "",
             "| vehicle | estimator | model decisions | both ways | one way (justified) | form | template statements "
             "| template branches | kernel statements | kernel branches |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        for form, files in r.code.items():
            template = [f for f in files if f.kind == "template"]
            kernel = [f for f in files if f.kind == "kernel"]
            lines.append(f"| {r.vehicle} | {r.name} | {_model_cells(r)} | {form} | {_share(template, 'lines')} | "
                         f"{_share(template, 'branches')} | {_share(kernel, 'lines')} | {_share(kernel, 'branches')} |")
    for r in results:
        lines += ["", f"## {r.vehicle} / {r.name}", ""]
        lines += _model_section(r) + _code_section(r)
    return "\n".join(lines) + "\n"


def _model_cells(r: EstimatorCoverage) -> str:
    if r.model is None:
        return "- | - | -"
    one_way = r.model.one_way()
    justified = sum(1 for d, _ in one_way if justification(r.name, d))
    return f"{len(r.model.decisions)} | {r.model.both_ways} | {len(one_way)} ({justified})"


def _share(files: list[code_coverage.FileCoverage], what: str) -> str:
    total = sum(getattr(f, what) for f in files)
    done = sum(getattr(f, "lines_run" if what == "lines" else "branches_taken") for f in files)
    return f"{done}/{total} ({100.0 * done / total:.1f} %)" if total else "-"


def _model_section(r: EstimatorCoverage) -> list[str]:
    if r.model is None:
        return ["Model: a particle filter's step is not one SX function (random numbers, resampling); its "
                "decisions are in the C and counted by the code coverage below.", ""]
    one_way = r.model.one_way()
    if not one_way:
        return [f"Model: all {len(r.model.decisions)} decisions taken both ways.", ""]
    lines = [f"Model: {len(one_way)} of {len(r.model.decisions)} decisions taken one way only:", "",
             "| decision | kind | taken | why |", "|---|---|---|---|"]
    for decision, way in one_way:
        why = justification(r.name, decision) or "**not justified**"
        lines.append(f"| `{_cell(decision.expression)}` | {decision.kind} | {'true' if way else 'false'} only | "
                     f"{why} |")
    return [*lines, ""]


def _code_section(r: EstimatorCoverage) -> list[str]:
    lines = []
    for form, files in r.code.items():
        for f in files:
            if f.kind != "template" or (not f.lines_never and not f.branches_never):
                continue
            source = r.sources[form][f.file]
            lines += [f"Template code not covered, {form}, `{f.file}`:", ""]
            lines += [f"- line {n}: statement never run: `{_cell(source[n - 1].strip())}`" for n in f.lines_never]
            lines += [f"- line {n}: a branch never taken: `{_cell(source[n - 1].strip())}`" for n in f.branches_never]
            lines.append("")
    return lines or ["Template code: every statement run and every branch taken in every form.", ""]


def _cell(text: str) -> str:
    text = text if len(text) <= 140 else text[:139] + "…"
    return text.replace("|", "\\|").replace("`", "'")


def totals(results: list[EstimatorCoverage]) -> dict[str, float]:
    """Shares over every estimator and form: model decisions both ways or justified, template
    statements and branches (for the CLI's last line)."""
    decisions = [r.model for r in results if r.model is not None]
    covered = sum(m.both_ways for m in decisions) + sum(
        1 for r in results if r.model for d, _ in r.model.one_way() if justification(r.name, d))
    files = [f for r in results for fs in r.code.values() for f in fs if f.kind == "template"]
    return {"model": 100.0 * covered / max(1, sum(len(m.decisions) for m in decisions)),
            "statements": 100.0 * sum(f.lines_run for f in files) / max(1, sum(f.lines for f in files)),
            "branches": 100.0 * sum(f.branches_taken for f in files) / max(1, sum(f.branches for f in files)),
            "not_justified": float(sum(1 for r in results if r.model for d, _ in r.model.one_way()
                                       if not justification(r.name, d)))}

