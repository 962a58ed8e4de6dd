"""The generated integration kit outside Python: Makefile flags, the CMake cross-build with the
kit's toolchain file, and the guard against double-precision code on a single-precision FPU."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from vsegen.codegen.generate import render
from vsegen.harness.project.files import write_folder as write

ARM = shutil.which("arm-none-eabi-gcc")


def _kit(config, tmp_path: Path, real: str = "double") -> Path:
    folder = tmp_path / f"kf2dof-{real}"
    write(render(config, "kf2dof", real), folder)
    return folder


def test_command_line_cflags_keep_the_kit_flags(config, tmp_path):
    """make CFLAGS=... (how a cross-build is usually asked for) still compiles as C99 with the
    warnings on: the Makefile appends them with override."""
    folder = _kit(config, tmp_path)
    result = subprocess.run(["make", "-n", "CFLAGS=-O1", "libvse_kf2dof.a"], cwd=folder,
                            capture_output=True, text=True, check=True)
    compiles = [line for line in result.stdout.splitlines() if " -c " in line]
    assert compiles and all("-O1" in line and "-std=c99 -Wall -Wextra -pedantic" in line
                            for line in compiles)


@pytest.mark.skipif(ARM is None or shutil.which("cmake") is None, reason="needs cmake and arm-none-eabi-gcc")
@pytest.mark.parametrize("user_flags", [[], ["-DCMAKE_C_FLAGS=-g"]])
def test_cmake_cross_build_with_the_kit_toolchain(config, tmp_path, user_flags):
    """The kit's toolchain file configures a Cortex-M build that makes the static library without
    startup code or syscalls (the stdio example is off when cross-compiling), at -O2 unless a build
    type says otherwise; the core flags stay when the user gives CMAKE_C_FLAGS (before, they were
    dropped and an ARMv4T library built at -O0)."""
    folder = _kit(config, tmp_path, "float")
    build = tmp_path / "build"
    subprocess.run(["cmake", "-S", str(folder), "-B", str(build), "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON",
                    "-DCMAKE_TOOLCHAIN_FILE=toolchain-arm-none-eabi.cmake", *user_flags],
                   check=True, capture_output=True, text=True)
    subprocess.run(["cmake", "--build", str(build)], check=True, capture_output=True, text=True)
    assert (build / "libvse_kf2dof.a").is_file() and not (build / "vse_kf2dof_example").exists()
    commands = json.loads((build / "compile_commands.json").read_text())
    assert commands and all("-mcpu=cortex-m4" in c["command"] and "-mfpu=fpv4-sp-d16" in c["command"]
                            and " -O2" in c["command"] for c in commands)
    attributes = subprocess.run(["arm-none-eabi-readelf", "-A", str(build / "libvse_kf2dof.a")],
                                capture_output=True, text=True, check=True).stdout
    assert "Tag_CPU_arch: v7E-M" in attributes and "Tag_FP_arch: VFPv4-D16" in attributes


@pytest.mark.skipif(ARM is None, reason="needs arm-none-eabi-gcc")
def test_double_code_for_a_single_precision_fpu_is_refused_with_a_way_out(config, tmp_path):
    """Double code built for a Cortex-M4F (no double-precision FPU) stops with one #error naming
    --real float and VSE_ALLOW_SOFT_DOUBLE; float code, a double-precision FPU (Cortex-M7) and the
    explicit opt-in build."""
    m4f = ["-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"]
    m7 = ["-mcpu=cortex-m7", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv5-d16"]

    def compile_api(real: str, flags: list[str]) -> subprocess.CompletedProcess:
        folder = _kit(config, tmp_path, real)
        return subprocess.run([ARM, *flags, "-std=c99", "-c", "vse_kf2dof.c", "-o", "/dev/null"],
                              cwd=folder, capture_output=True, text=True)

    refused = compile_api("double", m4f)
    assert refused.returncode != 0
    assert "generate with --real float or define VSE_ALLOW_SOFT_DOUBLE" in refused.stderr
    assert compile_api("float", m4f).returncode == 0
    assert compile_api("double", m7).returncode == 0
    assert compile_api("double", [*m4f, "-DVSE_ALLOW_SOFT_DOUBLE"]).returncode == 0
