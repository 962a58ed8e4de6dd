"""Cross-building generated C for embedded targets: warnings, sizes, stack, memory discipline.

Each target compiles the generated files with ``-std=c99 -Wall -Wextra -pedantic -Werror -Wvla``
(``-Wdouble-promotion`` for float), ``-ffunction-sections -fdata-sections``, ``-fstack-usage`` and
``-fcallgraph-info=su``; links them partially with ``--gc-sections`` keeping only the public API
(what an application links), and reports:

* .text / .data / .bss of that linked object (``arm-none-eabi-size``);
* worst-case stack of ``init`` and ``step``: the largest sum of frame sizes along any call path in
  gcc's call graph (library leaf functions such as ``atan2f`` are listed, their own frames are not
  known and not counted);
* the undefined symbols, which must all be on the target's allow-list (libm functions of the
  target's precision): no heap, no stdio, no exit, no double helpers (``__aeabi_d*``) for float;
* recursion: any cycle in the call graph is an error.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from vsegen.codegen.generate import library_sources

COMMON_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-Wvla", "-O2",
                "-ffunction-sections", "-fdata-sections", "-fstack-usage", "-fcallgraph-info=su")
LIBM = ("acos", "asin", "atan", "atan2", "ceil", "copysign", "cos", "cosh", "erf", "exp", "fabs",
        "floor", "fmax", "fmin", "fmod", "log", "pow", "sin", "sinh", "sqrt", "tan", "tanh")
ALLOWED = {"double": frozenset(LIBM), "float": frozenset(f + "f" for f in LIBM)}
"""Undefined symbols generated code may reference, per precision."""


@dataclass(frozen=True)
class Target:
    name: str
    compiler: str
    flags: tuple[str, ...]
    real: str
    """The precision this target is built with (its FPU's)."""
    tools_prefix: str = "arm-none-eabi-"


TARGETS = (
    Target("cortex-m4f", "arm-none-eabi-gcc",
           ("-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"), "float"),
    Target("cortex-m7", "arm-none-eabi-gcc",
           ("-mcpu=cortex-m7", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv5-d16"), "double"),
)


class TargetError(RuntimeError):
    """A target build failed or broke a memory-discipline rule."""


@dataclass(frozen=True)
class TargetReport:
    target: str
    real: str
    text: int
    data: int
    bss: int
    stack_init: int
    stack_step: int
    library_calls: tuple[str, ...]
    undefined: tuple[str, ...]


def target_for(real: str) -> Target:
    """The target whose FPU builds ``real`` code ("float": the Cortex-M4F, "double": the M7)."""
    return next(target for target in TARGETS if target.real == real)


def available(target: Target) -> bool:
    return shutil.which(target.compiler) is not None


def build_for_target(files: dict[str, str], estimator: str, target: Target) -> TargetReport:
    """Cross-build a generated folder's ``files`` for ``target``; TargetError on any violation."""
    flags = (*COMMON_FLAGS, *target.flags, *(("-Wdouble-promotion",) if target.real == "float" else ()))
    api = (f"vse_{estimator}_init", f"vse_{estimator}_step")
    with tempfile.TemporaryDirectory(prefix="vsegen-target-") as tmp:
        folder = Path(tmp)
        for name, text in files.items():
            (folder / name).write_text(text)
        sources = library_sources(files)
        _run([target.compiler, *flags, "-c", *sources], folder, f"{target.name} compile")
        size = link_to_api(folder, [s[:-2] + ".o" for s in sources], api, target.compiler,
                           target.flags, target.tools_prefix)
        undefined = tuple(sorted(line.split()[-1] for line in _run(
            [target.tools_prefix + "nm", "-u", "linked.o"], folder, "nm").splitlines() if line.strip()))
        graph, frames = _call_graph([(folder / (s[:-2] + ".ci")).read_text() for s in sources])
    not_allowed = [s for s in undefined if s not in ALLOWED[target.real]]
    if not_allowed:
        raise TargetError(f"{estimator} on {target.name}: undefined symbols outside the allow-list: "
                          f"{', '.join(not_allowed)}")
    stacks = [_worst_stack(graph, frames, root, ()) for root in api]
    library = sorted({callee for callees in graph.values() for callee in callees if callee not in frames})
    return TargetReport(target.name, target.real, *size,
                        stacks[0], stacks[1], tuple(library), undefined)


def link_to_api(folder: Path, objects: list[str], api: tuple[str, ...], compiler: str,
                flags: tuple[str, ...] = (), tools_prefix: str = "") -> tuple[int, int, int]:
    """Link ``objects`` partially into ``linked.o`` keeping only what ``api`` needs
    (``--gc-sections``, objects compiled with -ffunction-sections -fdata-sections); returns its
    (.text, .data, .bss) in bytes: what an application links."""
    keep = [f"-Wl,-u,{symbol}" for symbol in api]
    _run([compiler, *flags, "-no-pie", "-nostdlib",
          "-Wl,-r", "-Wl,--gc-sections", *keep, "-o", "linked.o", *objects], folder, "link")
    size = _run([tools_prefix + "size", "linked.o"], folder, "size").splitlines()[1].split()
    return int(size[0]), int(size[1]), int(size[2])


def _run(command: list[str], cwd: Path, what: str) -> str:
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
    if result.returncode != 0 or result.stderr.strip():
        raise TargetError(f"{what} failed or warned: {' '.join(command[:1])}\n{result.stderr}")
    return result.stdout


_NODE = re.compile(r'node: \{ title: "([^"]+)" label: "[^"]*\\n(\d+) bytes \((static|dynamic[^)]*)\)"')
_EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')


def _call_graph(ci_texts: list[str]) -> tuple[dict[str, set[str]], dict[str, int]]:
    """Edges and frame sizes from gcc's -fcallgraph-info=su files; dynamic frames are errors."""
    graph: dict[str, set[str]] = {}
    frames: dict[str, int] = {}
    for text in ci_texts:
        for name, size, kind in _NODE.findall(text):
            if kind != "static":
                raise TargetError(f"{name} has a {kind} stack frame (a VLA or alloca)")
            frames[name] = int(size)
        for source, target in _EDGE.findall(text):
            graph.setdefault(source, set()).add(target)
    return graph, frames


def _worst_stack(graph: dict[str, set[str]], frames: dict[str, int], node: str,
                 path: tuple[str, ...]) -> int:
    if node in path:
        raise TargetError(f"recursion: {' -> '.join((*path, node))}")
    below = [_worst_stack(graph, frames, callee, (*path, node)) for callee in graph.get(node, ())]
    return frames.get(node, 0) + max(below, default=0)
