"""The numeric kernel: CasADi's CodeGenerator on the estimator's SX Functions, pinned options.

Options (see DEVELOPERS guide, "Facts about CasADi code generation"): ``casadi_int = int``,
``with_header``, ``static_aux`` and an explicit ``prefix``; never ``with_mem`` (malloc),
``thread_safe`` (pthread) or ``inline_aux``. The raw output leaves parameters unused (``iw``, ``w``,
``mem``); :func:`_mark_unused` adds ``(void)`` casts so the kernel builds with -Wextra -Werror,
:func:`_include_own_header` makes the source include its header (MISRA Rule 8.4), and
:func:`_drop_pointer_checks` removes the per-access null tests (the API always passes valid
pointers).
Every rewrite must match the text CasADi emits; if a CasADi upgrade changes it, generation fails
loudly instead of emitting unreviewed code.
"""

from __future__ import annotations

import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from codegen.precision import to_single
from model.estimator import Estimator


@dataclass(frozen=True)
class Kernel:
    """Generated kernel sources and the facts the API template needs."""

    c_name: str
    h_name: str
    c_text: str
    h_text: str
    options: dict


def kernel_options(real: str, prefix: str) -> dict:
    """The pinned CodeGenerator options."""
    return {
        "casadi_real": real,
        "casadi_int": "int",
        "with_header": True,
        "static_aux": True,
        "prefix": prefix,
    }


def generate_kernel(estimator: Estimator, real: str = "double") -> Kernel:
    """C source and header of ``estimator``'s init and step Functions."""
    base = f"vse_{estimator.name}_kernel"
    options = kernel_options(real, f"{base}_")
    generator = ca.CodeGenerator(f"{base}.c", options)
    for function in (estimator.init, *estimator.structure.kernel_functions):
        generator.add(function)
    with tempfile.TemporaryDirectory(prefix="vsegen-kernel-") as tmp:
        generator.generate(tmp + "/")
        c_text = (Path(tmp) / f"{base}.c").read_text()
        h_text = (Path(tmp) / f"{base}.h").read_text()
    if _work_size(h_text) != 0:
        raise RuntimeError(f"{estimator.name}: the kernel needs a work vector; the API template "
                           "supports straight-line SX kernels only")
    c_text = _include_own_header(_drop_pointer_checks(_mark_unused(c_text)), f"{base}.h")
    if real == "float":
        c_text = to_single(c_text)
    return Kernel(f"{base}.c", f"{base}.h", c_text, h_text, options)


def _work_size(h_text: str) -> int:
    """The largest ``<function>_SZ_W`` the generated header declares (reals of work vector)."""
    sizes = [int(n) for n in re.findall(r"^#define \w+_SZ_W (\d+)$", h_text, flags=re.M)]
    if not sizes:
        raise RuntimeError("CasADi's generated header declares no _SZ_W; review codegen/kernel.py")
    return max(sizes)


_STATIC_BODY = re.compile(
    r"(static int casadi_f\d+\(const casadi_real\*\* arg, casadi_real\*\* res, "
    r"casadi_int\* iw, casadi_real\* w, int mem\) \{\n)"
)
_RELEASE = re.compile(r"(CASADI_SYMBOL_EXPORT void \w+_release\(int mem\) \{\n)")


_ARG_CHECK = re.compile(r"arg\[(\d+)\]\? arg\[\1\]\[(\d+)\] : 0")
_RES_CHECK = re.compile(r"if \(res\[(\d+)\]!=0\) res\[\1\]\[")


def _drop_pointer_checks(c_text: str) -> str:
    """Read arguments and write results without testing each pointer for null: the API template
    always passes valid pointers (a documented contract of the kernel), so the tests are dead
    weight on the hot path (and MISRA findings)."""
    c_text, reads = _ARG_CHECK.subn(r"arg[\1][\2]", c_text)
    c_text, writes = _RES_CHECK.subn(r"res[\1][", c_text)
    if reads == 0 or writes == 0:
        raise RuntimeError("CasADi's generated code no longer checks argument pointers the "
                           "expected way; review codegen/kernel.py")
    return c_text


def _include_own_header(c_text: str, header: str) -> str:
    """Include the kernel's header in its source, so every external definition has a visible
    declaration (MISRA C:2012 Rule 8.4)."""
    anchor = "#include <math.h>\n"
    if c_text.count(anchor) != 1:
        raise RuntimeError("CasADi's generated code no longer includes <math.h> once; review "
                           "codegen/kernel.py")
    return c_text.replace(anchor, f'{anchor}\n#include "{header}"\n')


def _mark_unused(c_text: str) -> str:
    c_text, bodies = _STATIC_BODY.subn(r"\1  (void)iw; (void)w; (void)mem;\n", c_text)
    c_text, releases = _RELEASE.subn(r"\1  (void)mem;\n", c_text)
    if bodies == 0 or releases == 0:
        raise RuntimeError(
            "CasADi's generated code no longer has the expected function signatures; "
            f"review codegen/kernel.py for CasADi {ca.__version__}"
        )
    return c_text
