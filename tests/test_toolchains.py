"""Every committed kit compiles warning-free under the strictest flags an integrator uses, with gcc,
clang and arm-none-eabi-gcc, with and without link-time optimisation (before, clang's -Wconversion
rejected every kit: CasADi's code used reals as truth values)."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest
from locations import GENERATED

from vsegen.codegen.generate import ARM_FLAGS, EXAMPLE

STRICT = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Wconversion", "-Wdouble-promotion", "-Werror", "-O2")
KITS = sorted(folder for folder in GENERATED.glob("*/*") if folder.is_dir())
COMPILERS = [cc for cc in ("gcc", "clang", "arm-none-eabi-gcc") if shutil.which(cc)]


def real_of(kit) -> str:
    kernel = next(kit.glob("*_kernel.h")).read_text()
    return "float" if "#define casadi_real float" in kernel else "double"


@pytest.mark.slow
@pytest.mark.parametrize("lto", [(), ("-flto",)], ids=["no-lto", "lto"])
@pytest.mark.parametrize("cc", COMPILERS)
def test_every_kit_compiles_warning_free_under_strict_flags(cc, lto, tmp_path):
    failures = []
    for kit in KITS:
        target = ARM_FLAGS[real_of(kit)].split() if cc.startswith("arm") else []
        for source in sorted(kit.glob("*.c")):
            if source.name == EXAMPLE:
                continue
            result = subprocess.run([cc, *STRICT, *lto, *target, "-c", str(source), "-o", str(tmp_path / "x.o")],
                                    capture_output=True, text=True)
            if result.returncode != 0:
                failures.append(f"{source.relative_to(GENERATED)}: {result.stderr.strip().splitlines()[0]}")
    assert failures == []


def test_reals_are_never_used_as_truth_values():
    """The kernels compare a real with 0 where C would convert it to _Bool (-Wfloat-conversion)."""
    implicit = re.compile(r"\((a\d+)\?|\(!(a\d+)\)|=\((a\d+)(&&|\|\|)")
    offending = [str(kit.relative_to(GENERATED)) for kit in KITS for kernel in kit.glob("*_kernel.c")
                 if implicit.search(kernel.read_text())]
    assert offending == []
