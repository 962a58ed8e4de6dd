"""The import layers: model -> codegen -> harness -> bench (each may import only the layers before
it), and the NumPy reference imports neither CasADi nor the symbolic model nor the code generator,
so it stays an independent check of both."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from locations import REPO

LAYERS = ("model", "codegen", "harness", "bench")
REFERENCE = Path("harness") / "reference"
NOT_IN_REFERENCE = ("casadi", "model", "codegen")


def layer(module: str) -> str:
    """The layer or top-level package of ``module``: "model" for vsegen.model.params."""
    return module.removeprefix("vsegen.").split(".")[0]


def imported_packages(path: Path) -> set[str]:
    """Layers and top-level packages of every module ``path`` imports (absolute imports)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(layer(alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(layer(node.module))
    return names


def sources(layer: str) -> list[Path]:
    return sorted((REPO / layer).rglob("*.py"))


@pytest.mark.parametrize("layer", LAYERS)
def test_a_layer_imports_only_the_layers_before_it(layer):
    later = set(LAYERS[LAYERS.index(layer) + 1:])
    offences = {str(path.relative_to(REPO)): sorted(imported_packages(path) & later)
                for path in sources(layer)}
    assert {k: v for k, v in offences.items() if v} == {}


def test_the_reference_imports_neither_casadi_nor_the_model():
    offences = {str(path.relative_to(REPO)): sorted(imported_packages(path) & set(NOT_IN_REFERENCE))
                for path in sorted((REPO / REFERENCE).rglob("*.py"))}
    assert {k: v for k, v in offences.items() if v} == {}


def test_the_check_sees_an_offending_import(tmp_path):
    offender = tmp_path / "bad.py"
    offender.write_text("import numpy as np\nfrom casadi import SX\nimport model.params\n"
                        "from . import sibling\nfrom vsegen.codegen import kernel\n")
    assert imported_packages(offender) == {"numpy", "casadi", "model", "codegen"}
