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
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.sim.scenarios import VERIFICATION_SET, Case
from vsegen.harness.verify import code_coverage, decision_sites, model_coverage
from vsegen.harness.verify.equivalence import case_inputs
from vsegen.model.estimator import Particles
from vsegen.model.estimators import build_fresh
from vsegen.model.params import VehicleConfig


@dataclass(frozen=True)
class Justification:
    """Why a decision is taken one way only: it cannot be taken the other way by any plausible
    input, or need not be."""

    estimator: str
    """The estimator's name, or "*" for every estimator."""
    site: str
    """A regular expression on the decision's site (``decision_sites``: ``file.py:line function``)."""
    kind: str
    way: bool
    """The way it is taken."""
    why: str


JUSTIFIED: tuple[Justification, ...] = (
    Justification("*", r"^guard\.py:\d+ model_speed\b", "min", True,
                  "the speed clamp's upper bound is the v_x plausibility limit (vx_max): the model sees "
                  "a plausible (held) speed, so the clamp never returns vx_max from above; only a "
                  "corrupted state reaches past it"),
    Justification("fusion", r"^estimators/fusion\.py:\d+ kinematic_weight$", "max", True,
                  "|a_y,f| / (2 threshold) is never negative, so the weight's lower clamp never acts"),
    Justification("*", r"^increments\.py:\d+ sqrt <- three_dof\.py:\d+ adhesion$", "max", True,
                  "the 0/0 guard of the pair's square roots: adhesion's root is of (mu F_z - G)^2 + W^2 "
                  ">= W^2 (W = ADHESION_ROUNDING, 100 N), so the roots sum to at least 200 N, never "
                  "below the guard's 1e-30"),
    Justification("*", r"^increments\.py:\d+ sqrt <- three_dof\.py:\d+ tyre$", "max", True,
                  "the 0/0 guard of the pair's square roots of a tyre's combined slip demand: they sum "
                  "to less than 1e-30 only when the demand is exactly 0 at the mean and at both sigma "
                  "points (a zero sigma spread and a slip that rounds to exactly 0); kept for that case"),
    Justification("aukf", r"^estimators/aukf\.py:\d+ _sage_husa$", "min", True,
                  "the ceiling of the adapted Q (process_noise_max) bounds what abusive inputs (a_y "
                  "alternating +-25 m/s^2) taught Sage-Husa; such inputs raise a monitor bit, and no "
                  "sample with a bit raised is learnt from (20 abusive runs of 3000 samples: no entry "
                  "reached its ceiling); kept as the bound of the noise state for an input no monitor "
                  "flags"),
)


@dataclass
class ModelCoverage:
    """The decisions of one estimator's step and the ways they are taken."""

    name: str
    """The estimator's."""
    scenarios: model_coverage.Counts
    """Over the verification scenarios."""
    with_faults: model_coverage.Counts
    """Over the scenarios and the injected state faults (:data:`STATE_FAULTS`)."""

    def one_way(self) -> list[tuple[model_coverage.Decision, bool, str | None]]:
        """The decisions taken one way only even with the faults: (decision, way, justification)."""
        return [(d, way, justification(d, way, self.name)) for d, way in self.with_faults.one_way()]

    def by_faults_only(self) -> list[model_coverage.Decision]:
        """The decisions that only an injected state fault takes both ways."""
        left = {d.index for d, _ in self.with_faults.one_way()}
        return [d for d, _ in self.scenarios.one_way() if d.index not in left]


@dataclass
class EstimatorCoverage:
    """The coverage of one estimator of one vehicle."""

    vehicle: str
    name: str
    model: ModelCoverage | None
    """None for a particle filter (its step is not one SX function)."""
    code: dict[str, list[code_coverage.FileCoverage]] = field(default_factory=dict)
    """By form ("double-baked")."""
    sources: dict[str, dict[str, list[str]]] = field(default_factory=dict)
    """The measured sources' lines, by form and file."""


STATE_FAULTS: tuple[tuple[str, Callable[[np.ndarray], np.ndarray]], ...] = (
    ("every entry negated", lambda state: -state),
    ("every entry times 1e6", lambda state: 1e6 * state),
    ("every entry times 3", lambda state: 3.0 * state),
)
"""Injected faults of the state (a corrupted memory), applied to the state in the middle of the
first scenario, which then runs on for FAULT_STEPS samples: variances below zero and a covariance
no longer positive definite; variances, noise estimates and estimates far above any bound; and
every estimate a few times too large, still within its numbers' range (a learned parameter beyond
the band it is clamped to, which a filter re-fitting from a huge covariance never reaches)."""
FAULT_STEPS = 20


def measure(config: VehicleConfig, name: str, forms: list[tuple[str, str]], folder: Path,
            cases: tuple[Case, ...] = VERIFICATION_SET, seed: int = 1) -> EstimatorCoverage:
    """Model coverage of ``name`` and code coverage of each of its ``forms`` (real, params), built
    under ``folder``."""
    estimator, compiled = compile_estimator(config, name, "double", "baked")
    result = EstimatorCoverage(config.name, name, None)
    if not isinstance(estimator.structure, Particles):
        runs = []
        for case in cases:
            inputs = case_inputs(config, estimator, case, seed, "double")
            runs.append((compiled.run(inputs)[1][:-1], inputs))
        result.model = model_of(config, name, runs)
    for real, params in forms:
        form = f"{real}-{params}"
        inputs = [case_inputs(config, estimator, case, seed, real) for case in cases]
        where = folder / config.name / name / form
        result.code[form] = code_coverage.measure(config, name, real, params, inputs, where)
        result.sources[form] = {f.file: (where / f.file).read_text().splitlines() for f in result.code[form]}
    return result


def model_of(config: VehicleConfig, name: str, runs: list[tuple[np.ndarray, np.ndarray]]) -> ModelCoverage:
    """The model coverage of ``name`` over ``runs`` ((states, inputs) of its double baked C), and
    with the state faults injected into the first; the step is built anew under
    ``decision_sites.traced`` so that each decision has its site."""
    with decision_sites.traced() as sites:
        step = build_fresh(name, config, "baked").step
    return ModelCoverage(name, model_coverage.count(step, runs, sites),
                         model_coverage.count(step, [*runs, *state_faults(step, *runs[0])], sites))


def state_faults(step: ca.Function, states: np.ndarray, inputs: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(states, inputs) of the CasADi ``step`` run from each of :data:`STATE_FAULTS` applied to
    ``states``' middle entry, over the inputs that follow it."""
    start = len(states) // 2
    runs = []
    for _, fault in STATE_FAULTS:
        state, visited = fault(states[start]), []
        for row in inputs[start:start + FAULT_STEPS]:
            visited.append(state)
            state = np.array(step.call([state, row])[0]).ravel()
        runs.append((np.array(visited), inputs[start:start + FAULT_STEPS]))
    return runs


def justification(decision: model_coverage.Decision, way: bool, name: str = "*") -> str | None:
    """Why ``decision`` of estimator ``name``, taken ``way`` only, may be, if :data:`JUSTIFIED` says."""
    return next((j.why for j in JUSTIFIED
                 if j.estimator in ("*", name) and j.kind == decision.kind and j.way == way
                 and decision.site is not None and re.search(j.site, decision.site)), None)


def markdown(results: list[EstimatorCoverage], written_by: str) -> str:
    """docs/coverage.md: a summary table, then per estimator what is not covered and why."""
    faults = "; ".join(label for label, _ in STATE_FAULTS)
    lines = ["# Coverage of the models and of the generated C", "",
             f"{written_by}. Over the {len(VERIFICATION_SET)} verification runs (seed 1; the synthetic "
             "`input_extremes` among them drives inputs to the edges of the decisions); a calibratable "
             "form also runs a few samples with each calibration entry a check reads set to NaN (and, "
             "for the state-matrix norm, as an oversteering car and with a yaw inertia 1000 times too "
             "small).", "",
             "Model: every decision of the CasADi step (comparisons, logic, min/max, if_else on a flag) "
             "counted true and false, evaluated from the C's states, and named by the model line that "
             "built it. Then with injected state faults (a corrupted memory: "
             f"{faults}; from the middle of the first run, {FAULT_STEPS} samples on, stepped by the "
             "CasADi function), which reach the defensive code no input reaches (a covariance that is "
             "no longer positive definite). A decision still taken one way only is listed with the "
             "reason it may be, or as **not justified**.", "",
             "Code: gcc --coverage -O0 and gcovr; statements are lines with code; the kernel is "
             "CasADi's straight-line output (its branches are the model's decisions, compiled), the "
             "template vsegen's API and checks.", "",
             "| vehicle | estimator | model decisions | both ways | with state faults | one way: justified "
             "| not justified | form | template statements | template branches | kernel statements "
             "| kernel branches |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
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
        return "- | - | - | - | -"
    one_way = r.model.one_way()
    justified = sum(1 for *_, why in one_way if why)
    return (f"{len(r.model.scenarios.decisions)} | {r.model.scenarios.both_ways} | {r.model.with_faults.both_ways} | "
            f"{justified} | {len(one_way) - justified}")


def _share(files: list[code_coverage.FileCoverage], what: str) -> str:
    total = sum(getattr(f, what) for f in files)
    done = sum(getattr(f, "lines_run" if what == "lines" else "branches_taken") for f in files)
    return f"{done}/{total} ({100.0 * done / total:.1f} %)" if total else "-"


def _model_section(r: EstimatorCoverage) -> list[str]:
    if r.model is None:
        return ["Model: a particle filter's step is not one SX function (random numbers, resampling); its "
                "decisions are in the C and counted by the code coverage below.", ""]
    total = len(r.model.scenarios.decisions)
    lines = _by_faults_only(r.model.by_faults_only())
    one_way = r.model.one_way()
    if not one_way:
        return [f"Model: all {total} decisions taken both ways.", "", *lines]
    rows: dict[tuple, list] = {}
    for decision, way, why in one_way:
        rows.setdefault((decision.site, decision.kind, way, why), []).append(decision)
    lines += [f"Model: {len(one_way)} of {total} decisions taken one way only, by the model line that built "
              "them:", "", "| where | kind | taken | decisions | e.g. | why |", "|---|---|---|---|---|---|"]
    for (site, kind, way, why), decisions in rows.items():
        lines.append(f"| `{site or 'not traced'}` | {kind} | {'true' if way else 'false'} only | {len(decisions)} | "
                     f"`{_cell(decisions[0].expression)}` | {why or '**not justified**'} |")
    return [*lines, ""]


def _by_faults_only(decisions: list[model_coverage.Decision]) -> list[str]:
    if not decisions:
        return []
    counts = Counter((d.site, d.kind) for d in decisions)
    return ["Taken both ways only with an injected state fault:", "",
            *[f"- `{site or 'not traced'}`: {n} {kind}" for (site, kind), n in counts.items()], ""]


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
    """Shares over every estimator and form: model decisions both ways (with the state faults) or
    justified, template statements and branches, and the count not justified (for the CLI's last
    line)."""
    models = [r.model for r in results if r.model is not None]
    one_way = [why for m in models for *_, why in m.one_way()]
    covered = sum(m.with_faults.both_ways for m in models) + sum(1 for why in one_way if why)
    files = [f for r in results for fs in r.code.values() for f in fs if f.kind == "template"]
    return {"model": 100.0 * covered / max(1, sum(len(m.scenarios.decisions) for m in models)),
            "statements": 100.0 * sum(f.lines_run for f in files) / max(1, sum(f.lines for f in files)),
            "branches": 100.0 * sum(f.branches_taken for f in files) / max(1, sum(f.branches for f in files)),
            "not_justified": float(sum(1 for why in one_way if not why))}
