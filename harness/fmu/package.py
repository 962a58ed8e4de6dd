"""An FMU file: codegen.fmu's text files, the binary for this platform compiled from them, zipped.

The binary is built from the FMU's own ``sources/`` (the kit as generated, and vsegen's FMI
wrapper) with the flags the harness builds every estimator with (``harness.host.build``), plus
``-fvisibility=hidden`` so that only the FMI functions are exported. The archive is reproducible:
its entries are sorted and carry a fixed time stamp.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

from vsegen.codegen.fmu import FMI_HEADERS, PLATFORM_FOLDER, render_fmu
from vsegen.harness.host.build import LIBRARY_FLAGS, WARNING_FLAGS, compile_cached, compiler
from vsegen.harness.project.files import write_atomic
from vsegen.model.params import VehicleConfig

EXPORT_FLAGS = ("-fvisibility=hidden",)
"""Only the FMI functions (FMI3_Export / FMI2_Export: default visibility) leave the library."""
STAMP = (1980, 1, 1, 0, 0, 0)
"""The time stamp of every archive entry (the earliest a zip file can hold)."""


@dataclass(frozen=True)
class Fmu:
    """A written FMU."""

    path: Path
    fmi: int
    binary: str
    """Its binary's path inside the archive."""
    sources: int
    """C files under sources/."""


def build_fmu(config: VehicleConfig, name: str, real: str, params: str, fmi: int, out: Path) -> Fmu:
    """Write the FMU of ``name`` in form (``real``, ``params``) for FMI ``fmi`` to ``out``."""
    files = render_fmu(config, name, real, params, fmi)
    binary = f"binaries/{PLATFORM_FOLDER[fmi]}/vse_{name}.so"
    library = compile_binary(files)
    entries = {**{path: text.encode() for path, text in files.items()}, binary: library.read_bytes()}
    write_atomic(out, lambda tmp: _zip(entries, tmp))
    return Fmu(out, fmi, binary, sum(path.endswith(".c") for path in files))


def compile_binary(files: dict[str, str]) -> Path:
    """The shared library of the FMU ``files`` (cached like every harness build)."""
    sources = {path.removeprefix("sources/"): text for path, text in files.items()
               if path.startswith("sources/") and path.endswith((".c", ".h"))}
    headers = {path.name: path.read_text() for path in sorted(FMI_HEADERS.glob("*.h"))}
    return compile_cached({**sources, **headers}, compiler(), (*WARNING_FLAGS, *LIBRARY_FLAGS, *EXPORT_FLAGS),
                          "fmu", ".so")


def _zip(entries: dict[str, bytes], path: Path) -> None:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name in sorted(entries):
            info = zipfile.ZipInfo(name, STAMP)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, entries[name])
