"""Lowering: checked tmpc expressions (AST) -> IR, with helpers and predicate calls inlined.

The checker has already verified names and types, so lowering only maps each construct onto IR
operators; anything it cannot map is a bug and raises ``ValueError``. A predicate's parameters
become :class:`~tmpc.compiler.ir.Arg` slots in order.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import count

from tmpc.compiler import ir
from tmpc.compiler.ir import BOOL, BOX, ENTITY, QUAT, SCALAR, TRANSFORM, VEC3
from tmpc.lang import ast as A
from tmpc.lang.scope import Scope
from tmpc.lang.symbols import NUMBER_CONSTANTS

_UNARY = {"abs", "sqrt", "exp", "log", "sin", "cos", "tan", "asin", "acos"}
_CMP = {"<": "lt", "<=": "le", ">": "gt", ">=": "ge"}
_AXES = {"x-axis": 0, "y-axis": 1, "z-axis": 2}
_RPY = {"roll": 0, "pitch": 1, "yaw": 2}
_XYZ = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class Lowered:
    """A predicate's IR: ``body`` refers to ``params`` through ``Arg(i)``."""

    name: str
    params: tuple[A.Typed, ...]
    body: ir.Node


class Lowerer:
    def __init__(self, scope: Scope, entity_names: set[str] | None = None):
        self.scope = scope
        #: names (lower case) that denote entities: domain constants/objects, robot frames
        self.entity_names = entity_names
        self._slots = count()
        self._active: list[str] = []

    # ---- entry points ----------------------------------------------------------------------
    def predicate(self, decl: A.PredicateDecl) -> Lowered:
        if decl.semantics is None:
            raise ValueError(f"predicate {decl.name.text} has no inline semantics")
        env = {p.name.key: ir.Arg(i) for i, p in enumerate(decl.params)}
        body = self.expr(decl.semantics, env)
        return Lowered(decl.name.text, decl.params, body)

    # ---- expressions -----------------------------------------------------------------------
    def expr(self, e: A.Expr, env: dict) -> ir.Node:
        if isinstance(e, A.Num):
            return ir.Const(e.value)
        if isinstance(e, A.ExprVar):
            return env[e.name.key]
        if isinstance(e, A.ExprName):
            if e.name.key in NUMBER_CONSTANTS:
                return ir.Const(NUMBER_CONSTANTS[e.name.key])
            info = self.scope.objects.get(e.name.key)
            return ir.Entity(info.name.text if info else e.name.text)
        if isinstance(e, A.Let):
            inner = dict(env)
            for b in e.bindings:
                inner[b.name.key] = self.expr(b.value, inner)
            return self.expr(e.body, inner)
        if isinstance(e, A.If):
            return ir.If(self.expr(e.cond, env), self.expr(e.then, env), self.expr(e.orelse, env))
        if isinstance(e, A.ExprQuant):
            return self.quant(e, env)
        return self.call(e, env)

    def quant(self, e: A.ExprQuant, env: dict) -> ir.Node:
        body_env = dict(env)
        slots = []
        for p in e.params:
            slot = next(self._slots)
            body_env[p.name.key] = ir.Var(slot)
            slots.append((slot, tuple(n.key for n in p.type.names) if p.type else ("object",)))
        node = self.expr(e.body, body_env)
        for slot, domain in reversed(slots):
            node = ir.Quant(e.kind, slot, domain, node)
        return node

    def call(self, e: A.Call, env: dict) -> ir.Node:
        name = e.op.key
        if name == "joint":
            return ir.Joint(e.args[0].name.text)
        helper = self.scope.helper(name)
        if helper is None and name not in _BUILTIN_NAMES:
            pred = self.scope.predicates.get(name)
            if pred is not None:
                return self.inline(pred.name.text, pred.params, pred.semantics, e, env)
        if helper is not None:
            return self.inline(helper.name.text, helper.params, helper.body, e, env)
        args = [self.expr(a, env) for a in e.args]
        return builtin(name, args)

    def inline(self, name, params, body, e: A.Call, env: dict) -> ir.Node:
        if body is None:
            raise ValueError(f"`{name}` has no inline semantics (a Lua predicate?)")
        if name in self._active:
            raise ValueError(f"`{name}` is recursive")
        args = [self.expr(a, env) for a in e.args]
        self._active.append(name)
        try:
            return self.expr(body, {p.name.key: a for p, a in zip(params, args)})
        finally:
            self._active.pop()


_BUILTIN_NAMES = frozenset({
    "+", "-", "*", "/", *_UNARY, "pow", "atan2", "min", "max", "clamp", "vec3", "norm", "norm1",
    "dot", "cross", "distance", "x", "y", "z", "position", "orientation", "transform", "rpy",
    "roll", "pitch", "yaw", "x-axis", "y-axis", "z-axis", "rotate", "relative", "extent",
    "support-region", "local-support", "grasp-point", "grasp-axis", "grasp-hand-axis",
    "stable-up", "base", "box", "grow", "lower", "upper", "center", "inside", "<", "<=",
    ">", ">=", "=", "and", "or", "not", "implies"})


#: static per-object vectors read from the scene (docs/language.md, "Scene data"): DSL name -> IR op
SCENE_VECTOR_OPS = {"grasp-point": "grasp_point", "grasp-axis": "grasp_axis",
                    "grasp-hand-axis": "grasp_hand_axis", "stable-up": "stable_up"}


def _fold(name: str, args: list[ir.Node]) -> ir.Node:
    acc = args[0]
    for a in args[1:]:
        acc = arith(name, acc, a)
    return acc


def arith(name: str, a: ir.Node, b: ir.Node) -> ir.Node:
    vt = VEC3 if VEC3 in (a.type, b.type) else SCALAR
    return ir.op(name, (a, b), vt)


def _pose(x: ir.Node) -> ir.Node:
    """An entity's world transform; a transform stays as it is."""
    return ir.op("pose", (x,), TRANSFORM) if x.type == ENTITY else x


def _rot(x: ir.Node) -> ir.Node:
    return x if x.type == QUAT else _pose(x)


def builtin(name: str, args: list[ir.Node]) -> ir.Node:
    """The IR of a built-in operator applied to lowered arguments (types already checked)."""
    if name == "+":
        return _fold("add", args)
    if name == "-":
        return ir.op("neg", args, args[0].type) if len(args) == 1 else _fold("sub", args)
    if name == "*":
        return _fold("mul", args)
    if name == "/":
        return arith("div", args[0], args[1])
    if name in _UNARY:
        return ir.op(name, args, SCALAR)
    if name in ("pow", "atan2", "clamp"):
        return ir.op(name, args, SCALAR)
    if name in ("min", "max"):
        acc = args[0]
        for a in args[1:]:
            acc = ir.op(name, (acc, a), SCALAR)
        return acc
    if name == "vec3":
        return ir.op("vec3", args, VEC3)
    if name in ("norm", "norm1", "dot", "distance"):
        return ir.op(name, args, SCALAR)
    if name == "cross":
        return ir.op("cross", args, VEC3)
    if name in _XYZ:
        v = args[0]
        if v.type == ENTITY:
            v = ir.op("position", (_pose(v),), VEC3)
        return ir.op("component", (v, ir.Const(float(_XYZ[name]))), SCALAR)
    if name == "position":
        return ir.op("position", (_pose(args[0]),), VEC3)
    if name == "orientation":
        return ir.op("orientation", (_pose(args[0]),), QUAT)
    if name == "transform":
        return _pose(args[0])
    if name == "rpy":
        return ir.op("rpy", (_rot(args[0]),), VEC3)
    if name in _RPY:
        return ir.op("component", (ir.op("rpy", (_rot(args[0]),), VEC3),
                                   ir.Const(float(_RPY[name]))), SCALAR)
    if name in _AXES:
        return ir.op("rotation_axis", (_rot(args[0]), ir.Const(float(_AXES[name]))), VEC3)
    if name == "rotate":
        return ir.op("rotate", args, VEC3)
    if name == "relative":
        return ir.op("relative", (_pose(args[0]), _pose(args[1])), VEC3)
    if name == "extent":
        return ir.op("extent", args, VEC3)
    if name == "support-region":
        return ir.op("support", args, BOX)
    if name == "local-support":
        return ir.op("support_local", args, BOX)
    if name in SCENE_VECTOR_OPS:
        return ir.op(SCENE_VECTOR_OPS[name], args, VEC3)
    if name == "base":
        return ir.op("base", (), TRANSFORM)
    if name == "box":
        return ir.op("box", args, BOX)
    if name == "grow":
        if len(args) == 2:
            args = [args[0], args[1], args[1], args[1]]
        return ir.op("grow", args, BOX)
    if name in ("lower", "upper", "center"):
        return ir.op(name, args, VEC3)
    if name == "inside":
        return ir.op("inside", args, BOOL)
    if name in _CMP:
        return ir.op(_CMP[name], args, BOOL)
    if name == "=":
        if args[0].type == ENTITY:
            return ir.op("same", args, BOOL)
        return ir.op("eq", args, BOOL)
    if name in ("and", "or"):
        return ir.op(name, args, BOOL) if len(args) > 1 else args[0]
    if name in ("not", "implies"):
        return ir.op(name, args, BOOL)
    raise ValueError(f"no IR for built-in `{name}`")
