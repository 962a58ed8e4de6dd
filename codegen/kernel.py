"""The numeric kernel: CasADi's CodeGenerator on the estimator's SX Functions, pinned options.

Options (see DEVELOPERS guide, "Facts about CasADi code generation"): ``casadi_int = int``,
``with_header``, ``static_aux`` and an explicit ``prefix``; never ``with_mem`` (malloc),
``thread_safe`` (pthread) or ``inline_aux``. The raw output leaves parameters unused (``iw``, ``w``,
``mem``); :func:`_mark_unused` adds ``(void)`` casts so the kernel builds with -Wextra -Werror,
:func:`_include_own_header` makes the source include its header (MISRA Rule 8.4), and
:func:`_drop_pointer_checks` removes the per-access null tests (the API always passes valid
pointers), :func:`_compare_min_max` makes fmax/fmin comparisons, :func:`_read_state_first` lets a
kernel update the caller's state in place, :func:`_drop_metadata` keeps
of CasADi's exports only each Function's entry point, and :func:`_document_entries` writes above
each the names of its arguments' entries.
Every rewrite must match the text CasADi emits; if a CasADi upgrade changes it, generation fails
loudly instead of emitting unreviewed code.
"""

from __future__ import annotations

import re
import tempfile
import textwrap
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from vsegen.codegen.precision import to_single
from vsegen.model.estimator import Estimator


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
    functions = (estimator.init, *estimator.structure.kernel_functions)
    c_text, h_text = _drop_metadata(c_text, h_text, [function.name() for function in functions])
    c_text = _document_entries(c_text, functions, _argument_names(estimator))
    c_text = _include_own_header(_drop_pointer_checks(_mark_unused(c_text)), f"{base}.h")
    c_text = _essentially_real(_explicit_truth(_compare_min_max(c_text)))
    for entry in estimator.structure.in_place:
        c_text = _read_state_first(c_text, entry)
    if real == "float":
        c_text = to_single(c_text)
    return Kernel(f"{base}.c", f"{base}.h", c_text, h_text, options)


def _argument_names(estimator: Estimator) -> dict[str, tuple[str, ...]]:
    """Entry names of the kernel arguments and results that have a layout, by argument name."""
    states = estimator.states.names
    return {"state": states, "state_next": states, "state_mid": states,
            "input": estimator.inputs.names, "output": estimator.outputs.names,
            "params": tuple(estimator.parameters.names),
            **estimator.structure.argument_names(estimator.states)}


def _document_entries(c_text: str, functions, names: dict[str, tuple[str, ...]]) -> str:
    """A comment above each entry point: its operation count and, for every argument and result,
    its size and the names of its entries (``arg[i][j]`` is entry j of argument i)."""
    for function in functions:
        lines = [f"{function.name()}: {function.n_instructions()} operations (CasADi SX instructions)"]
        for kind, count, name_of, size_of in (("arg", function.n_in(), function.name_in, function.numel_in),
                                              ("res", function.n_out(), function.name_out,
                                               function.numel_out)):
            for i in range(count):
                label, size = name_of(i), size_of(i)
                entries = names.get(label, ())
                if label in _METHOD_STATES:     # the state before the input checks' entries
                    entries = entries[:size]
                described = ", ".join(entries) if len(entries) == size else f"{size} entries"
                lines += textwrap.wrap(f"{kind}[{i}] {label}[{size}]: {described}", 96,
                                       subsequent_indent="    ")
        anchor = f"CASADI_SYMBOL_EXPORT int {function.name()}("
        if c_text.count(anchor) != 1:
            raise RuntimeError(f"{function.name()}: entry point not found once; review codegen/kernel.py")
        comment = "/*\n" + "".join(f" * {line}\n" for line in lines) + " */\n"
        c_text = c_text.replace(anchor, comment + anchor)
    return c_text


_METHOD_STATES = ("state_next", "state_mid")
"""Results a method's kernel writes from the state's first entry on: all of it, or the entries before
the input checks' (``model.estimator.CheckSegment``)."""


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
METADATA = ("checkout", "release", "incref", "decref", "n_in", "n_out", "default_in", "name_in",
            "name_out", "sparsity_in", "sparsity_out", "work", "work_bytes")
"""The functions CasADi exports beside each Function for its own runtime (memory objects,
introspection, work sizes); the API template calls none of them."""
_LIBRARY_INFO = ("_casadi_version", "_casadi_int_size", "_casadi_real_size")
_EXPORT = re.compile(r"^CASADI_SYMBOL_EXPORT [^\n]*?\b(\w+)\([^\n]*\{(?:[^\n]*\}\n|\n(?:.*\n)*?\}\n)\n?",
                     flags=re.M)
_SPARSITY = re.compile(r"^static const casadi_int (casadi_s\d+)\[\d+\] = \{[^}]*\};\n", flags=re.M)


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


_MIN_MAX = {name: (f"static casadi_real casadi_{name}(casadi_real x, casadi_real y) {{\n"
                   "/* Pre-c99 compatibility */\n"
                   "#if __STDC_VERSION__ < 199901L\n"
                   f"  return x{op}y ? x : y;\n"
                   "#else\n"
                   f"  return {name}(x, y);\n"
                   "#endif\n"
                   "}\n",
                   f"static casadi_real casadi_{name}(casadi_real x, casadi_real y) {{\n"
                   f"  return ((x {op} y) || (isnan(y) != 0)) ? x : y;\n"
                   "}\n")
            for name, op in (("fmax", ">"), ("fmin", "<"))}


def _compare_min_max(c_text: str) -> str:
    """CasADi's fmax and fmin as comparisons with C99's NaN rule (a NaN argument yields the
    other), not the library calls: gcc inlines comparisons, while fmax/fmin stay calls of 10-15
    instructions each on x86-64 and pull fmaxf/fminf into a Cortex-M4F image."""
    for name, (raw, compared) in _MIN_MAX.items():
        if f"casadi_{name}(" in c_text:
            if raw not in c_text:
                raise RuntimeError(f"CasADi's casadi_{name} changed; review codegen/kernel.py")
            c_text = c_text.replace(raw, compared)
    return c_text


_CONDITION = re.compile(r"\((a\d+)\?")
_NOT = re.compile(r"\(!(a\d+)\)")
_LOGIC = re.compile(r"=\((a\d+)(&&|\|\|)(a\d+)\);")


def _explicit_truth(c_text: str) -> str:
    """A real used as a truth value, compared with 0 as C does implicitly: ``(a?b:0)`` becomes
    ``((a!=0.)?b:0)``, ``(!a)`` ``(a==0.)`` and ``(a&&b)`` ``((a!=0.)&&(b!=0.))``. The same code (NaN
    is true either way), but no implicit real-to-_Bool conversion, which clang's -Wconversion
    rejects (-Wfloat-conversion); the real literal keeps both operands essentially real (MISRA
    C:2012 10.4) and becomes ``0.f`` in float code."""
    c_text = _CONDITION.sub(r"((\1!=0.)?", c_text)
    c_text = _NOT.sub(r"(\1==0.)", c_text)
    return _LOGIC.sub(r"=((\1!=0.)\2(\3!=0.));", c_text)


_ZERO_ELSE = re.compile(r"\?(a\d+):0\)")
_TRUTH_ASSIGNED = re.compile(r"^(\s*a\d+)=(\((?:a\d+(?:<=|>=|==|!=|<|>)(?:a\d+|[\d.eE+-]+)"
                             r"|\(a\d+!=0\.\)(?:&&|\|\|)\(a\d+!=0\.\))\));$", re.MULTILINE)


def _essentially_real(c_text: str) -> str:
    """Every value assigned to a ``casadi_real`` made essentially real (MISRA C:2012 rule 10.3,
    required): a comparison's or a logical operation's 0/1 by an explicit cast,
    ``a=(casadi_real)(b<c);``, and the else-branch constant of a condition as a real literal,
    ``(c?b:0.)``. The conversions C made implicitly, now written: the same machine code (tested)."""
    return _TRUTH_ASSIGNED.sub(r"\1=(casadi_real)\2;", _ZERO_ELSE.sub(r"?\1:0.)", c_text))


_STATE_READ = re.compile(r"arg\[0\]\[(\d+)\]")


def function_span(c_text: str, entry: str) -> tuple[int, int]:
    """(start, end) in ``c_text`` of the static function that CasADi's entry point ``entry``
    calls: its body, from its signature to before its closing brace."""
    call = re.search(rf"int {entry}\(const casadi_real\*\* arg[^{{]*\{{\n  return (casadi_f\d+)\(", c_text)
    if call is None:
        raise RuntimeError(f"CasADi's entry point {entry} changed; review codegen/kernel.py")
    start = c_text.index(f"static int {call.group(1)}(")
    return start, c_text.index("\n}\n", start)


def _read_state_first(c_text: str, entry: str) -> str:
    """The step kernel ``entry`` with every read of its argument 0 (the state) that comes after
    its first write of result 0 moved into a local set just before that write, so result 0 may be
    the same array: the API steps the caller's state in place, without a copy. (CasADi's SX code
    reads an input entry where it first needs it, often after it has written results; reads
    before the first write stay where they are, so no value lives longer than it must.)"""
    start, end = function_span(c_text, entry)
    body = c_text[start:end]
    first_write = body.find("  res[0][")
    if first_write < 0:
        raise RuntimeError(f"{entry} no longer writes its state as expected; review codegen/kernel.py")
    before, after = body[:first_write], body[first_write:]
    late = sorted({int(k) for k in _STATE_READ.findall(after)})
    after = _STATE_READ.sub(r"state_\1", after)
    locals_ = "".join(f"  const casadi_real state_{k} = arg[0][{k}];\n" for k in late)
    return c_text[:start] + before + locals_ + after + c_text[end:]


def _include_own_header(c_text: str, header: str) -> str:
    """Include the kernel's header in its source, so every external definition has a visible
    declaration (MISRA C:2012 Rule 8.4)."""
    anchor = "#include <math.h>\n"
    if c_text.count(anchor) != 1:
        raise RuntimeError("CasADi's generated code no longer includes <math.h> once; review "
                           "codegen/kernel.py")
    return c_text.replace(anchor, f'{anchor}\n#include "{header}"\n')


def _drop_metadata(c_text: str, h_text: str, entries: list[str]) -> tuple[str, str]:
    """Keep of CasADi's exports only the entry point of each Function (``entries``): the
    METADATA functions, the library information and the sparsity patterns only they read are
    dead code in a production image and most of the kernel's MISRA findings. Fails loudly unless
    exactly the expected functions were found."""
    expected = {f"{entry}_{suffix}" for entry in entries for suffix in METADATA}
    expected |= {f"{entries[0].rsplit('_kernel_', 1)[0]}_kernel_{info}" for info in _LIBRARY_INFO}
    found = {match.group(1) for match in _EXPORT.finditer(c_text)}
    if found != expected | set(entries):
        raise RuntimeError(f"CasADi's exports changed (unexpected: {sorted(found - expected - set(entries))}, "
                           f"missing: {sorted(expected | set(entries) - found)}); review codegen/kernel.py")
    c_text = _EXPORT.sub(lambda m: "" if m.group(1) in expected else m.group(0), c_text)
    for match in _SPARSITY.finditer(c_text):
        name = match.group(1)
        if len(re.findall(rf"\b{name}\b", c_text)) != 2:      # its #define and its definition
            raise RuntimeError(f"{name} is still read after the metadata was dropped; review "
                               "codegen/kernel.py")
        c_text = c_text.replace(match.group(0), "").replace(f"#define {name} CASADI_PREFIX(s{name[8:]})\n", "")
    declared = re.compile(r"^[^\n#]*\b(\w+)\([^\n]*\);\n|^#define (\w+)_SZ_\w+ \d+\n", flags=re.M)
    h_text = declared.sub(lambda m: "" if (m.group(1) or "") in expected or m.group(2) else m.group(0),
                          h_text)
    return c_text, h_text


def _mark_unused(c_text: str) -> str:
    c_text, bodies = _STATIC_BODY.subn(r"\1  (void)iw; (void)w; (void)mem;\n", c_text)
    if bodies == 0:
        raise RuntimeError(
            "CasADi's generated code no longer has the expected function signatures; "
            f"review codegen/kernel.py for CasADi {ca.__version__}"
        )
    return c_text
