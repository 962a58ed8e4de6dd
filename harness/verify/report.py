"""Verify results for machines: JSON, and JUnit XML (the test report every CI renders), written by
``harness.project.results``.

One record (a JUnit test case) per vehicle, estimator, form (real, params), scenario and signal,
its figures alongside (max |diff|, max relative difference, tolerance); a signal out of
tolerance is a failure whose message says by how much. The whole-state and step-from-the-C-state
checks are signals like the outputs ("state (all entries)", "step from the C state").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from vsegen.harness.project import results as results_io
from vsegen.harness.project.results import Check
from vsegen.harness.verify.compare import Difference
from vsegen.harness.verify.equivalence import CaseResult


@dataclass(frozen=True)
class Run:
    """Where the results come from: the vehicle file's name and the form verified, and the
    estimators whose generated/ folder was not what the vehicle file generates ({estimator: why};
    verify stops before running when there is one)."""

    vehicle: str
    real: str
    params: str
    stale: Mapping[str, str] = field(default_factory=dict)

    @property
    def form(self) -> str:
        return f"{self.real}-{self.params}"


def checks(result: CaseResult) -> tuple[Difference, ...]:
    """Every signal verify judges in one run: the outputs, the whole state and the steps taken
    from the C's state (once when they are the same check)."""
    stepwise = () if result.stepwise is result.states else (result.stepwise,)
    return (*result.outputs, result.states, *stepwise)


def as_checks(run: Run, results: Sequence[CaseResult]) -> list[Check]:
    """One check per stale estimator, then per (estimator, scenario, signal) of ``results``."""
    suite = f"{run.vehicle}.{{}}.{run.form}"
    stale = [Check(suite.format(estimator), "generated folder is what the vehicle file generates",
                   {"vehicle": run.vehicle, "estimator": estimator, "real": run.real, "params": run.params},
                   why, "stale generated code") for estimator, why in run.stale.items()]
    return stale + [Check(suite.format(r.estimator), f"{r.case}: {d.name}", _figures(run, r, d),
                          None if d.ok else _failure(d), "tolerance")
                    for r in results for d in checks(r)]


def as_json(run: Run, results: Sequence[CaseResult]) -> str:
    """The results as a JSON document: the run, the verdict and every check."""
    return results_io.as_json(_title(run), as_checks(run, results),
                              {"vehicle": run.vehicle, "real": run.real, "params": run.params, "runs": len(results),
                               "failed_runs": sum(not r.ok for r in results)})


def as_junit(run: Run, results: Sequence[CaseResult]) -> str:
    """The results as JUnit XML: a test suite per estimator, a test case per scenario and signal
    (class name ``<vehicle>.<estimator>.<form>``), the figures as properties."""
    return results_io.as_junit(_title(run), as_checks(run, results))


def _title(run: Run) -> str:
    return f"vsegen verify {run.vehicle} {run.form}"


def _figures(run: Run, result: CaseResult, difference: Difference) -> dict:
    figures = {"vehicle": run.vehicle, "estimator": result.estimator, "real": run.real, "params": run.params,
               "scenario": result.case, "signal": difference.name, "samples": result.samples,
               "max_abs": difference.max_abs}
    if difference.integer:
        figures["tolerance"] = "identical"
    else:
        figures |= {"max_rel": difference.max_rel, "tolerance": difference.tolerance}
    return figures | {"explained_flips": result.flips, "explained_crossings": result.crossings}


def _failure(difference: Difference) -> str:
    if difference.integer:
        return f"{difference.name} differs (max |diff| {difference.max_abs:.3e}); expected identical"
    return (f"{difference.name}: max relative difference {difference.max_rel:.3e} above the tolerance "
            f"{difference.tolerance:.0e} (max |diff| {difference.max_abs:.3e})")
