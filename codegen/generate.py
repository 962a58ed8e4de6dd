"""The C folder of one estimator for one vehicle, as text.

``render(config, name)`` returns {file name: text}; the text depends only on the vehicle
configuration, the templates, and the vsegen and CasADi versions (no time stamps, no paths), so
regeneration is byte-identical. codegen never touches the file system: writing the folder and
comparing it with a checked-in one is the harness's (``harness.project.files``).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import metadata
from pathlib import Path

import casadi as ca
import jinja2
import numpy as np

from vsegen.codegen import a2l
from vsegen.codegen.checks import condition
from vsegen.codegen.kernel import generate_kernel
from vsegen.codegen.precision import literal
from vsegen.model import status, ziggurat
from vsegen.model.calibration_checks import calibration_checks, dynamics_checks
from vsegen.model.estimator import RNG_WORDS
from vsegen.model.estimators import DEFINITIONS, SCHEMAS, build
from vsegen.model.guard import LIMIT_KEYS
from vsegen.model.params import VehicleConfig
from vsegen.model.schema import REALS

TEMPLATES = Path(__file__).parent / "templates"
EXAMPLE = "example_main.c"
"""The host example of a generated folder (stdio; not part of the library)."""


def generator_version() -> str:
    """vsegen's version as installed."""
    return metadata.version("vsegen")


@lru_cache(maxsize=8)
def template_environment(folder: Path = TEMPLATES) -> jinja2.Environment:
    """The one jinja2 set-up of every C template in vsegen (generated code here, the harness's
    runner and fuzz drivers, the benchmark drivers): undefined names fail, block tags leave no
    blank lines, a template's final newline is kept."""
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(folder),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def check_sums(estimator, limits, real: str) -> list[tuple[str, str, str | None]]:
    """(state entry, C value, C plausibility test or None) of each sum the input checks keep
    between two runs (``model.estimator.Sum``): the value its input, or the first minus the
    second; the test of a judged sum, |value| <= the [inputs] limit of its first input (in a
    calibratable build the limit's calibration entry, ``p``, as the kernels' guard reads it)."""
    checks = getattr(estimator.structure, "checks", None)
    if checks is None:
        return []
    ref = {name: f"u[{estimator.inputs.index(name)}]" for name in estimator.inputs.names}
    fabs = "fabsf" if real == "float" else "fabs"
    calibrated = estimator.parameters.names

    def limit(key: str) -> str:
        return f"p[{calibrated.index(key)}]" if key in calibrated else literal(limits[key], real)

    sums = []
    for total in checks.sums:
        terms = total.terms
        value = ref[terms[0]] if len(terms) == 1 else f"({ref[terms[0]]} - {ref[terms[1]]})"
        gate = f"({fabs}({value}) <= {limit(LIMIT_KEYS[terms[0]])})" if total.judged else None
        sums.append((total.entry, value, gate))
    return sums


def ziggurat_literals(real: str) -> dict[str, list[str]]:
    """The ziggurat's tables (``model.ziggurat``) as C literals of type ``real``: a float build's
    entries are the double tables rounded once to float (written as that float's exact value)."""
    tables = ziggurat.tables()
    rounded = (lambda v: float(np.float32(v))) if real == "float" else float
    reals = {name: [literal(rounded(v), real) for v in getattr(tables, name)]
             for name in ("width", "floor", "height")}
    return {"core": [f"{k}UL" for k in tables.core], "edge": literal(rounded(ziggurat.EDGE), real),
            **reals}


def forms_to_write(config: VehicleConfig, name: str) -> list[tuple[str, str, str]]:
    """(real, params, folder name) of every form of ``name`` the vehicle file declares: its
    [codegen] default first, then those of its [codegen] ``forms``."""
    default = (config.codegen["real"], config.codegen["params"])
    others = [(real, params) for estimator, real, params in config.codegen["forms"]
              if estimator == name and (real, params) != default]
    return [(*default, name), *((real, params, form_folder(name, (real, params), default)) for real, params in others)]


def form_folder(name: str, form: tuple[str, str], default: tuple[str, str]) -> str:
    """The folder of ``generated/<vehicle>/`` that holds estimator ``name`` in ``form`` (real,
    params): ``<name>`` for the vehicle file's ``default`` form, else ``<name>-<real>-<params>``."""
    return name if form == default else f"{name}-{form[0]}-{form[1]}"


def render(config: VehicleConfig, name: str, real: str | None = None,
           params: str | None = None) -> dict[str, str]:
    """All files of ``generated/<vehicle>/<name>/`` as {file name: text}; ``real`` ("double" or
    "float") and ``params`` ("baked" or "calibratable") default to the vehicle file's [codegen]."""
    real = real or config.codegen["real"]
    params = params or config.codegen["params"]
    if real not in REALS:
        raise ValueError(f"real type {real!r}: expected one of {REALS}")
    estimator = build(name, config, params)
    kernel = generate_kernel(estimator, real)
    prefix = f"vse_{name}"
    context = {
        "est": estimator,
        "p": prefix,
        "P": prefix.upper(),
        "guard": f"{prefix.upper()}_H",
        "vehicle": config.name,
        "sample_time": repr(config.sample_time),
        "sample_time_literal": literal(config.sample_time, real),
        "zero": literal(0.0, real),
        "one": literal(1.0, real),
        "real": real,
        "params": params,
        "calibration": [(n, literal(v, real)) for n, v in zip(estimator.parameters.names,
                                                              estimator.parameters.values)],
        "version": generator_version(),
        "casadi_version": ca.__version__,
        "parameter_hash": config.parameter_hash(name),
        "ops": estimator.operation_counts,
        "status_bits": {bit.name: (bit.value, bit.meaning) for bit in status.described((
            *DEFINITIONS[name].status_bits,
            *((status.INVALID_CALIBRATION,) if estimator.parameters.calibratable else ())))},
        "calibration_checks": [(condition(c, real), c.says) for c in (
            *calibration_checks(SCHEMAS[name], estimator.parameters.names),
            *dynamics_checks(SCHEMAS[name], estimator.parameters.names, estimator.parameters.values))],
        "invalid_calibration": literal(float(status.INVALID_CALIBRATION), real),
        "status_index": estimator.outputs.index("status"),
        "check_sums": check_sums(estimator, config.limits, real),
        "kernel": kernel,
        "rng_words": RNG_WORDS,
        "ziggurat": ziggurat_literals(real),
        "f": "f" if real == "float" else "",
        "arm_flags": ARM_FLAGS[real],
    }
    if estimator.parameters.calibratable:
        context.update(a2l=a2l.describe(estimator, real, prefix), a2l_datatype=a2l.DATATYPES[real][0],
                       a2l_text=a2l.text)
    env = template_environment()
    files = {}
    templates = TEMPLATE_FILES + (CALIBRATION_FILES if estimator.parameters.calibratable else ())
    context["library_sources"] = sorted(
        [kernel.c_name] + [file.format(p=prefix) for _, file, _ in templates
                           if file.endswith(".c") and file != EXAMPLE])
    for template, file, style in templates:
        file = file.format(p=prefix)
        banner = _comment(env.get_template("banner.j2").render(
            context, file=file, source=f"template {template}"), style)
        files[file] = env.get_template(template).render(context, file=file, banner=banner)
    options = ", ".join(f"{k}={v}" for k, v in sorted(kernel.options.items()))
    for file, text in ((kernel.c_name, kernel.c_text), (kernel.h_name, kernel.h_text)):
        banner = env.get_template("banner.j2").render(
            context, file=file, source=f"CasADi CodeGenerator ({options})")
        files[file] = _comment(banner, "c") + text
    return files


TEMPLATE_FILES = (  # template, file name, comment style
    ("api.h.j2", "{p}.h", "c"),
    ("api.c.j2", "{p}.c", "c"),
    ("example_main.c.j2", EXAMPLE, "c"),
    ("CMakeLists.txt.j2", "CMakeLists.txt", "hash"),
    ("Makefile.j2", "Makefile", "hash"),
    ("toolchain-arm-none-eabi.cmake.j2", "toolchain-arm-none-eabi.cmake", "hash"),
    ("README.md.j2", "README.md", "markdown"),
)
ARM_FLAGS = {"float": "-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16",
             "double": "-mcpu=cortex-m7 -mthumb -mfloat-abi=hard -mfpu=fpv5-d16"}
"""The toolchain file's default core: a Cortex-M4F for float code (single-precision FPU), a
Cortex-M7 with a double-precision FPU for double code."""


CALIBRATION_FILES = (("calibration.c.j2", "{p}_calibration.c", "c"), ("a2l.j2", "{p}.a2l", "c"))
"""Files of a calibratable build only: the calibration struct's instance and its ASAP2 description."""


def library_sources(files: dict[str, str]) -> list[str]:
    """The C sources of the estimator library (every .c but the host example)."""
    return sorted(n for n in files if n.endswith(".c") and n != EXAMPLE)


def _comment(text: str, style: str) -> str:
    """``text`` as a comment block of ``style`` ("c", "hash" or "markdown")."""
    lines = text.rstrip("\n").split("\n")
    if style == "c":
        return "/*\n" + "".join(f" * {line}".rstrip() + "\n" for line in lines) + " */\n"
    if style == "hash":
        return "".join(f"# {line}".rstrip() + "\n" for line in lines)
    return "<!--\n" + "\n".join(lines) + "\n-->\n"
