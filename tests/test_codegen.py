"""Generated C: byte-identical, traceable, warning-free on gcc and clang, no heap, fresh."""

from __future__ import annotations

import ctypes
import itertools
import math
import os
import re
import shutil
import subprocess
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from locations import GENERATED, REPO

from vsegen.codegen.generate import render
from vsegen.codegen.kernel import function_span, kernel_options
from vsegen.harness.host.build import WARNING_FLAGS
from vsegen.harness.project.files import folder_diffs as check
from vsegen.harness.project.files import write_folder as write
from vsegen.harness.target.toolchains import ALLOWED, TARGETS, TargetError, available, build_for_target
from vsegen.model.estimators import DEFINITIONS, build

COMPILERS = ["gcc", "clang"]
STRICT_TEMPLATE_FLAGS = ("-Wconversion", "-Wshadow", "-Wcast-qual", "-Wstrict-prototypes",
                         "-Wmissing-prototypes", "-Wdouble-promotion", "-Wvla")
"""Extra warnings our own template code (the API file) must pass."""


@pytest.fixture(scope="module")
def files(config):
    return render(config, "kf2dof")


@pytest.fixture(scope="module", params=["double", "float"])
def files_real(config, request):
    return request.param, render(config, "kf2dof", request.param)


def test_regeneration_is_byte_identical(config, files):
    assert render(config, "kf2dof") == files


def test_checked_in_folder_is_fresh(config, files):
    assert check(files, GENERATED / "c_class" / "kf2dof", "generated") == []


def test_every_file_is_traceable_and_marked(config, files):
    assert set(files) == {"vse_kf2dof.h", "vse_kf2dof.c", "vse_kf2dof_kernel.c", "vse_kf2dof_kernel.h",
                          "CMakeLists.txt", "Makefile", "toolchain-arm-none-eabi.cmake", "README.md",
                          "example_main.c"}
    for _name, text in files.items():
        head = text[:1500]
        assert "DO NOT EDIT" in head
        assert config.parameter_hash("kf2dof") in head
        assert "Vehicle c_class" in head and "Options: real=double, params=baked" in head
        assert f"CasADi {ca.__version__}" in head
        assert re.search(r"Operations: step \d+, (input checks \d+ a run \(every check_period\), )?init \d+", head)
        assert "template " in head or "CasADi CodeGenerator" in head
        assert str(Path.home()) not in text and "/tmp" not in text and "/work" not in text
        assert not re.search(r"20\d\d-\d\d-\d\d", text), "no dates in generated files"


def test_parameter_change_changes_code(config, files):
    other = render(config.with_sample_time(0.001), "kf2dof")
    assert other["vse_kf2dof_kernel.c"] != files["vse_kf2dof_kernel.c"]


def _require(tool: str) -> str:
    path = shutil.which(tool)
    if path is None:
        if os.environ.get("CI"):
            pytest.fail(f"{tool} is required in CI (install it with .ci/install)")
        pytest.skip(f"{tool} not installed")
    return path


@pytest.mark.parametrize("cc", COMPILERS)
@pytest.mark.parametrize("opt", ["-O0", "-O2"])
def test_compiles_warning_free_without_heap(tmp_path, files_real, cc, opt):
    real, files = files_real
    compiler = _require(cc)
    write(files, tmp_path)
    extra = ("-Wdouble-promotion",) if real == "float" else ()
    for source in ("vse_kf2dof.c", "vse_kf2dof_kernel.c"):
        obj = tmp_path / (source + ".o")
        result = subprocess.run([compiler, *WARNING_FLAGS, *extra, opt, "-c", source, "-o", str(obj)],
                                cwd=tmp_path, capture_output=True, text=True)
        assert result.returncode == 0 and result.stderr == "", result.stderr
        undefined = subprocess.run(["nm", "-u", str(obj)], capture_output=True, text=True).stdout
        symbols = {line.split()[-1] for line in undefined.splitlines() if line.strip()}
        symbols -= {f"vse_kf2dof_kernel_{kernel}" for kernel in ("init", "checks", "guard", "active", "held")}
        assert symbols <= ALLOWED[real], f"unexpected symbols in {source}: {symbols - ALLOWED[real]}"


@pytest.mark.parametrize("cc", COMPILERS)
@pytest.mark.parametrize("params", ["baked", "calibratable"])
@pytest.mark.parametrize("real", ["double", "float"])
@pytest.mark.parametrize("name", list(DEFINITIONS))
def test_template_code_passes_strict_warnings(tmp_path, config, cc, params, real, name):
    compiler = _require(cc)
    files = render(config, name, real, params)
    write(files, tmp_path)
    for source in [n for n in files if n.endswith(".c")]:  # the kernel: the standard flags
        result = subprocess.run([compiler, *WARNING_FLAGS, "-c", source], cwd=tmp_path,
                                capture_output=True, text=True)
        assert result.returncode == 0 and result.stderr == "", result.stderr
    ours = [n for n in files if n.endswith(".c") and "_kernel" not in n]
    assert (f"vse_{name}_calibration.c" in ours) == (params == "calibratable")
    for source in ours:
        result = subprocess.run([compiler, *WARNING_FLAGS, *STRICT_TEMPLATE_FLAGS, "-c", source],
                                cwd=tmp_path, capture_output=True, text=True)
        assert result.returncode == 0 and result.stderr == "", result.stderr


BUDGETS = {"ukf": (36864, 3328), "aukf": (36864, 3328)}
"""Text and step-stack bytes per estimator where they differ from 16 KiB / 1 KiB: the unscented
filters propagate 13 sigma points through a four-wheel tyre model (the heaviest estimators); their
input monitors (frozen signals, cross-checks, the yaw rate against the wheels) took the double
Cortex-M7 aukf step from 3,040 to 3,160 B, so the stack budget is 3.25 KiB. The text budget is
36 KiB again since the input checks run in a kernel of their own (the float Cortex-M4F aukf:
37,188 B before, 35,624 B with it)."""


@pytest.mark.parametrize("name", list(DEFINITIONS))
@pytest.mark.parametrize("target", TARGETS, ids=[t.name for t in TARGETS])
def test_cross_builds_within_budget(config, target, name):
    if not available(target):
        _require(target.compiler)
    report = build_for_target(render(config, name, target.real), name, target)
    assert set(report.undefined) <= ALLOWED[target.real]
    assert not any(s.startswith("__aeabi_d") for s in report.undefined)
    text, stack = BUDGETS.get(name, (16384, 1024))
    assert 0 < report.text < text and report.data == 0 and report.bss == 0
    assert 0 < report.stack_step < stack and 0 < report.stack_init < 1024
    _assert_documented(name, target, "baked", report)


def _documented_sizes() -> dict[tuple[str, str, str, str], list[str]]:
    """docs/integration.md's size table (`vsegen size` of the default car): by (estimator, target,
    real, params), the cells .text, .data, .bss, stack init, stack step, libm calls."""
    rows = {}
    for line in (REPO / "docs" / "integration.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 10 and cells[1].startswith("cortex-"):
            rows[tuple(cells[:4])] = cells[4:]
    return rows


def _assert_documented(name: str, target, params: str, report) -> None:
    """The size table of docs/integration.md gives this build's figures, if it lists it."""
    row = _documented_sizes().get((name, target.name, target.real, params))
    measured = [str(v) for v in (report.text, report.data, report.bss, report.stack_init, report.stack_step)]
    assert row is None or row == [*measured, ", ".join(report.library_calls)], (
        f"docs/integration.md's size row of {name} {target.name} {params} is stale: measured {measured}")


@pytest.mark.parametrize("name", ["kf2dof", "switching"])
@pytest.mark.parametrize("target", TARGETS, ids=[t.name for t in TARGETS])
def test_the_documented_calibratable_sizes_are_measured(config, target, name):
    if not available(target):
        _require(target.compiler)
    report = build_for_target(render(config, name, target.real, "calibratable"), name, target)
    _assert_documented(name, target, "calibratable", report)


def test_memory_discipline_violations_are_caught(config):
    target = TARGETS[0]
    if not available(target):
        _require(target.compiler)
    files = render(config, "kf2dof", target.real)
    heap = dict(files)
    heap["vse_kf2dof.c"] = heap["vse_kf2dof.c"].replace(
        '#include "vse_kf2dof_kernel.h"\n',
        '#include "vse_kf2dof_kernel.h"\n#include <stdlib.h>\n'
        "void *vse_kept;\n", 1).replace(
        "pack_input(in, u);\n", "pack_input(in, u);\n    vse_kept = malloc(4);\n", 1)
    with pytest.raises(TargetError, match="malloc"):
        build_for_target(heap, "kf2dof", target)
    vla = dict(files)
    vla["vse_kf2dof.c"] += "\nint vse_vla(int n);\nint vse_vla(int n) { float a[n]; a[0] = 1.0f; return (int)a[0]; }\n"
    with pytest.raises(TargetError, match="vla|VLA|variable length"):
        build_for_target(vla, "kf2dof", target)


def test_header_is_self_contained_and_cpp_compatible(tmp_path, files):
    compiler = _require("g++")
    write(files, tmp_path)
    (tmp_path / "use.cpp").write_text('#include "vse_kf2dof.h"\nint main() { vse_kf2dof_state s; '
                                      "(void)s; return VSE_KF2DOF_N_STATE == 8 ? 0 : 1; }\n")
    result = subprocess.run([compiler, "-Wall", "-Wextra", "-Werror", "-c", "use.cpp"], cwd=tmp_path,
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_check_reports_a_stale_file_with_a_diff(tmp_path, files):
    write(files, tmp_path)
    path = tmp_path / "vse_kf2dof.c"
    path.write_text(path.read_text().replace("pack_input(in, u);", "pack_input(in, u); /* edit */"))
    (tmp_path / "stray.c").write_text("int stray;\n")
    diffs = check(files, tmp_path, "out")
    assert len(diffs) == 2
    stray, edited = diffs
    assert "--- out/stray.c" in stray and "+++ /dev/null" in stray
    assert "--- out/vse_kf2dof.c" in edited and "-    pack_input(in, u); /* edit */" in edited
    write(files, tmp_path)
    assert check(files, tmp_path, "out") == []


def test_integration_kit_builds_and_reproduces_the_harness(tmp_path, config, files):
    """make and cmake build the library and example; the example's output on a log equals the
    harness's run of the same C (so a user can check the C without Python)."""
    from vsegen.harness.host.build import load_estimator
    from vsegen.harness.logs.table import write_log
    from vsegen.harness.sim.scenarios import Case
    from vsegen.model.estimators import build

    _require("make")
    write(files, tmp_path)
    result = subprocess.run(["make", "CFLAGS=-O2 -Werror"], cwd=tmp_path, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    log = Case.of("invalid_inputs").simulate(config, 100.0)
    write_log(log, tmp_path / "log.csv")
    with open(tmp_path / "log.csv") as stdin:
        run = subprocess.run(["./vse_kf2dof_example"], cwd=tmp_path, stdin=stdin, capture_output=True,
                             text=True, check=True)
    lines = run.stdout.splitlines()
    assert lines[0] == "t,beta,vy,r,status" and len(lines) == len(log) + 1
    example = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    outputs, _ = load_estimator(build("kf2dof", config), files).run(log.matrix(("delta", "vx", "ay", "r")))
    np.testing.assert_array_equal(example[:, 1:], outputs)
    if shutil.which("cmake"):
        build_dir = tmp_path / "cmake-build"
        subprocess.run(["cmake", "-S", str(tmp_path), "-B", str(build_dir),
                        "-DCMAKE_C_FLAGS=-Wall -Wextra -pedantic -Werror"], check=True, capture_output=True)
        result = subprocess.run(["cmake", "--build", str(build_dir)], capture_output=True, text=True)
        assert result.returncode == 0, result.stdout + result.stderr


def test_declared_forms_follow_the_default_without_repeating_it(config, variant):
    from vsegen.codegen.generate import forms_to_write
    assert forms_to_write(config, "kf2dof") == [
        ("double", "baked", "kf2dof"), ("float", "baked", "kf2dof-float-baked"),
        ("double", "calibratable", "kf2dof-double-calibratable"),
        ("float", "calibratable", "kf2dof-float-calibratable")]
    floating = variant("codegen", real="float")
    assert forms_to_write(floating, "kf2dof")[:2] == [
        ("float", "baked", "kf2dof"), ("double", "calibratable", "kf2dof-double-calibratable")]
    assert forms_to_write(config, "switching") == [("double", "baked", "switching")]


def test_only_the_entry_points_of_casadis_exports_are_kept_and_a_new_export_fails(tmp_path):
    import casadi as ca

    from vsegen.codegen.kernel import _drop_metadata, kernel_options
    x = ca.SX.sym("x", 2)
    generator = ca.CodeGenerator("vse_t_kernel.c", kernel_options("double", "vse_t_kernel_"))
    generator.add(ca.Function("vse_t_kernel_init", [x], [2 * x]))
    generator.generate(str(tmp_path) + "/")
    c_text, h_text = ((tmp_path / f"vse_t_kernel.{ext}").read_text() for ext in ("c", "h"))
    kept_c, kept_h = _drop_metadata(c_text, h_text, ["vse_t_kernel_init"])
    assert "vse_t_kernel_init_sparsity_in" in c_text and "casadi_s0" in c_text
    assert "sparsity" not in kept_c and "casadi_s0" not in kept_c and "_SZ_" not in kept_h
    assert "int vse_t_kernel_init(const casadi_real** arg" in kept_c + kept_h
    extra = c_text.replace("CASADI_SYMBOL_EXPORT int vse_t_kernel_init_checkout(void) {",
                           "CASADI_SYMBOL_EXPORT int vse_t_kernel_init_new(void) {\n  return 0;\n}\n\n"
                           "CASADI_SYMBOL_EXPORT int vse_t_kernel_init_checkout(void) {")
    with pytest.raises(RuntimeError, match="unexpected: \\['vse_t_kernel_init_new'\\]"):
        _drop_metadata(extra, h_text, ["vse_t_kernel_init"])


def test_each_kernel_entry_point_maps_its_arguments_to_names(config):
    estimator = build("kf2dof", config)
    kernel = render(config, "kf2dof")["vse_kf2dof_kernel.c"]
    held = estimator.structure.held
    start = kernel.index(" * vse_kf2dof_kernel_held:")
    comment = kernel[start:kernel.index("CASADI_SYMBOL_EXPORT int vse_kf2dof_kernel_held(")]
    assert f"vse_kf2dof_kernel_held: {held.n_instructions()} operations" in comment
    flat = " ".join(line.strip(" *") for line in comment.splitlines())
    assert f"arg[0] state[{len(estimator.states)}]: {', '.join(estimator.states.names)}" in flat
    decisions = ", ".join(f"plausible_{name}" for name in estimator.inputs.names) + ", low_speed, active"
    assert f"arg[2] decisions[{len(estimator.inputs) + 2}]: {decisions}" in flat
    assert f"res[1] output[{len(estimator.outputs)}]: {', '.join(estimator.outputs.names)}" in flat


@pytest.mark.parametrize("real", ["double", "float"])
def test_min_max_are_inline_comparisons_with_c99s_nan_rule(tmp_path, real):
    """The kernel's fmax/fmin are comparisons (no library call, kf2dof's Euler step 618 -> 571
    instructions) that give what C99's fmax/fmin give, a NaN argument yielding the other, over
    finite, infinite and NaN pairs; and the rewrite fails loudly if CasADi's helper changes."""
    from vsegen.codegen.kernel import _compare_min_max
    x = ca.SX.sym("x", 2)
    generator = ca.CodeGenerator("vse_t_kernel.c", {**kernel_options(real, "vse_t_kernel_")})
    generator.add(ca.Function("vse_t_kernel_f", [x], [ca.vertcat(ca.fmax(x[0], x[1]),
                                                                  ca.fmin(x[0], x[1]))]))
    generator.generate(str(tmp_path) + "/")
    c_text = _compare_min_max((tmp_path / "vse_t_kernel.c").read_text())
    assert "fmax(x, y)" not in c_text and "fmin(x, y)" not in c_text
    (tmp_path / "vse_t_kernel.c").write_text(c_text)
    library = tmp_path / "t.so"
    subprocess.run(["gcc", "-std=c99", "-O2", "-shared", "-fPIC", "-o", str(library),
                    str(tmp_path / "vse_t_kernel.c"), "-lm"], check=True)
    kind = ctypes.c_double if real == "double" else ctypes.c_float
    function = ctypes.CDLL(str(library)).vse_t_kernel_f
    values = [0.0, -0.0, 1.5, -2.0, math.inf, -math.inf, math.nan]
    for a, b in itertools.product(values, repeat=2):
        arg, res = (kind * 2)(a, b), (kind * 2)()
        args, results = (ctypes.POINTER(kind) * 1)(arg), (ctypes.POINTER(kind) * 1)(res)
        function(args, results, None, None, 0)
        expected = (np.fmax(a, b), np.fmin(a, b))
        for got, want in zip(res, expected):
            assert (math.isnan(got) and math.isnan(want)) or got == want, (a, b, got, want)
    with pytest.raises(RuntimeError, match="casadi_fmax changed"):
        _compare_min_max(c_text.replace("casadi_real casadi_fmax(casadi_real x, casadi_real y) {",
                                        "casadi_real casadi_fmax(casadi_real x, casadi_real y) {\n"
                                        "/* changed */"))


@pytest.mark.parametrize("name", [n for n in DEFINITIONS if n in ("kf2dof", "ukf", "aukf", "ekf_rls",
                                                                  "arx_dual_kf", "fusion", "switching")])
def test_an_in_place_kernel_reads_its_state_before_writing_it(config, name):
    """The API passes the caller's state as an in-place kernel's argument 0 and result 0 (no
    copy): in the kernel, no read of argument 0 may follow the first write of result 0."""
    estimator = build(name, config)
    if not estimator.structure.in_place:
        pytest.skip(f"{name} has no in-place kernel")
    files = render(config, name)
    for entry in estimator.structure.in_place:
        body = _kernel_body(files[f"vse_{name}_kernel.c"], entry)
        first_write = body.index("res[0][")
        assert "arg[0][" not in body[first_write:], entry
    assert "arg[0] = state->x;" in files[f"vse_{name}.c"] and "res[0] = state->x;" in files[f"vse_{name}.c"]


def _kernel_body(text: str, entry: str) -> str:
    start, end = function_span(text, entry)
    return text[start:end]


def test_a_guarded_step_runs_no_hold_rule_work_on_an_active_sample(vehicle_text):
    """kf2dof without its monitors: the active kernel has no select (no ``?:``: the holds of
    rejected inputs and the hold rule's choices between held and updated values are gone) and
    does not read the holding flag; the held kernel computes no Kalman update (no division)."""
    from vsegen.harness.project.vehicles import with_settings
    from vsegen.model.params import parse_vehicle
    text = with_settings(vehicle_text, "estimator.kf2dof", residual_window=0.0, linear_range=0.0,
                         frozen_time=0.0)
    config = parse_vehicle(text, "c_class.toml", "c_class")
    estimator = build("kf2dof", config)
    kernel = render(config, "kf2dof")["vse_kf2dof_kernel.c"]
    active = _kernel_body(kernel, estimator.structure.active.name())
    held = _kernel_body(kernel, estimator.structure.held.name())
    holding = estimator.states.index("holding")
    assert "?" not in active and f"arg[0][{holding}]" not in active
    assert "/" in active and "/" not in held and "atan" not in held


@pytest.mark.parametrize("name", ["kf2dof", "switching", "fusion", "ekf_rls"])
@pytest.mark.parametrize("real", ["double", "float"])
def test_the_misra_10_3_rewrite_leaves_the_machine_code_as_it_was(config, monkeypatch, tmp_path, name, real):
    """codegen.kernel._essentially_real writes CasADi's implicit conversions to casadi_real as casts
    and real literals: the object code of the kernel (gcc -O2, .text and .rodata) is byte for byte
    what it was without it."""
    from vsegen.codegen import kernel as kernel_module
    from vsegen.model.estimators import build

    estimator = build(name, config, "baked")
    rewritten = kernel_module.generate_kernel(estimator, real)
    monkeypatch.setattr(kernel_module, "_essentially_real", lambda text: text)
    plain = kernel_module.generate_kernel(estimator, real)
    assert "(casadi_real)(" in rewritten.c_text and rewritten.c_text != plain.c_text
    sections = {}
    for label, kernel in (("rewritten", rewritten), ("plain", plain)):
        folder = tmp_path / label
        folder.mkdir()
        (folder / kernel.c_name).write_text(kernel.c_text)
        (folder / kernel.h_name).write_text(kernel.h_text)
        subprocess.run(["gcc", "-std=c99", "-O2", "-c", kernel.c_name, "-o", "k.o"], cwd=folder, check=True)
        for section in (".text", ".rodata"):
            subprocess.run(["objcopy", "-O", "binary", "-j", section, "k.o", f"k{section}"], cwd=folder, check=True)
        sections[label] = [(folder / f"k{section}").read_bytes() for section in (".text", ".rodata")]
    assert sections["rewritten"] == sections["plain"]
