"""Where each decision of a model lives: the model source line that built it.

While :func:`traced` is active, CasADi's choosing operations (``fmin``, ``fmax``, ``if_else``,
the ``logic_*`` functions and SX's comparison operators) record, for every scalar node they
return, the call site in vsegen's model (``file.py:line function``, and the caller in another
model file when the site is a shared helper). Substitutions (``ca.substitute``), calls of SX
Functions on expressions and common-subexpression elimination (``ca.cse``) are followed, so that
a node they rebuild (the guard's decisions, a kernel called in the step) keeps its site. The
expressions built are unchanged: the wrappers only look at what CasADi returns; a call is
evaluated once, with the recorded nodes beside its outputs, and an elimination runs on its
expressions alone before the recorded nodes are mapped onto its result.

Used by the model coverage (``model_coverage``) to say where a decision taken one way only lives,
and by its justifications (``coverage.JUSTIFIED``), which name sites rather than expressions.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import casadi as ca

import vsegen.model

MODEL = Path(vsegen.model.__file__).resolve().parent
FUNCTIONS = ("fmin", "fmax", "if_else", "logic_and", "logic_or", "logic_not")
COMPARISONS = ("__lt__", "__le__", "__gt__", "__ge__", "__eq__", "__ne__")
REBUILDING = ("substitute", "cse")
SITES_OUTPUT = "vsegen_decision_sites"


class Sites:
    """The sites recorded so far, by node (``SXElem.element_hash``). The nodes are kept alive, so
    that a hash (a node's address) is never reused by another node while the record lives."""

    def __init__(self) -> None:
        self._site: dict[int, str] = {}
        self._nodes: list[ca.SX] = []

    def of(self, node: ca.SX) -> str | None:
        """The site of the scalar ``node``, if one was recorded."""
        return self._site.get(node.element_hash())

    def record(self, value: object, site: str) -> None:
        """Record ``site`` for every scalar node of ``value`` (an SX; anything else is ignored),
        and for the branch nodes an if_else leaves (``c ? a : 0``, its condition's negation)."""
        if not isinstance(value, ca.SX):
            return
        for k in range(value.nnz()):
            node = value.nz[k]
            self._add(node, site)
            for part in _if_else_parts(node):
                self._add(part, site)

    def _add(self, node: ca.SX, site: str) -> None:
        if node.is_constant() or node.is_symbolic() or node.element_hash() in self._site:
            return
        self._site[node.element_hash()] = site
        self._nodes.append(node)

    def follow(self, nodes: list[ca.SX], images: ca.SX) -> None:
        """Give each of the recorded ``nodes``' image under a substitution or call (``images``, in
        the same order) the node's site."""
        sites = [self._site[n.element_hash()] for n in nodes]
        for k, site in enumerate(sites):
            self._add(images[k], site)

    def nodes(self) -> list[ca.SX]:
        return list(self._nodes)

    def within(self, function: ca.Function) -> list[ca.SX]:
        """The recorded nodes among the instructions of the SX Function ``function``."""
        if not function.is_a("SXFunction"):
            return []
        instructions = function.instructions_sx()
        return [instructions.nz[k] for k in range(instructions.nnz())
                if instructions.nz[k].element_hash() in self._site]


def _column(nodes: list[ca.SX]) -> ca.SX:
    return ca.vertcat(*nodes) if nodes else ca.SX(0, 1)


def _outputs(function: ca.Function) -> list[ca.SX]:
    """The output expressions of the SX Function ``function``, made of its own nodes (rebuilt from
    its instructions; ``sx_out`` would give symbols and a call new nodes)."""
    values, inputs = function.instructions_sx(), function.sx_in()
    outputs = [ca.SX(function.sparsity_out(i)) for i in range(function.n_out())]
    work: dict[int, ca.SX] = {}
    for k in range(function.n_instructions()):
        op = function.instruction_id(k)
        if op == ca.OP_INPUT:
            i, nz = function.instruction_input(k)
            work[function.instruction_output(k)[0]] = inputs[i].nz[nz]
        elif op == ca.OP_OUTPUT:
            i, nz = function.instruction_output(k)
            outputs[i].nz[nz] = work[function.instruction_input(k)[0]]
        else:
            work[function.instruction_output(k)[0]] = values.nz[k]
    return outputs


def _if_else_parts(node: ca.SX) -> list[ca.SX]:
    """The ``c ? a : 0`` terms of an if_else's result (``c ? a : 0 + !c ? b : 0``, or one term
    when a branch is 0), and their negated conditions ``!c``."""
    terms = [node.dep(i) for i in range(2)] if node.op() == ca.OP_ADD else [node]
    parts = [t for t in terms if t.op() == ca.OP_IF_ELSE_ZERO]
    return parts + [p.dep(0) for p in parts if p.dep(0).op() == ca.OP_NOT]


def call_site() -> str | None:
    """The model line that called the operation being recorded (``file.py:line function``), with
    the nearest caller in another model file (``... <- estimators/ukf.py:120 predict``); None when
    the operation was not called from the model."""
    frames = []
    frame = sys._getframe(2)
    while frame is not None and len(frames) < 2:
        path = Path(frame.f_code.co_filename)
        if path.is_relative_to(MODEL):
            where = f"{path.relative_to(MODEL).as_posix()}:{frame.f_lineno} {frame.f_code.co_name}"
            if path.name == "__init__.py" or (frames and frames[0].startswith("estimators/")):
                break
            if not frames or frames[0].split(":")[0] != where.split(":")[0]:
                frames.append(where)
        elif frames:
            break
        frame = frame.f_back
    return " <- ".join(frames) if frames else None


@contextmanager
def traced() -> Iterator[Sites]:
    """Record the sites of the decisions built inside the block (a model build)."""
    sites = Sites()
    originals = {name: getattr(ca, name) for name in (*FUNCTIONS, *REBUILDING)}
    own_methods = {name: ca.SX.__dict__.get(name) for name in COMPARISONS}

    def recording(operation):
        def wrapper(*args, **kwargs):
            value = operation(*args, **kwargs)
            site = call_site()
            if site is not None:
                sites.record(value, site)
            return value
        return wrapper

    def substitute(expressions, symbols, values):
        single = not isinstance(expressions, list)
        listed = [expressions] if single else list(expressions)
        symbols, values = ([symbols], [values]) if single else (symbols, values)
        nodes = sites.nodes()
        *images, followed = originals["substitute"]([*listed, _column(nodes)], symbols, values)
        sites.follow(nodes, followed)
        return images[0] if single else images

    def cse(expressions):
        # eliminated on their own first (eliminated beside the recorded nodes, they would share
        # more); a second pass maps each recorded node onto its equal in the result
        result = originals["cse"](expressions)
        nodes = sites.nodes()
        *_, followed = originals["cse"]([*(result if isinstance(result, list) else [result]), _column(nodes)])
        sites.follow(nodes, followed)
        return result

    def call(function, *args, **kwargs):
        nodes = sites.within(function)
        if not nodes:
            return original_call(function, *args, **kwargs)
        beside = ca.Function(function.name(), function.sx_in(), [*_outputs(function), _column(nodes)],
                             function.name_in(), [*function.name_out(), SITES_OUTPUT])
        result = original_call(beside, *args, **kwargs)
        if isinstance(result, dict):
            sites.follow(nodes, result.pop(SITES_OUTPUT))
            return result
        *outputs, followed = result
        sites.follow(nodes, followed)
        return outputs[0] if len(outputs) == 1 else tuple(outputs)

    for name in FUNCTIONS:
        setattr(ca, name, recording(originals[name]))
    ca.substitute, ca.cse = substitute, cse
    original_call = ca.Function.__call__
    ca.Function.__call__ = call
    for name in COMPARISONS:
        setattr(ca.SX, name, recording(getattr(ca.SX, name)))
    try:
        yield sites
    finally:
        ca.Function.__call__ = original_call
        for name, original in originals.items():
            setattr(ca, name, original)
        for name, method in own_methods.items():
            if method is None:
                delattr(ca.SX, name)
            else:
                setattr(ca.SX, name, method)
