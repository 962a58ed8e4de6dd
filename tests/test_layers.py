"""The import contract. Layers: model -> codegen -> harness -> bench, each importing only the layers
before it. Inside harness, the stages of the flow in order: each stage (a sub-package) imports
only itself and the stages before it. The NumPy reference imports neither CasADi nor the symbolic
model nor the code generator, so it stays an independent check of both. harness/ has no module at
its top level but its ``__init__``."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from locations import REPO

LAYERS = ("model", "codegen", "harness", "bench")
STAGES = ("reference", "project", "jobs", "logs", "physics", "outputs", "sim", "host", "score", "campaign",
          "identify", "tune", "verify", "target", "fmu", "starter", "cli")
"""harness's stages in flow order: the NumPy reference first (it imports nothing of harness), then
the project's files, job pools, logs (readers), their physics checks, the estimates files, the truth
simulation, the host build, scoring, campaigns of
logs, identification, tuning, verification, the target stage, the FMU (software in the loop), a
new project's starter files and reference pages, and the command line on top."""
NEEDS = {
    "reference": (),
    "project": (),
    "jobs": (),
    "logs": ("project",),
    "physics": ("logs",),
    "outputs": ("project", "logs"),
    "sim": ("project", "jobs", "logs"),
    "host": ("reference", "project", "jobs", "logs"),
    "score": ("project", "logs"),
    "campaign": ("project", "logs", "physics", "host", "score"),
    "identify": ("project", "logs", "physics"),
    "tune": ("project", "jobs", "logs", "physics", "host", "score"),
    "verify": ("reference", "project", "jobs", "sim", "host"),
    "target": ("jobs", "sim", "host", "verify"),
    "fmu": ("project", "host"),
    "starter": ("project",),
    "cli": STAGES[1:-1],
}
"""The stages each stage imports, no more: a new import between stages is a decision, made here
(the order alone would let score import the host build, or a stage import the command line's)."""
REFERENCE = Path("harness") / "reference"
NOT_IN_REFERENCE = ("casadi", "model", "codegen")


def imported_modules(path: Path) -> set[str]:
    """Every module ``path`` imports by absolute name, with the ``vsegen.`` prefix removed."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name.removeprefix("vsegen.") for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            module = node.module.removeprefix("vsegen.")
            names.add(module)
            if module in ("harness",):              # from vsegen.harness import cli
                names.update(f"{module}.{alias.name}" for alias in node.names)
    return names


def layer(module: str) -> str:
    """The layer or top-level package of ``module``: "model" for model.params."""
    return module.split(".")[0]


def stage(module: str) -> str | None:
    """The harness stage of ``module`` ("logs" for harness.logs.mdf), None outside harness."""
    parts = module.split(".")
    return parts[1] if parts[0] == "harness" and len(parts) > 1 else None


def sources(folder: str) -> list[Path]:
    return sorted((REPO / folder).rglob("*.py"))


@pytest.mark.parametrize("name", LAYERS)
def test_a_layer_imports_only_the_layers_before_it(name):
    later = set(LAYERS[LAYERS.index(name) + 1:])
    offences = {str(path.relative_to(REPO)): sorted({layer(m) for m in imported_modules(path)} & later)
                for path in sources(name)}
    assert {k: v for k, v in offences.items() if v} == {}


@pytest.mark.parametrize("name", STAGES)
def test_a_stage_imports_only_itself_and_the_stages_before_it(name):
    allowed = set(STAGES[:STAGES.index(name) + 1])
    offences = {str(path.relative_to(REPO)): sorted({stage(m) for m in imported_modules(path)} - allowed - {None})
                for path in sources(f"harness/{name}")}
    assert {k: v for k, v in offences.items() if v} == {}


@pytest.mark.parametrize("name", STAGES)
def test_a_stage_imports_the_stages_it_declares_it_needs(name):
    used = set()
    for path in sources(f"harness/{name}"):
        used |= {stage(m) for m in imported_modules(path)} - {None, name}
    assert set(NEEDS[name]) <= set(STAGES[:STAGES.index(name)])          # declared in flow order
    assert sorted(used - set(NEEDS[name])) == [], f"harness/{name} imports stages it does not declare"
    assert sorted(set(NEEDS[name]) - used) == [], f"harness/{name} declares stages it does not import"


def test_every_harness_module_belongs_to_a_stage():
    top_level = sorted(p.name for p in (REPO / "harness").iterdir() if p.suffix == ".py" and p.name != "__init__.py")
    packages = sorted(p.name for p in (REPO / "harness").iterdir() if (p / "__init__.py").is_file())
    assert top_level == []
    assert packages == sorted(STAGES)


def test_the_reference_imports_neither_casadi_nor_the_model():
    offences = {str(path.relative_to(REPO)): sorted({layer(m) for m in imported_modules(path)}
                                                    & set(NOT_IN_REFERENCE))
                for path in sorted((REPO / REFERENCE).rglob("*.py"))}
    assert {k: v for k, v in offences.items() if v} == {}


def test_the_check_sees_an_offending_import(tmp_path):
    offender = tmp_path / "bad.py"
    offender.write_text("import numpy as np\nfrom casadi import SX\nimport model.params\n"
                        "from . import sibling\nfrom vsegen.codegen import kernel\n"
                        "from vsegen.harness.cli.common import UserError\nfrom vsegen.harness import tune\n")
    modules = imported_modules(offender)
    assert {layer(m) for m in modules} == {"numpy", "casadi", "model", "codegen", "harness"}
    assert {stage(m) for m in modules} - {None} == {"cli", "tune"}
