"""Verify results for machines: JSON, and JUnit XML (the test report every CI renders).

One record (a JUnit test case) per vehicle, estimator, form (real, params), scenario and signal,
its figures alongside (max |diff|, max relative difference, tolerance); a signal out of
tolerance is a failure whose message says by how much. The whole-state and step-from-the-C-state
checks are signals like the outputs ("state (all entries)", "step from the C state").
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

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


def records(run: Run, results: Sequence[CaseResult]) -> list[dict]:
    """One JSON-ready record per (estimator, scenario, signal) of ``results``."""
    return [{"vehicle": run.vehicle, "estimator": r.estimator, "real": run.real, "params": run.params,
             "scenario": r.case, "samples": r.samples, "signal": d.name, "max_abs": _number(d.max_abs),
             "max_rel": None if d.integer else _number(d.max_rel),
             "tolerance": "identical" if d.integer else d.tolerance, "ok": d.ok,
             "explained_flips": r.flips, "explained_crossings": r.crossings}
            for r in results for d in checks(r)]


def as_json(run: Run, results: Sequence[CaseResult]) -> str:
    """The results as a JSON document: the run, the verdict and every record."""
    rows = records(run, results)
    return json.dumps({"vehicle": run.vehicle, "real": run.real, "params": run.params,
                       "runs": len(results), "failed_runs": sum(not r.ok for r in results),
                       "stale_generated": dict(run.stale),
                       "ok": not run.stale and all(r.ok for r in results), "checks": rows}, indent=1) + "\n"


def as_junit(run: Run, results: Sequence[CaseResult]) -> str:
    """The results as JUnit XML: a test suite per estimator, a test case per scenario and signal
    (class name ``<vehicle>.<estimator>.<form>``), the figures as properties."""
    root = ET.Element("testsuites", name=f"vsegen verify {run.vehicle} {run.form}")
    for estimator, why in run.stale.items():
        suite = ET.SubElement(root, "testsuite", name=f"{run.vehicle}.{estimator}.{run.form}", tests="1",
                              failures="1", errors="0", skipped="0")
        case = ET.SubElement(suite, "testcase", name="generated folder is what the vehicle file generates",
                             classname=f"{run.vehicle}.{estimator}.{run.form}")
        ET.SubElement(case, "failure", message=why, type="stale generated code")
    for estimator in dict.fromkeys(r.estimator for r in results):
        mine = [r for r in results if r.estimator == estimator]
        cases = [(r, d) for r in mine for d in checks(r)]
        suite = ET.SubElement(root, "testsuite", name=f"{run.vehicle}.{estimator}.{run.form}",
                              tests=str(len(cases)), failures=str(sum(not d.ok for _, d in cases)),
                              errors="0", skipped="0")
        for result, difference in cases:
            case = ET.SubElement(suite, "testcase", name=f"{result.case}: {difference.name}",
                                 classname=f"{run.vehicle}.{estimator}.{run.form}")
            properties = ET.SubElement(case, "properties")
            for name, value in _figures(result, difference).items():
                ET.SubElement(properties, "property", name=name, value=value)
            if not difference.ok:
                ET.SubElement(case, "failure", message=_failure(difference), type="tolerance")
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def _figures(result: CaseResult, difference: Difference) -> dict[str, str]:
    figures = {"samples": str(result.samples), "max_abs": f"{difference.max_abs:.3e}"}
    if difference.integer:
        figures["tolerance"] = "identical"
    else:
        figures |= {"max_rel": f"{difference.max_rel:.3e}", "tolerance": f"{difference.tolerance:.0e}"}
    return figures


def _failure(difference: Difference) -> str:
    if difference.integer:
        return f"{difference.name} differs (max |diff| {difference.max_abs:.3e}); expected identical"
    return (f"{difference.name}: max relative difference {difference.max_rel:.3e} above the tolerance "
            f"{difference.tolerance:.0e} (max |diff| {difference.max_abs:.3e})")


def _number(value: float) -> float | str:
    """A float for JSON; 'inf' or 'nan' as strings (JSON has no such numbers)."""
    return value if math.isfinite(value) else str(value)
