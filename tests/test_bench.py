"""The benchmark's hand-written baseline computes the same estimator (else the ratio means
nothing), and the benchmark drivers measure what they claim. Timing itself is never asserted."""

from __future__ import annotations

import ctypes
import re

import numpy as np
import pytest
from locations import REPO

from bench.document import section_of, with_section
from bench.measure import HERE, hand_raw_parameters
from vsegen.harness.host.build import build_library
from vsegen.harness.project.vehicles import with_settings
from vsegen.harness.reference import kf2dof as reference
from vsegen.harness.reference.loop import run_reference
from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.harness.verify.compare import TOLERANCES, difference
from vsegen.model.params import parse_vehicle

WRAPPER = """
#include "kf2dof_hand.h"
void hand_run(int n, const double *raw, const double *inputs, double *outputs);
void hand_run(int n, const double *raw, const double *inputs, double *outputs)
{
    kf2dof_hand_params p;
    kf2dof_hand_state s;
    int k;
    kf2dof_hand_setup(&p, raw);
    kf2dof_hand_init(&s, &p, inputs);
    for (k = 0; k < n; ++k) {
        kf2dof_hand_step(&s, &p, inputs + 4 * k, outputs + 4 * k);
    }
}
"""


@pytest.mark.parametrize("method", ["zoh", "euler"])
def test_handwritten_baseline_equals_the_reference(vehicle_text, method):
    literal = with_settings(vehicle_text, "estimator.kf2dof", residual_window=0.0, linear_range=0.0,
                            frozen_time=0.0, lateral_check_limit=0.0, steering_offset_limit=0.0,
                            steer_check_limit=0.0, process_noise_load=0.0)
    config = parse_vehicle(literal.replace('discretisation = "zoh"', f'discretisation = "{method}"'),
                           "v.toml", "c_class")          # the hand-written filter has no monitors
    sources = {n: (HERE / "handwritten" / n).read_text() for n in ("kf2dof_hand.c", "kf2dof_hand.h")}
    library = ctypes.CDLL(str(build_library({}, {**sources, "wrap.c": WRAPPER})))
    raw = np.array(hand_raw_parameters(config))
    for case in VERIFICATION_SET:
        inputs = np.ascontiguousarray(case.simulate(config, 100.0).matrix(reference.INPUTS))
        outputs = np.zeros((len(inputs), 4))
        pointer = ctypes.POINTER(ctypes.c_double)
        library.hand_run(len(inputs), raw.ctypes.data_as(pointer), inputs.ctypes.data_as(pointer),
                         outputs.ctypes.data_as(pointer))
        expected, _ = run_reference(reference, config, inputs)
        for i, name in enumerate(reference.OUTPUTS):
            assert difference(name, outputs[:, i], expected[:, i], TOLERANCES["double"],
                              integer=name == "status").ok, (case.label, name)


def test_the_suite_keeps_every_section_another_command_writes():
    """Before, `python -m bench` dropped bench.campaign's two sections from docs/benchmarks.md."""
    from bench.__main__ import KEPT_SECTIONS
    text = (REPO / "docs" / "benchmarks.md").read_text()
    sections = re.findall(r"^(## .+)\n\n(Written by `python -m bench\.\w+`[^\n]*)", text, flags=re.M)
    others = {heading for heading, said in sections if "also written by `python -m bench`" not in said}
    assert others and others <= set(KEPT_SECTIONS), others - set(KEPT_SECTIONS)


def test_feedback_section_is_replaced_in_place_and_kept_by_the_suite():
    from bench import feedback
    body = [feedback.SECTION, "", "| new |"]
    document = "# Benchmarks\n\n## A\n\na\n\n## Feedback times\n\n| old |\n\n## B\n\nb\n"
    updated = with_section(document, body)
    assert updated == "# Benchmarks\n\n## A\n\na\n\n## Feedback times\n\n| new |\n\n## B\n\nb\n"
    assert section_of(updated, feedback.SECTION) == body + [""]
    assert with_section("# Benchmarks\n", body).endswith("# Benchmarks\n\n## Feedback times\n\n| new |\n")
    assert section_of("# Benchmarks\n", feedback.SECTION) == []
