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
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from tmpc.compiler import ir
from tmpc.compiler.ground import ground as ground_program
from tmpc.compiler.jaxcfg import configured
from tmpc.compiler.kernels import (
    KernelWorld,
    Options,
    build_world,
    condition_kernel,
    lua_host_call,
    residual_kernel,
)
from tmpc.compiler.lower import Lowerer
from tmpc.compiler.lua_trace import trace_module
from tmpc.compiler.robot import RobotModel, make_fk, robot_model
from tmpc.lang import ast as A
from tmpc.lang.checker import CheckedProgram
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.lua import load_lua_predicates
from tmpc.lang.world import Scene


@dataclass(frozen=True)
class Formula:
    """A lifted geometric condition: ``body`` over ``Arg(i)`` = ``params[i]``."""

    name: str
    params: tuple[A.Typed, ...]
    body: ir.Node


@dataclass(eq=False)
class CompiledProgram:
    program: CheckedProgram
    scene: Scene
    model: RobotModel | None
    options: Options = Options()
    #: IR of externally defined (Lua) predicates, by lower-case name, supplied by the Lua tracer
    external: dict[str, ir.Node] = field(default_factory=dict)
    _kernels: dict = field(default_factory=dict, repr=False)

    @cached_property
    def tables(self) -> KernelWorld:
        """The kernels' entity, pose and frame tables."""
        return build_world(self.scene, self.model, self.program.scope)

    @cached_property
    def fk(self):
        """Jitted forward kinematics of :attr:`model` (None without a robot)."""
        if self.model is None:
            return None
        return configured().jit(make_fk(self.model))

    @cached_property
    def ground(self):
        """The grounded problem (:class:`~tmpc.compiler.ground.GroundProblem`)."""
        return ground_program(self.program)

    @cached_property
    def goal(self) -> Formula | None:
        """The conjunction of the goal's geometric literals, their predicates' bodies bound to
        the goal's objects; None when the goal is purely symbolic."""
        lits = self.ground.goal.geometric
        if not lits:
            return None
        parts = []
        for lit in lits:
            inner = self.predicate(lit.predicate)
            body = substitute(inner.body, {i: ir.Entity(a) for i, a in enumerate(lit.args)})
            parts.append(body if lit.positive else ir.op("not", (body,), ir.BOOL))
        body = parts[0] if len(parts) == 1 else ir.op("and", parts, ir.BOOL)
        return Formula("goal", (), body)

    # ---- formulas ----------------------------------------------------------------------------
    def predicate(self, name: str) -> Formula:
        decl = self.program.scope.predicates.get(name.lower())
        if decl is None:
            raise InputError(error("E582", f"unknown predicate `{name}`", None))
        if decl.kind is not A.Kind.GEOMETRIC:
            raise InputError(error("E586", f"`{name}` is a {decl.kind.value} predicate, not "
                                   "geometric", None))
        if decl.semantics is not None:
            body = Lowerer(self.program.scope).predicate(decl).body
        elif isinstance(self.external.get(decl.name.key), _Untraceable):
            # evaluated directly: a `lua` node calling the fallback on the host (docs/lua.md)
            body = ir.op("lua", (ir.Const(decl.name.key, "lua"),
                                 *(ir.Arg(i) for i in range(len(decl.params)))), ir.BOOL)
        elif decl.name.key in self.external:
            body = self.external[decl.name.key]
        else:
            raise InputError(error("E583", f"`{name}` has no semantics: it is implemented by a "
                                   "Lua function that was not loaded", decl.span,
                                   "give the Lua predicate file (the run configuration's "
                                   "`semantics`)"))
        return Formula(decl.name.text, decl.params, body)

    def action(self, name: str) -> Formula:
        """The geometric condition of an action schema's precondition."""
        act = self.program.scope.actions.get(name.lower())
        if act is None:
            raise InputError(error("E587", f"unknown action `{name}`", None))
        literals = []
        for lit in _conjuncts(act.precondition):
            atom, positive = (lit.part, False) if isinstance(lit, A.Not) else (lit, True)
            if not isinstance(atom, A.Atom):
                continue
            decl = self.program.scope.predicates.get(atom.pred.key)
            if decl is None or decl.kind is not A.Kind.GEOMETRIC:
                continue
            literals.append(self._bind(atom, act.params, positive))
        if not literals:
            body: ir.Node = ir.Const(1.0, ir.BOOL)
        else:
            body = literals[0] if len(literals) == 1 else ir.op("and", literals, ir.BOOL)
        return Formula(act.name.text, act.params, body)

    def _bind(self, atom: A.Atom, params, positive: bool) -> ir.Node:
        """A predicate's body with its Arg slots renamed to the action's parameter slots."""
        slots = {p.name.key: i for i, p in enumerate(params)}
        inner = self.predicate(atom.pred.text)
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
        """(condition kernel, residual kernel) of a formula, jitted once per formula."""
        key = (formula.name, formula.body)
        if key not in self._kernels:
            jax = configured()
            frames = self.frames_for(formula)
            self._kernels[key] = (
                jax.jit(condition_kernel(formula.body, self.tables, self.options, frames,
                                         self.lua_fallbacks)),
                residual_kernel(formula.body, self.tables, self.options, frames,
                                self.lua_fallbacks))
        return self._kernels[key]

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
    external = {}
    if cfg is not None and cfg.semantics is not None and program is not None:
        external = external_predicates(cfg.semantics, program)
    return CompiledProgram(program, world.scene, robot_model(world.scene), options, external)


def external_predicates(semantics: str, program: CheckedProgram) -> dict[str, ir.Node]:
    """IR of the program's Lua-defined geometric predicates, traced from ``semantics``.

    A predicate tracing cannot capture (data-dependent branches) is evaluated directly by its Lua
    fallback: its formula is a `lua` node, and kernels call the fallback on the host.
    """
    decls = {d.name.text: d for d in program.domain.predicates if d.external}
    if not decls:
        return {}
    result = trace_module(load_lua_predicates(semantics), decls)
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


def _conjuncts(f):
    if f is None:
        return []
    if isinstance(f, A.And):
        return [x for p in f.parts for x in _conjuncts(p)]
    return [f]


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
