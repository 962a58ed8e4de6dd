"""The one shape every estimator has, and the kernel structures its step comes in.

    state_0 = init(input_0);   state_k+1, output_k = step(state_k, input_k)   for k = 0, 1, ...

``init`` and ``step`` are CasADi SX Functions of flat vectors with named layouts, so codegen, the
harness, equivalence checks and benchmarks are written once for all estimators.

How the generated C computes a step is the estimator's *structure*, exactly one of:

* :class:`SingleStep`: one ``step`` Function, called once per sample;
* :class:`Guarded`: a ``guard`` Function decides whether the sample is active (every input
  plausible, speed not low); the generated C then runs either the ``active`` Function, written
  without the hold rule's selects and input holds, or the ``held`` one (``model.guard.Decisions``
  derives both from one step expression);
* :class:`Schemes`: an estimator that switches between schemes (seed 000) has a ``select``
  Function that updates the shared part of the state and picks a scheme, and one Function per
  scheme; the generated C evaluates only the chosen scheme (CasADi's SX ``if_else`` would evaluate
  every branch);
* :class:`Repeated`: a step that applies one computation to several items (the unscented
  transform's sigma-point pairs, seed 002); the generated C loops over the items with one copy of
  that code rather than unrolling it;
* :class:`Particles`: a particle filter (seed 003), whose random draws, weights, estimate and
  resampling are generic template C; its model is a few Functions applied per particle. It has no
  composed ``step`` (random numbers and resampling are no SX expressions); the NumPy reference and
  the C are compared instead.

Each structure names its kernel Functions (``kernel_functions``, generated after ``init``), those
that step the caller's state in place (``in_place``), its operation count per step and the
template fragments (``codegen/templates/``) that call them, so the code generator and the API
template never branch on the kind of estimator.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import casadi as ca

from vsegen.model import signals, status
from vsegen.model.calibration import Parameters
from vsegen.model.guard import Decisions
from vsegen.model.layout import Layout
from vsegen.model.schema import EstimatorSchema

if TYPE_CHECKING:
    from vsegen.model.monitor_block import MonitorBlock


class Sum(NamedTuple):
    """A sum the input checks keep between two runs (their period's mean, ``model.input_monitors.AVERAGED``)."""

    terms: tuple[str, ...]
    """The input it adds, or the first minus the second (an axle's right and left wheel speed)."""
    entry: str
    """Its state entry."""
    judged: bool
    """Whether its terms are read by the checks alone (so they can be implausible on an active
    sample): then it adds its value only where |value| <= the [inputs] limit of its first term
    (false for NaN and +-Inf; for a wheel-speed difference, one test of the difference: a wheel
    speed gone wrong shows in it, and the check is there to see it)."""


@dataclass(frozen=True)
class CheckSegment:
    """The input checks' part of the state: its last entries, which the method only reads. After
    the method's kernels, a kernel of their own (``checks``) steps them in place on an active
    sample when their countdown is 0 (every ``check_period``); on the other active samples the
    generated C counts the countdown down and sums the averaged inputs, on a held one it waits
    (``model.monitor_block``).
    The method reads their last run: it sees a run from the next sample on."""

    names: tuple[str, ...]
    """Their names, the state layout's last entries."""
    ran: ca.SX
    """Their values after a run on an active sample (the ``checks`` kernel's result)."""
    counting: ca.SX
    """1 while the countdown is above 0."""
    counted: ca.SX
    """Their values on such an active sample: the countdown one less, the sample added to the sums
    of the averaged inputs, the rest kept."""
    kept: ca.SX
    """Their values as they came in."""
    sums: tuple[Sum, ...] = ()
    """The sums kept between two runs."""

    def composed(self, active: ca.SX) -> ca.SX:
        """Their values after a sample that was ``active`` (a held one keeps them)."""
        return ca.if_else(active, ca.if_else(self.counting, self.counted, self.ran), self.kept)

    def method_part(self, state_sym: ca.SX, expressions: ca.SX) -> ca.SX:
        """``expressions``' entries before the segment (a method's next state: the segment's
        entries there must be the state's own, untouched)."""
        method = state_sym.numel() - len(self.names)
        for k in range(method, expressions.numel()):
            if not _keeps(expressions[k], state_sym[k]):
                raise ValueError(f"the method writes {self.names[k - method]}, an entry of the input checks")
        return expressions[:method]

    def kernel(self, name: str, state_sym: ca.SX, input_sym: ca.SX, parameters: Parameters) -> CheckKernel:
        """The ``checks`` kernel, (state, input[, params]) -> the segment after a run, and the sums
        the generated C keeps between two runs."""
        extra = parameters.inputs()
        function = ca.Function(f"vse_{name}_kernel_checks", [state_sym, input_sym, *extra], [ca.densify(self.ran)],
                               ["state", "input", *["params"] * len(extra)], ["checks_next"])
        return CheckKernel(function, self.sums)


@dataclass(frozen=True)
class CheckKernel:
    """What the generated C needs of the input checks (:class:`CheckSegment`): their kernel, run
    every ``check_period``, and the sums it keeps on the active samples in between."""

    function: ca.Function
    """(state, input[, params]) -> the segment after a run."""
    sums: tuple[Sum, ...]
    """The sums it keeps between two runs."""

    @property
    def gated(self) -> bool:
        """Whether a sum takes only the plausible values of its inputs."""
        return any(total.judged for total in self.sums)


def hold_entry(states: Layout) -> str:
    """The state entry that says a sample was held (0 when it was active): ``holding`` or
    ``hold_reason``."""
    return next(name for name in (signals.HOLDING.name, signals.HOLD_REASON.name) if name in states.names)


def _keeps(expression: ca.SX, entry: ca.SX) -> bool:
    """Whether the scalar ``expression`` is ``entry`` itself, also as both branches of SX
    ``if_else`` (which CasADi writes (c ? a : 0) + (!c ? b : 0))."""
    if ca.is_equal(expression, entry):
        return True
    if expression.op() != ca.OP_ADD:
        return False
    branches = [expression.dep(i) for i in range(2)]
    if any(b.op() != ca.OP_IF_ELSE_ZERO for b in branches):
        return False
    condition, otherwise = branches[0].dep(0), branches[1].dep(0)
    complementary = otherwise.op() == ca.OP_NOT and ca.is_equal(otherwise.dep(0), condition)
    return complementary and all(_keeps(b.dep(1), entry) for b in branches)


class _ComposedStep:
    """Operation counts of a structure with a composed ``step`` Function."""

    step: ca.Function | None
    checks: CheckKernel | None = None
    """The input checks' kernel (:class:`CheckSegment`), where the estimator has input checks."""
    header_template = "state_index.h.j2"
    in_place: tuple[str, ...] = ()
    """Names of the kernels that read their whole state (argument 0) before writing any of their
    next state (result 0), so the API passes the caller's state as both
    (``codegen.kernel._read_state_first`` makes them so)."""

    def step_operations(self) -> int:
        return self.step.n_instructions()

    @property
    def system_headers(self) -> tuple[str, ...]:
        """math.h where the template judges a summed input (fabs)."""
        return ("math.h",) if self.checks is not None and self.checks.gated else ()

    @property
    def checks_kernels(self) -> tuple[ca.Function, ...]:
        """The input checks' kernel, if any: generated first; it steps its part of the state in place."""
        return () if self.checks is None else (self.checks.function,)

    def checks_names(self, states: Layout) -> dict[str, tuple[str, ...]]:
        """The entry names of the checks kernel's result (the state's last entries)."""
        return {} if self.checks is None else {"checks_next": states.names[-self.checks.function.numel_out(0):]}

    def init_operations(self, init: ca.Function) -> int:
        return init.n_instructions()

    def argument_names(self, states: Layout) -> dict[str, tuple[str, ...]]:
        """Entry names of this structure's own kernel arguments (beyond state, input, output,
        params), by argument name."""
        return {}


@dataclass(frozen=True)
class SingleStep(_ComposedStep):
    """A step that is one Function: ``step(state, input[, params]) -> (state_next, output)``;
    its C kernel reads the whole state before writing any of it, so the API passes the caller's
    state as both (``codegen.kernel._read_state_first``)."""

    step: ca.Function
    templates = ("init.c.j2", "step_single.c.j2")

    @property
    def kernel_functions(self) -> tuple[ca.Function, ...]:
        return (self.step,)

    @property
    def in_place(self) -> tuple[str, ...]:
        return (self.step.name(),)


@dataclass(frozen=True)
class Guarded(_ComposedStep):
    """A step that does only the work its sample needs: ``guard(state, input[, params]) ->
    decisions`` (flags: each input's plausibility, low speed and, last, active), then
    ``active(state, input[, params]) -> (state_next, output)`` on an active sample, else
    ``held(state, input, decisions[, params])`` (same results). ``step`` is the composition, for
    Python. Built by :func:`make_guarded`; both branches step the caller's state in place."""

    guard: ca.Function
    active: ca.Function
    held: ca.Function
    step: ca.Function
    checks: CheckKernel | None = None
    templates = ("init.c.j2", "step_guarded.c.j2")

    @property
    def kernel_functions(self) -> tuple[ca.Function, ...]:
        return *self.checks_kernels, self.guard, self.active, self.held

    @property
    def in_place(self) -> tuple[str, ...]:
        return *(f.name() for f in self.checks_kernels), self.active.name(), self.held.name()

    def step_operations(self) -> int:
        """An active sample's: the guard's and the active kernel's (a held one runs the guard and
        the held kernel)."""
        return self.guard.n_instructions() + self.active.n_instructions()

    @property
    def decision_count(self) -> int:
        return self.guard.numel_out(0)

    def argument_names(self, states: Layout) -> dict[str, tuple[str, ...]]:
        return {"decisions": tuple(str(flag) for flag in ca.vertsplit(self.held.sx_in("decisions"))),
                **self.checks_names(states)}


@dataclass(frozen=True)
class Schemes(_ComposedStep):
    """Only-one-scheme-per-step structure.

    ``select(state, input[, params]) -> (state_mid, scratch)``; ``scratch[0]`` is the index of the
    scheme to run. ``branches[i] = (label, fn)`` with
    ``fn(state_mid, input, scratch[, params]) -> (state_next, output)``. ``step`` is their
    composition (every scheme evaluated, the chosen one selected), for Python (set by the
    builder once it has made it).
    """

    select: ca.Function
    branches: tuple[tuple[str, ca.Function], ...]
    scratch: Layout
    step: ca.Function | None = None
    checks: CheckKernel | None = None
    templates = ("init.c.j2", "step_schemes.c.j2")

    @property
    def kernel_functions(self) -> tuple[ca.Function, ...]:
        return (*self.checks_kernels, self.select, *(fn for _, fn in self.branches))

    @property
    def in_place(self) -> tuple[str, ...]:
        return tuple(f.name() for f in self.checks_kernels)

    @property
    def mid_entries(self) -> int:
        """Entries of the select's state (the method's: the input checks' are read in place)."""
        return self.select.numel_out(0)

    def argument_names(self, states: Layout) -> dict[str, tuple[str, ...]]:
        return {"scratch": self.scratch.names, "state_mid": states.names[:self.mid_entries],
                **self.checks_names(states)}


@dataclass(frozen=True)
class Repeated(_ComposedStep):
    """A step whose bulk is one Function applied to ``count`` items.

    ``prepare(state, input[, params]) -> (items, shared)``: ``items`` holds the ``count`` item
    inputs back to back; ``each(shared, item[, params]) -> (result)``;
    ``finish(state, input, results[, params]) -> (state_next, output)``, ``results`` the
    ``count`` results back to back. ``step`` is the composition, for Python (set by the
    builder once it has made it: ``dataclasses.replace(repeated, step=step)``).
    """

    prepare: ca.Function
    each: ca.Function
    finish: ca.Function
    count: int
    step: ca.Function | None = None
    checks: CheckKernel | None = None
    templates = ("init.c.j2", "step_repeated.c.j2")

    @property
    def kernel_functions(self) -> tuple[ca.Function, ...]:
        return *self.checks_kernels, self.prepare, self.each, self.finish

    @property
    def in_place(self) -> tuple[str, ...]:
        return tuple(f.name() for f in self.checks_kernels)

    def argument_names(self, states: Layout) -> dict[str, tuple[str, ...]]:
        return self.checks_names(states)


RNG_WORDS = 4
"""A particle filter's state stores the 64-bit state of its PCG32 random stream as this many
16-bit words, most significant first, each an integer-valued real (exact in float too), so the
whole state stays one flat real vector."""


@dataclass(frozen=True)
class Particles:
    """A particle filter's model-specific Functions; the C around them is template code.

    State = [head (``head_size`` entries), RNG_WORDS random-stream words, ``count`` particles of
    ``len(particle)`` entries]; a particle's last entry is its normalised weight.

    * ``init(input[, params]) -> (head, shared)``: the head at the first sample and the ``shared``
      vector that ``spawn`` draws the initial particles with;
    * ``prepare(head, input[, params]) -> shared``: ``shared[0]`` is the sample's mode: 0 hold
      (the particles and the stream are left alone), 1 propagate, 2 spawn a new set;
    * ``spawn(shared, normals[, params]) -> particle`` and
      ``propagate(shared, particle, normals[, params]) -> particle``, with the particle's
      log-weight score in its last entry; ``normals`` are standard normal draws, in state order;
    * ``finish(head, shared, summary[, params]) -> (head_next, output)``: ``summary`` is the
      weighted mean of the particles' entries but the last, then N_eff = 1 / sum w^2.

    ``resampling``: "every_sample" or "effective_size" (only when N_eff < count / 2), systematic.
    ``sampler``: the normal draws' algorithm, "ziggurat" (``model.ziggurat``) or "box_muller".
    """

    init: ca.Function
    prepare: ca.Function
    spawn: ca.Function
    propagate: ca.Function
    finish: ca.Function
    count: int
    seed: int
    resampling: str
    sampler: str
    head_size: int
    particle: Layout

    @property
    def normals(self) -> int:
        """Standard normal draws per particle and sample."""
        return self.propagate.numel_in(2)

    step = None
    """No composed step: random numbers and resampling are no SX expressions."""
    in_place: tuple[str, ...] = ()
    templates = ("particles.c.j2",)
    header_template = "particle_index.h.j2"
    system_headers = ("math.h",)

    @property
    def kernel_functions(self) -> tuple[ca.Function, ...]:
        return self.prepare, self.spawn, self.propagate, self.finish

    def step_operations(self) -> int:
        """The kernels' count for the particle count (the template's draws, weights and
        resampling come on top)."""
        return (self.prepare.n_instructions() + self.count * self.propagate.n_instructions()
                + self.finish.n_instructions())

    def init_operations(self, init: ca.Function) -> int:
        return init.n_instructions() + self.count * self.spawn.n_instructions()

    def argument_names(self, states: Layout) -> dict[str, tuple[str, ...]]:
        head = states.names[:self.head_size]
        return {"head": head, "head_next": head, "particle": self.particle.names,
                "particle_next": self.particle.names}


Structure = SingleStep | Guarded | Schemes | Repeated | Particles


@dataclass(frozen=True)
class Estimator:
    """A built estimator for one vehicle configuration.

    Attributes:
        name: estimator name (``[estimator.<name>]``, C prefix ``vse_<name>_``).
        summary: one line: what it estimates and how.
        inputs, states, outputs: layouts of the flat vectors.
        init: Function ``init(input[, params]) -> (state)``; for a particle filter its
            ``Particles.init`` (the head of the state; the template draws the particles).
        structure: how the generated C computes a step (module docstring).
        parameters: where the parameter values come from (``params`` is an input when they are
            calibratable).
        notes: facts worth printing in generated files (e.g. discretisation error bound).
        rounding_gain: how much the algorithm amplifies the rounding of its NumPy reference
            beyond that of a plain Kalman filter (1 for most; the unscented transform's weighted
            sums, ``model.unscented``); the double equivalence tolerance is widened by it.
    """

    name: str
    summary: str
    inputs: Layout
    states: Layout
    outputs: Layout
    init: ca.Function
    structure: Structure
    parameters: Parameters
    notes: Mapping[str, str] = field(default_factory=dict)
    rounding_gain: float = 1.0

    @property
    def step(self) -> ca.Function | None:
        """``step(state, input[, params]) -> (state_next, output)`` for Python; None for a
        particle filter."""
        return self.structure.step

    def read_parameters(self) -> tuple[str, ...]:
        """The calibration entries some Function of the generated code depends on (CasADi's
        which_depends on the ``params`` input), in calibration order; () when baked."""
        names = self.parameters.names
        read: set[int] = set()
        for function in (self.init, *self.structure.kernel_functions):
            if "params" not in function.name_in():
                continue
            for output in function.name_out():
                flags = function.which_depends("params", [output], 1, False)
                read |= {i for i, flag in enumerate(flags) if flag}
        return tuple(names[i] for i in sorted(read))

    @property
    def hold_entry(self) -> str:
        """The state entry that is 0 after an active sample (:func:`hold_entry`)."""
        return hold_entry(self.states)

    @property
    def operation_counts(self) -> dict[str, int]:
        """CasADi instructions of one step, of a run of the input checks (0 without them) and of
        init (a particle filter's for its particle count, without the template's draws and
        resampling)."""
        checks = getattr(self.structure, "checks", None)
        return {"step": self.structure.step_operations(),
                "checks": 0 if checks is None else checks.function.n_instructions(),
                "init": self.structure.init_operations(self.init)}


EVERYWHERE = "everywhere"
BEYOND_LINEAR = "beyond_linear"
LOW_FRICTION = "low_friction"
REGIMES = {
    EVERYWHERE: "every sample",
    BEYOND_LINEAR: "lateral acceleration beyond the tyres' linear range",
    LOW_FRICTION: "driving near the friction limit of a low-friction road",
}
"""Where a tunable setting acts: ``vsegen tune`` searches a setting only when the training logs
cover its regime (harness.tune.coverage), so a setting the logs never exercise keeps its value."""


@dataclass(frozen=True)
class Tunable:
    """A numeric setting ``vsegen tune`` may search: the scalar, or each entry of a list or
    matrix diagonal, between ``low`` and ``high`` (units of the setting), on a log scale when
    ``log``. Only settings read at run time by the calibratable C (no structural ones); ``when``
    (of the estimator's settings) says whether the configured options read it; ``regime`` (a key
    of :data:`REGIMES`) where it acts."""

    low: float
    high: float
    log: bool = True
    when: Callable[[Mapping[str, Any]], bool] | None = None
    regime: str = EVERYWHERE

    def applies(self, settings: Mapping[str, Any]) -> bool:
        """Whether the generated code of ``settings`` reads this setting."""
        return self.when is None or self.when(settings)


IDENTIFIED = {"roll_gradient": "rad/(m/s^2)", "gyro_noise": "rad/s", "ay_noise": "m/s^2",
              "ax_noise": "m/s^2", "tyre_friction": "-"}
"""Car and sensor quantities ``vsegen identify`` estimates from logs, by name, with their units."""


@dataclass(frozen=True)
class Derived:
    """A car-specific setting: it follows from identified quantities (names of :data:`IDENTIFIED`),
    ``value(*quantities)`` giving the setting in its own unit. ``vsegen identify`` fills it;
    ``generate`` and ``run`` warn when it was not derived for the file's [vehicle]."""

    quantities: tuple[str, ...]
    value: Callable[..., Any]
    optional: bool = False
    """Only logs of some driving show it (the tyres' friction: driving at the limit): not derived,
    the file keeps its value and the others' ``derived_for`` still holds."""


ROLL_GRADIENT = {"roll_gradient": Derived(("roll_gradient",), lambda k: k)}
"""The roll correction's roll gradient is the car's."""
KF_MEASUREMENT_NOISE = {"measurement_noise": Derived(("ay_noise", "gyro_noise"), lambda ay, r: [ay**2, r**2])}
"""R = diag(sigma_ay^2, sigma_r^2) of a Kalman filter measuring [a_y, r]."""
TYRE_FRICTION = {"tyre_friction": Derived(("tyre_friction",), lambda mu: [mu, mu], optional=True)}
"""A Kalman filter's saturating tyres carry the friction identify fits (both axles alike)."""
GYRO_VARIANCE = {"measurement_noise": Derived(("gyro_noise",), lambda r: r**2)}
"""R = sigma_r^2 of a filter measuring the yaw rate."""
INERTIAL_SIGMAS = {"measurement_noise": Derived(("ax_noise", "ay_noise", "gyro_noise"),
                                                lambda ax, ay, r: [ax, ay, r])}
"""Standard deviations of [a_x, a_y, r]."""


@dataclass(frozen=True, kw_only=True)
class Definition:
    """Everything the rest of vsegen needs to know about one estimator, declared in its module
    (``model/estimators/<module>.py``) and collected by ``model.estimators``: its name (the
    ``[estimator.<name>]`` table and the C prefix ``vse_<name>_``), how to build it, the schema of
    its settings, the settings ``tune`` may search, the status bits it can raise and its
    car-specific settings. The NumPy
    reference is bound by name in ``harness.reference`` (the model never imports the harness)."""

    name: str
    build: Callable[[Parameters], Estimator]
    schema: EstimatorSchema
    tunable: Mapping[str, Tunable] = field(default_factory=dict)
    status_bits: tuple[int, ...] = (status.LOW_SPEED, status.INVALID_INPUT)
    """The ``model.status`` bits it can raise (the hold rule's two, and its own), as the status
    constants; the generated header defines only these."""
    derived: Mapping[str, Derived] = field(default_factory=dict)
    """Its car-specific settings and how each follows from identified quantities."""
    monitors: Callable[[Mapping], MonitorBlock] | None = None
    """Its monitor block for numeric settings (``model.monitor_block``), if it carries one."""


def make_functions(name: str, inputs: Layout, states: Layout, outputs: Layout, input_sym: ca.SX,
                   state_sym: ca.SX, init_state: ca.SX, next_state: ca.SX, output: ca.SX,
                   parameters: Parameters, checks: CheckSegment | None = None):
    """The ``init`` and ``step`` Functions with the naming every estimator uses; with ``checks``,
    the step runs the input checks first and the method (``next_state``, ``output``) on what they
    left (:class:`CheckSegment`)."""
    extra = parameters.inputs()
    extra_names = ["params"] * len(extra)
    if checks is not None:
        method = checks.method_part(state_sym, next_state)
        next_state = ca.vertcat(method, checks.composed(method[states.index(hold_entry(states))] <= 0))
    # dense: the C copies flat vectors, so a structural zero (e.g. of SX.eye) must be stored too
    init_state, next_state, output = (ca.densify(e) for e in (init_state, next_state, output))
    init = ca.Function(f"vse_{name}_kernel_init", [input_sym, *extra], [init_state],
                       ["input", *extra_names], ["state"])
    step = ca.Function(f"vse_{name}_kernel_step", [state_sym, input_sym, *extra],
                       [next_state, output], ["state", "input", *extra_names],
                       ["state_next", "output"])
    for fn, layout, label in ((init, states, "state"), (step, states, "state_next")):
        if fn.numel_out(label) != len(layout):
            raise ValueError(f"{name}: {label} has {fn.numel_out(label)} entries, layout {len(layout)}")
    if step.numel_out("output") != len(outputs) or step.numel_in("input") != len(inputs):
        raise ValueError(f"{name}: output or input size does not match its layout")
    return init, step


def make_guarded(name: str, inputs: Layout, states: Layout, outputs: Layout, input_sym: ca.SX,
                 state_sym: ca.SX, init_state: ca.SX, next_state: ca.SX, output: ca.SX,
                 parameters: Parameters, decisions: Decisions,
                 checks: CheckSegment | None = None) -> tuple[ca.Function, Guarded]:
    """``init`` and the :class:`Guarded` structure of a step whose ``next_state`` and ``output``
    are written with the symbolic guard ``decisions`` (``model.guard.symbolic``): the composed
    step takes their values, the active kernel the values of an active sample (where every hold
    and select falls away), the held kernel the guard's decisions as its third argument. With
    ``checks``, the method's kernels write the state before their segment (:class:`CheckSegment`)."""
    init, step = make_functions(name, inputs, states, outputs, input_sym, state_sym, init_state,
                                decisions.actual(next_state), decisions.actual(output), parameters, checks)
    if checks is not None:
        next_state = checks.method_part(state_sym, next_state)
    extra = parameters.inputs()
    extra_names = ["params"] * len(extra)
    arguments, names = [state_sym, input_sym], ["state", "input"]
    guard = ca.Function(f"vse_{name}_kernel_guard", [*arguments, *extra], [decisions.values],
                        [*names, *extra_names], ["decisions"])
    active = ca.Function(f"vse_{name}_kernel_active", [*arguments, *extra],
                         _shared(decisions.when_active(next_state), decisions.when_active(output)),
                         [*names, *extra_names], ["state_next", "output"])
    held = ca.Function(f"vse_{name}_kernel_held", [*arguments, decisions.symbols, *extra],
                       _shared(decisions.when_held(next_state), decisions.when_held(output)),
                       [*names, "decisions", *extra_names], ["state_next", "output"])
    kernel = None if checks is None else checks.kernel(name, state_sym, input_sym, parameters)
    return init, Guarded(guard, active, held, step, kernel)


def _shared(*results: ca.SX) -> list[ca.SX]:
    """Dense ``results`` with their common subexpressions merged (a substitution rebuilds a
    subexpression once per path that reaches it, e.g. a clamped speed used by two formulas)."""
    joint = ca.cse(ca.vertcat(*[ca.densify(ca.vec(r)) for r in results]))
    offsets = [0]
    for r in results:
        offsets.append(offsets[-1] + r.numel())
    return [ca.reshape(part, *r.shape) for part, r in zip(ca.vertsplit(joint, offsets), results)]


def make_schemes(name: str, states: Layout, scratch: Layout, state_sym: ca.SX, input_sym: ca.SX,
                 mid_state: ca.SX, scratch_expr: ca.SX,
                 branches: list[tuple[str, ca.SX, ca.SX, ca.SX, ca.SX, ca.SX]],
                 parameters: Parameters, checks: CheckSegment | None = None) -> tuple[Schemes, ca.SX, ca.SX]:
    """Functions of a switching step and the composed (next_state, output) expressions; the
    composed step is the method's (``make_functions`` runs the ``checks`` after it).

    ``branches``: (label, mid symbol, scratch symbol, input symbol, next state, output) per scheme,
    in index order; each branch's expressions use its own symbols. With ``checks``, the select and
    the schemes carry the state before the input checks' segment, which they only read.
    """
    extra = parameters.inputs()
    extra_names = ["params"] * len(extra)

    def method(symbols: ca.SX, expressions: ca.SX) -> tuple[ca.SX, ca.SX]:
        if checks is None:
            return symbols, expressions
        kept = checks.method_part(symbols, expressions)
        return symbols[:kept.numel()], kept

    select = ca.Function(f"vse_{name}_kernel_select", [state_sym, input_sym, *extra],
                         [ca.densify(method(state_sym, mid_state)[1]), ca.densify(scratch_expr)],
                         ["state", "input", *extra_names],
                         ["state_mid", "scratch"])
    functions = []
    for label, mid_sym, scratch_sym, input_b, next_state, output in branches:
        mid_part, next_part = method(mid_sym, next_state)
        functions.append((label, ca.Function(
            f"vse_{name}_kernel_{label}", [mid_part, input_b, scratch_sym, *extra],
            [ca.densify(next_part), ca.densify(output)],
            ["state_mid", "input", "scratch", *extra_names],
            ["state_next", "output"])))
    mid, scr = select(state_sym, input_sym, *extra)
    composed_state, composed_output = None, None
    for index in range(len(functions) - 1, -1, -1):
        branch_state, branch_output = functions[index][1](mid, input_sym, scr, *extra)
        if composed_state is None:
            composed_state, composed_output = branch_state, branch_output
        else:
            chosen = scr[0] == index
            composed_state = ca.if_else(chosen, branch_state, composed_state)
            composed_output = ca.if_else(chosen, branch_output, composed_output)
    if checks is None:
        return Schemes(select, tuple(functions), scratch), composed_state, composed_output
    untouched = state_sym[composed_state.numel():]        # the segment, as the method sees it
    return (Schemes(select, tuple(functions), scratch, checks=checks.kernel(name, state_sym, input_sym, parameters)),
            ca.vertcat(composed_state, untouched), composed_output)


def make_repeated(name: str, state_sym: ca.SX, input_sym: ca.SX, items: list[ca.SX],
                  shared: ca.SX, each: ca.Function, results_sym: ca.SX, next_state: ca.SX,
                  output: ca.SX, parameters: Parameters,
                  checks: CheckSegment | None = None) -> tuple[Repeated, ca.SX, ca.SX]:
    """The Functions of a repeated step and the composed (next_state, output) expressions of the
    method (``make_functions`` runs the ``checks`` after it).

    ``items`` and ``shared`` are expressions of the state and input; ``each`` maps (shared, item
    [, params]) to one result; ``next_state`` and ``output`` use ``results_sym``, the results of
    all items back to back. With ``checks``, ``finish`` writes the state before their segment.
    """
    extra = parameters.inputs()
    extra_names = ["params"] * len(extra)
    prepare = ca.Function(f"vse_{name}_kernel_prepare", [state_sym, input_sym, *extra],
                          [ca.densify(ca.vertcat(*items)), ca.densify(shared)],
                          ["state", "input", *extra_names], ["items", "shared"])
    written = next_state if checks is None else checks.method_part(state_sym, next_state)
    finish = ca.Function(f"vse_{name}_kernel_finish", [state_sym, input_sym, results_sym, *extra],
                         [ca.densify(written), ca.densify(output)],
                         ["state", "input", "results", *extra_names], ["state_next", "output"])
    results = ca.vertcat(*[each(shared, item, *extra) for item in items])
    composed_state, composed_output = ca.substitute([next_state, output], [results_sym], [results])
    kernel = None if checks is None else checks.kernel(name, state_sym, input_sym, parameters)
    return Repeated(prepare, each, finish, len(items), checks=kernel), composed_state, composed_output
