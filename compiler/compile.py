"""The one compile step: a loaded world -> :class:`CompiledProgram`, the product the runtime consumes.

:func:`compile_world` builds it from a :class:`~tmpc.lang.inputs.World` (scene, run configuration,
checked program): the robot model and its forward kinematics, the Lua predicates traced, the
grounded problem and the goal's geometric condition. Nothing else constructs one.

:class:`CompiledProgram` holds, per geometric predicate and per action schema, the IR of its
geometric condition over ``Arg`` slots (predicate parameters / action parameters) and builds the
JAX kernels lazily (one per lifted formula, never per ground atom). The discrete part of a
precondition is the grounder's business; here an action's geometric condition is the conjunction
of the geometric literals of its precondition's top-level ``and``.
"""

from __future__ import annotations

import weakref
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from tmpc.compiler import ir
from tmpc.compiler.artifact import load_bank
from tmpc.compiler.bank import F64, I64, KernelBank
from tmpc.compiler.ground import with_geometric_symbols
from tmpc.compiler.ground import ground as ground_program
from tmpc.compiler.jaxcfg import configured
from tmpc.compiler.kernels import (
    KernelTables,
    Options,
    build_tables,
    condition_kernel,
    has_lua_calls,
    inner_bands,
    lua_host_call,
    projector_fn,
    residual_kernel,
)
from tmpc.compiler.lower import Lowerer
from tmpc.compiler.lua_trace import trace_module
from tmpc.compiler.robot import RobotModel, make_fk, make_fk_frames, robot_model
from tmpc.lang import ast as A
from tmpc.lang.checker import CheckedProgram
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.lua import LuaLimits, load_lua_predicates, lua_limits
from tmpc.lang.world import Scene


class Formula:
    """A lifted geometric condition: ``body`` (IR) over ``Arg(i)`` = ``params[i]``. ``kind`` is
    ``predicate``, ``action`` or ``goal``; ``key`` names its kernels in the bank. The body is
    lowered on first use: a run whose kernels come from an artifact never asks for it."""

    __slots__ = ("name", "params", "kind", "_body", "_lower")

    def __init__(self, name: str, params: tuple[A.Typed, ...], body: ir.Node | None = None, *,
                 kind: str = "predicate", lower: Callable[[], ir.Node] | None = None):
        self.name, self.params, self.kind = name, tuple(params), kind
        self._body, self._lower = body, lower

    @property
    def body(self) -> ir.Node:
        if self._body is None:
            self._body = self._lower()
        return self._body

    @property
    def key(self) -> str:
        return f"{self.kind}/{self.name.lower()}"

    def __repr__(self) -> str:
        return f"Formula({self.key}, {len(self.params)} params)"


@dataclass(eq=False)
class CompiledProgram:
    program: CheckedProgram
    scene: Scene
    model: RobotModel | None
    options: Options = Options()
    #: IR of externally defined (Lua) predicates, by lower-case name, supplied by the Lua tracer
    #: (a mapping that traces on first access when built by :func:`compile_world`)
    external: Mapping[str, ir.Node] = field(default_factory=dict)
    #: the jitted functions: exported kernels of an artifact, else traced on first use
    bank: KernelBank = field(default_factory=KernelBank)
    _kernels: dict = field(default_factory=dict, repr=False)

    @cached_property
    def tables(self) -> KernelTables:
        """The kernels' entity, pose and frame tables."""
        return build_tables(self.scene, self.model, self.program.scope)

    @property
    def dof(self) -> int:
        return self.model.dof if self.model is not None else 0

    @cached_property
    def fk(self):
        """Forward kinematics of one configuration ``q (n,) -> Frames`` (None without a robot)."""
        if self.model is None:
            return None
        return self.bank.function("fk", lambda: make_fk(self.model), [((self.dof,), F64)])

    @cached_property
    def fk_frames(self):
        """Forward kinematics of a batch, batch-last: ``Q (b, n) -> (R (F, 3, 3, b), p (F, 3,
        b))`` (:func:`~tmpc.compiler.robot.make_fk_frames`; None without a robot)."""
        if self.model is None:
            return None
        return self.bank.function("fk/frames", lambda: make_fk_frames(self.model),
                                  [(("b", self.dof), F64)])

    @cached_property
    def ground(self):
        """The grounded problem (:class:`~tmpc.compiler.ground.GroundProblem`). Its geometric
        symbols (:mod:`tmpc.compiler.ground.symbols`) start false: which hold where a plan
        starts is the runtime's to decide (:func:`tmpc.runtime.problem.true_symbols`)."""
        return ground_program(self.program)

    @cached_property
    def goal(self) -> Formula | None:
        """The conjunction of the goal's geometric literals, their predicates' bodies bound to
        the goal's objects; None when the goal is purely symbolic."""
        lits = self.ground.goal.geometric
        if not lits:
            return None
        inner = [self.predicate(lit.predicate) for lit in lits]

        def lower() -> ir.Node:
            parts = []
            for lit, f in zip(lits, inner):
                body = substitute(f.body, {i: ir.Entity(a) for i, a in enumerate(lit.args)})
                parts.append(body if lit.positive else ir.op("not", (body,), ir.BOOL))
            return parts[0] if len(parts) == 1 else ir.op("and", parts, ir.BOOL)
        return Formula("goal", (), kind="goal", lower=lower)

    # ---- formulas ----------------------------------------------------------------------------
    def predicate(self, name: str) -> Formula:
        decl = self.program.scope.predicates.get(name.lower())
        if decl is None:
            raise InputError(error("E582", f"unknown predicate `{name}`", None))
        if decl.kind is not A.Kind.GEOMETRIC:
            raise InputError(error("E586", f"`{name}` is a {decl.kind.value} predicate, not "
                                   "geometric", None))
        key = decl.name.key
        if decl.semantics is None and not self._has_external(key):
            raise InputError(error("E583", f"`{name}` has no semantics: it is implemented by a "
                                   "Lua function that was not loaded", decl.span,
                                   "give the Lua predicate file (the run configuration's "
                                   "`semantics`)"))

        def lower() -> ir.Node:
            if decl.semantics is not None:
                return Lowerer(self.program.scope).predicate(decl).body
            if isinstance(self.external.get(key), _Untraceable):
                # evaluated directly: a `lua` node calling the fallback on the host (docs/lua.md)
                return ir.op("lua", (ir.Const(key, "lua"),
                                     *(ir.Arg(i) for i in range(len(decl.params)))), ir.BOOL)
            return self.external[key]
        return Formula(decl.name.text, decl.params, kind="predicate", lower=lower)

    def _has_external(self, key: str) -> bool:
        """Is the Lua predicate ``key`` defined? Known without tracing when the kernels came from
        an artifact (a predicate it compiled had its Lua function)."""
        if isinstance(self.external, LazyExternal) and not self.external.loaded:
            return self.external.defines(key)
        return key in self.external

    def action(self, name: str) -> Formula:
        """The geometric condition of an action schema's precondition."""
        act = self.program.scope.actions.get(name.lower())
        if act is None:
            raise InputError(error("E587", f"unknown action `{name}`", None))
        atoms = []
        for lit in A.conjuncts(act.precondition):
            atom, positive = (lit.part, False) if isinstance(lit, A.Not) else (lit, True)
            if not isinstance(atom, A.Atom):
                continue
            decl = self.program.scope.predicates.get(atom.pred.key)
            if decl is None or decl.kind is not A.Kind.GEOMETRIC:
                continue
            atoms.append((atom, positive, self.predicate(atom.pred.text)))

        def lower() -> ir.Node:
            literals = [self._bind(atom, act.params, positive, inner)
                        for atom, positive, inner in atoms]
            if not literals:
                return ir.Const(1.0, ir.BOOL)
            return literals[0] if len(literals) == 1 else ir.op("and", literals, ir.BOOL)
        return Formula(act.name.text, act.params, kind="action", lower=lower)

    def _bind(self, atom: A.Atom, params, positive: bool, inner: Formula) -> ir.Node:
        """A predicate's body with its Arg slots renamed to the action's parameter slots."""
        slots = {p.name.key: i for i, p in enumerate(params)}
        mapping = {}
        for i, term in enumerate(atom.args):
            if isinstance(term, A.Var):
                mapping[i] = ir.Arg(slots[term.name.key])
            else:
                mapping[i] = ir.Entity(term.name.text)
        body = substitute(inner.body, mapping)
        return body if positive else ir.op("not", (body,), ir.BOOL)

    # ---- kernels -----------------------------------------------------------------------------
    @cached_property
    def lua_fallbacks(self) -> dict:
        """Registry of the `lua` IR nodes: key (the predicate's lower-case name) -> the JAX host
        call of its :class:`~tmpc.compiler.lua_trace.LuaFallback`."""
        return {key: lua_host_call(u.fallback, self.tables) for key, u in self.external.items()
                if isinstance(u, _Untraceable)}

    def kernels(self, formula: Formula):
        """(condition kernel, residual kernel) of a formula. The condition kernel
        ``(q (n,), obj_T (M, 4, 4), obj_parent (M,), args (k,)) -> (truth, distance)`` comes
        from the bank (exported, or traced once); the residual kernel (for Gauss-Newton) is
        traced on first call."""
        key = formula.key
        if key not in self._kernels:
            cond = self.bank.function(
                f"cond/{key}", lambda: self._condition(formula),
                [((self.dof,), F64), *self._mode_spec(), ((len(formula.params),), I64)],
                _host_calls(formula))
            self._kernels[key] = (cond, _Lazy(lambda: residual_kernel(
                formula.body, self.tables, self.options, self.frames_for(formula),
                self.lua_fallbacks)))
        return self._kernels[key]

    def projector(self, formula: Formula):
        """``project(Q0 (b, n), obj_T, obj_parent, args (k,), iterations ()) -> (Q, holds,
        distance)`` of a formula (:func:`~tmpc.compiler.kernels.projector_fn`), from the bank."""
        lower = np.asarray(self.model.lower)
        upper = np.asarray(self.model.upper)
        return self.bank.function(
            f"proj/{formula.key}",
            lambda: projector_fn(self._condition(formula, inner=True), lower, upper,
                                 wraps=np.asarray(self.model.wraps, bool)),
            [(("b", self.dof), F64), *self._mode_spec(), ((len(formula.params),), I64),
             ((), I64)], _host_calls(formula))

    def distance_grad(self, formula: Formula):
        """``(q (n,), obj_T, obj_parent, args) -> (distance, d distance / d q)``, from the bank."""
        def build():
            jax = configured()
            kernel = self._condition(formula)
            return jax.value_and_grad(lambda q, T, par, args: kernel(q, T, par, args)[1])
        return self.bank.function(f"grad/{formula.key}", build,
                                  [((self.dof,), F64), *self._mode_spec(),
                                   ((len(formula.params),), I64)], _host_calls(formula))

    def register_kernels(self, run_only: bool = False) -> None:
        """Name in the bank every kernel a run, ``tmpc sample`` and ``tmpc eval`` can call, so
        an artifact exports them all: per geometric predicate its condition, distance gradient
        and projector; per action schema with a geometric precondition its condition and
        projector; the goal's; forward kinematics of one state and of a batch. ``run_only``:
        what planning calls (no gradients, no predicate projectors): the run cache's
        artifacts, which only `tmpc run` reads, export half as much."""
        if self.model is None or self.program is None:
            return
        for decl in self.program.domain.predicates:
            if decl.kind is A.Kind.GEOMETRIC and (decl.semantics is not None
                                                  or self._has_external(decl.name.key)):
                f = self.predicate(decl.name.text)
                self.kernels(f)
                if not run_only:
                    self.distance_grad(f), self.projector(f)
        for act in self.program.domain.actions:
            f = self.action(act.name.text)
            self.kernels(f), self.projector(f)
        if self.program.problem is not None and self.goal is not None:
            self.kernels(self.goal), self.projector(self.goal)
        self.fk, self.fk_frames

    def _condition(self, formula: Formula, inner: bool = False):
        """The traceable condition kernel (lowers the formula's IR); ``inner``: its distance
        aims at the middle of two-sided bands (:func:`tmpc.compiler.kernels.inner_bands`), for
        projectors."""
        return condition_kernel(formula.body, self.tables, self.options,
                                self.frames_for(formula), self.lua_fallbacks,
                                inner_bands(formula.body) if inner else None)

    def _mode_spec(self):
        m = self.tables.n_objects
        return [((m, 4, 4), F64), ((m,), I64)]

    def frames_for(self, formula: Formula) -> set[int]:
        """Robot frames a formula's kernel may read: frames among the objects its parameters can
        take, the frames it names, and the frames that can hold an object (kinematic parents)."""
        w, scope = self.tables, self.program.scope
        is_frame = lambda e: e is not None and e < w.n_frames   # noqa: E731
        out: set[int] = set()
        types = [tuple(n.key for n in p.type.names) if p.type else ("object",)
                 for p in formula.params]
        for decl in scope.predicates.values():
            if decl.kinematic is not None:
                parent = next(p for p in decl.params if p.name.key == decl.kinematic.parent.key)
                types.append(tuple(n.key for n in parent.type.names) if parent.type
                             else ("object",))
        for want in types:
            for info in scope.objects.values():
                e = w.entity(info.name.text)
                if is_frame(e) and scope.compatible(info.types, want):
                    out.add(e)
        for name in ir.entities_used(formula.body):
            if is_frame(w.entity(name)):
                out.add(w.entity(name))
        for n in ir.walk(formula.body):
            if isinstance(n, ir.Op) and n.op == "base":
                out.add(w.entity(w.model.tree.root))
        return out

    def bind_args(self, formula: Formula, names: list[str]):
        """Entity ids for ground arguments, checked against the formula's parameter types."""
        if len(names) != len(formula.params):
            raise InputError(error("E588", f"`{formula.name}` takes {len(formula.params)} "
                                   f"arguments, given {len(names)}", None))
        scope = self.program.scope
        ids = []
        for name, p in zip(names, formula.params):
            e = self.tables.entity(name)
            if e is None:
                raise InputError(error("E589", f"`{name}` is neither a scene object nor a robot "
                                       "frame", None))
            info = scope.objects.get(name.lower())
            want = tuple(n.key for n in p.type.names) if p.type else ("object",)
            if info is not None and not scope.compatible(info.types, want):
                raise InputError(error("E591", f"`{name}` has type {info.types[0]}, but "
                                       f"`{formula.name}` expects {'|'.join(want)} for "
                                       f"`{p.name.text}`", None))
            ids.append(e)
        return np.asarray(ids, dtype=np.int64)


def compile_world(world, options: Options = Options()) -> CompiledProgram:
    """Compile a loaded world: its robot model (kinematics only: meshes are the collision
    checker's business), the Lua predicates its run configuration names, traced. Kernels,
    grounding and the goal are built lazily, on first use. A world is compiled once per options:
    every consumer of the same loaded world (planner, sampler, validator, viewer) shares the
    product and its jitted kernels."""
    per_world = _COMPILED.setdefault(world, {})
    if options not in per_world:
        per_world[options] = _compile(world, options)
    return per_world[options]


#: compiled products by loaded world (weakly: a world dropped by its user is compiled anew)
_COMPILED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _compile(world, options: Options) -> CompiledProgram:
    cfg, program = world.config, world.program
    external: Mapping = {}
    if cfg is not None and cfg.semantics is not None and program is not None:
        external = LazyExternal(cfg.semantics, program, lua_limits(cfg))
    bank = KernelBank()
    if world.artifact is not None:
        bank = load_bank(*world.artifact)
        if isinstance(external, LazyExternal):
            external.known = frozenset(world.artifact[1].get("lua_predicates", ()))
    if program is not None and world.scene is not None:
        program = with_geometric_symbols(program, *_movable_and_frames(program, world.scene))
    return CompiledProgram(program, world.scene, robot_model(world.scene), options, external,
                           bank)


def _movable_and_frames(program: CheckedProgram, scene: Scene) -> tuple[set[str], set[str]]:
    """Names (lower-case) of the scene's movable objects, and of the program's objects that are
    not scene objects (robot frames)."""
    bodies = {o.name.lower() for o in scene.objects}
    movable = {o.name.lower() for o in scene.objects if o.movable}
    return movable, set(program.scope.objects) - bodies


class LazyExternal(Mapping):
    """The Lua predicates' IR, traced from the semantics file on first access; ``known``: the
    names an artifact says the file defines (so a run from it needs no tracing to know)."""

    def __init__(self, semantics, program: CheckedProgram, limits: LuaLimits | None = None):
        self.semantics, self.program, self.limits = semantics, program, limits
        self.known: frozenset | None = None
        self._ir: dict | None = None

    @property
    def loaded(self) -> bool:
        return self._ir is not None

    def defines(self, key: str) -> bool:
        return key in self.known if self.known is not None else key in self

    def _load(self) -> dict:
        if self._ir is None:
            self._ir = external_predicates(self.semantics, self.program, self.limits)
        return self._ir

    def __getitem__(self, key):
        return self._load()[key]

    def __iter__(self):
        return iter(self._load())

    def __len__(self):
        return len(self._load())


def _host_calls(formula: Formula):
    """For the bank: why ``formula``'s kernels cannot be exported, if they call Lua on the host."""
    def reason() -> str | None:
        if has_lua_calls(formula.body):
            return ("calls a Lua predicate on the host (tracing could not capture it): "
                    "jax.export cannot serialize host callbacks, so it is traced from the "
                    "artifact's sources when used")
        return None
    return reason


class _Lazy:
    """A function built on its first call."""

    def __init__(self, build):
        self._build, self._fn = build, None

    def __call__(self, *args):
        if self._fn is None:
            self._fn = self._build()
        return self._fn(*args)


def external_predicates(semantics: str, program: CheckedProgram,
                        limits: LuaLimits | None = None) -> dict[str, ir.Node]:
    """IR of the program's Lua-defined geometric predicates, traced from ``semantics``.

    A predicate tracing cannot capture (data-dependent branches) is evaluated directly by its Lua
    fallback: its formula is a `lua` node, and kernels call the fallback on the host.
    """
    decls = {d.name.text: d for d in program.domain.predicates if d.external}
    if not decls:
        return {}
    result = trace_module(load_lua_predicates(semantics, limits=limits), decls)
    out = {name.lower(): node for name, node in result.traced.items()}
    for name, fb in result.fallbacks.items():
        fn = fb.module.functions.get(fb.function)
        out.setdefault(name.lower(), _Untraceable(
            name, getattr(fb, "reason", ""),
            fb.module.line_span(fn.line) if fn is not None else None, fb.module.files, fb))
    return out


@dataclass(frozen=True)
class _Untraceable:
    name: str
    reason: str
    #: the Lua function's line, and the files to render it
    span: object = None
    files: dict = field(default_factory=dict)
    #: the :class:`~tmpc.compiler.lua_trace.LuaFallback` evaluating it
    fallback: object = None


def substitute(node: ir.Node, mapping: dict[int, ir.Node]) -> ir.Node:
    """Replace ``Arg(i)`` by ``mapping[i]`` everywhere."""
    if isinstance(node, ir.Arg):
        return mapping[node.index]
    if isinstance(node, ir.Op):
        return ir.Op(node.op, tuple(substitute(a, mapping) for a in node.args), node.vtype)
    if isinstance(node, ir.If):
        return ir.If(substitute(node.cond, mapping), substitute(node.then, mapping),
                     substitute(node.orelse, mapping))
    if isinstance(node, ir.Quant):
        return ir.Quant(node.kind, node.slot, node.domain, substitute(node.body, mapping))
    return node
