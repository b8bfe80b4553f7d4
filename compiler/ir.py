"""The typed expression IR every geometric formula compiles through.

Native `:semantics` bodies (via :mod:`tmpc.compiler.lower`) and traced legacy Lua functions both
produce this IR; the JAX backend (:mod:`tmpc.compiler.kernels.emit`) turns it into truth and distance
kernels. Nodes are frozen dataclasses, so structurally equal subtrees compare and hash equal and
the backend computes each distinct subtree once.

Kernels are **lifted**: a formula refers to its objects through :class:`Arg` slots (indices into
the kernel's ``args`` vector of entity ids), never through ground names, so one kernel serves every
grounding. Entities are robot frames and scene objects alike (their ids index the kernel's pose
table); domain constants are :class:`Entity` nodes resolved by name when a kernel is built.

Value types: ``scalar``, ``vec3``, ``quat`` (x, y, z, w), ``box`` (lower, upper in the world
frame), ``transform`` (R, p), ``bool`` (a condition: has a truth value and a distance), ``entity``.
"""

from __future__ import annotations

from dataclasses import dataclass

SCALAR, VEC3, QUAT, BOX, TRANSFORM, BOOL, ENTITY = \
    "scalar", "vec3", "quat", "box", "transform", "bool", "entity"


@dataclass(frozen=True, slots=True)
class Node:
    """Base class of IR nodes; each subclass has a ``type`` property (its value type)."""


@dataclass(frozen=True, slots=True)
class Const(Node):
    value: float | tuple[float, ...]
    vtype: str = SCALAR

    @property
    def type(self) -> str:
        return self.vtype


@dataclass(frozen=True, slots=True)
class Arg(Node):
    """The kernel's ``index``-th entity argument (a predicate parameter)."""

    index: int

    @property
    def type(self) -> str:
        return ENTITY


@dataclass(frozen=True, slots=True)
class Entity(Node):
    """A named entity (domain constant, robot frame or scene object), resolved at build time."""

    name: str

    @property
    def type(self) -> str:
        return ENTITY


@dataclass(frozen=True, slots=True)
class Var(Node):
    """A variable bound by :class:`Quant` (an entity)."""

    slot: int

    @property
    def type(self) -> str:
        return ENTITY


@dataclass(frozen=True, slots=True)
class Joint(Node):
    """The value of a robot joint (a configuration coordinate or a fixed joint's value)."""

    name: str

    @property
    def type(self) -> str:
        return SCALAR


@dataclass(frozen=True, slots=True)
class Op(Node):
    """An operator application; ``op`` is a key of :data:`OPS`."""

    op: str
    args: tuple[Node, ...]
    vtype: str

    @property
    def type(self) -> str:
        return self.vtype


@dataclass(frozen=True, slots=True)
class If(Node):
    """``cond`` is static (entities, numbers, scene data): both branches are computed."""

    cond: Node
    then: Node
    orelse: Node

    @property
    def type(self) -> str:
        return self.then.type


@dataclass(frozen=True, slots=True)
class Quant(Node):
    """``forall``/``exists`` over the entities of PDDL type ``domain`` (bound in :class:`Var`
    ``slot``); expanded over the problem's objects when a kernel is built."""

    kind: str          # forall | exists
    slot: int
    domain: tuple[str, ...]
    body: Node

    @property
    def type(self) -> str:
        return BOOL


#: Operators: name -> human description. Types are fixed by the lowering; the backend maps each
#: to JAX. Logic and comparison operators produce ``bool`` (truth + distance).
OPS = {
    # arithmetic (scalar or vec3, elementwise; `neg` unary)
    "add": "a + b", "sub": "a - b", "mul": "a * b (scalar*scalar, scalar*vec3, vec3*scalar)",
    "div": "a / b", "neg": "-a",
    "abs": "", "sqrt": "", "exp": "", "log": "", "sin": "", "cos": "", "tan": "", "asin": "",
    "acos": "", "pow": "", "atan2": "", "min": "", "max": "", "clamp": "",
    # vectors
    "vec3": "(x, y, z) -> vec3", "norm": "", "norm1": "", "dot": "", "cross": "",
    "distance": "", "component": "component(v, Const(i))",
    # entities and the state
    "pose": "entity -> transform (world)", "position": "transform -> vec3",
    "orientation": "transform -> quat", "rotation_axis": "(transform|quat, Const(i)) -> vec3",
    "rotate": "(quat, vec3) -> vec3", "relative": "(transform a, transform b) -> vec3",
    "rpy": "transform|quat -> vec3", "quat_of": "quat passthrough",
    "extent": "entity -> vec3 (static)", "support": "entity -> box (world frame, enclosing)",
    "support_local": "entity -> box in the entity's own frame (static)",
    "grasp_point": "entity -> vec3: its first grasp set's template origin, object frame (static)",
    "grasp_axis": "entity -> vec3: that grasp set's rotation axis, object frame (static)",
    "grasp_hand_axis": "entity -> vec3: that axis in the template's (the hand's) frame (static)",
    "stable_up": "entity -> vec3: its object-frame direction that stands along its stable "
                 "pose's axis (static)",
    "base": "-> transform of the robot root",
    "same": "(entity, entity) -> bool, static identity",
    # boxes
    "box": "(lower, upper) -> box", "grow": "(box, dx, dy, dz) -> box", "lower": "",
    "upper": "", "center": "", "inside": "(vec3, box) -> bool",
    # comparisons and logic (-> bool)
    "le": "", "lt": "", "ge": "", "gt": "", "eq": "",
    "and": "", "or": "", "not": "", "implies": "",
    # a legacy distance function used as a condition: holds iff d <= tol, distance max(d, 0)
    "holds": "scalar distance -> bool",
    # a legacy Lua predicate tracing could not capture, evaluated directly on the host:
    # (Const(key), entity...) -> bool; ``key`` names its LuaFallback in the kernel's registry
    # (CompiledProgram.lua_fallbacks), so the IR stays hashable and printable. Holds iff the
    # fallback's distance <= tol; the distance is the fallback's.
    "lua": "(Const(key), entity, ...) -> bool, a Lua function called on the host",
}

COMPARISONS = ("le", "lt", "ge", "gt", "eq")
LOGIC = ("and", "or", "not", "implies")


def op(name: str, args, vtype: str) -> Op:
    if name not in OPS:
        raise ValueError(f"unknown IR operator {name!r}")
    return Op(name, tuple(args), vtype)


def walk(node: Node):
    """All nodes of a tree, parents before children (shared subtrees once)."""
    seen, stack = set(), [node]
    while stack:
        n = stack.pop()
        if n in seen:
            continue
        seen.add(n)
        yield n
        if isinstance(n, Op):
            stack.extend(n.args)
        elif isinstance(n, If):
            stack.extend((n.cond, n.then, n.orelse))
        elif isinstance(n, Quant):
            stack.append(n.body)


def entities_used(node: Node) -> set[str]:
    return {n.name for n in walk(node) if isinstance(n, Entity)}


def joints_used(node: Node) -> set[str]:
    return {n.name for n in walk(node) if isinstance(n, Joint)}


def show(node: Node) -> str:
    """A compact s-expression form, for messages and tests."""
    if isinstance(node, Const):
        return repr(node.value)
    if isinstance(node, Arg):
        return f"$arg{node.index}"
    if isinstance(node, Var):
        return f"$v{node.slot}"
    if isinstance(node, Entity):
        return node.name
    if isinstance(node, Joint):
        return f"(joint {node.name})"
    if isinstance(node, If):
        return f"(if {show(node.cond)} {show(node.then)} {show(node.orelse)})"
    if isinstance(node, Quant):
        return f"({node.kind} $v{node.slot}:{'|'.join(node.domain)} {show(node.body)})"
    return "(" + " ".join([node.op, *(show(a) for a in node.args)]) + ")"
