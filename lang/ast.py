"""The AST: frozen dataclasses, every node with a source span.

Spans are excluded from equality (``compare=False``) so two parses of the same program compare
equal however it was laid out; this is what the formatter's round-trip property checks.
Names keep the user's spelling in ``text``; PDDL identity is case-insensitive (``key``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Union

from tmpc.lang.source import Span

_SPAN = dict(compare=False, repr=False, kw_only=True, default=None)   # None: synthesized


@dataclass(frozen=True, slots=True)
class Name:
    text: str
    span: Span = field(**_SPAN)

    @property
    def key(self) -> str:
        return self.text.lower()

    def __str__(self) -> str:
        return self.text


# ---------------------------------------------------------------------------------------------
# Types and typed lists


@dataclass(frozen=True, slots=True)
class TypeRef:
    """A type: one name, or ``(either a b ...)`` with several."""

    names: tuple[Name, ...]
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Typed:
    """``name - type`` in a typed list; ``type`` is None when untyped (means ``object``)."""

    name: Name
    type: TypeRef | None
    span: Span = field(**_SPAN)


# ---------------------------------------------------------------------------------------------
# Terms and PDDL formulas


@dataclass(frozen=True, slots=True)
class Var:
    name: Name   # text includes the leading '?'
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Const:
    name: Name
    span: Span = field(**_SPAN)


Term = Union[Var, Const]


@dataclass(frozen=True, slots=True)
class Num:
    value: float
    text: str = field(compare=False)
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class FuncTerm:
    """A numeric fluent application ``(f t1 ... tn)``."""

    name: Name
    args: tuple[Term, ...]
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class NumOp:
    op: str
    args: tuple["NumExpr", ...]
    span: Span = field(**_SPAN)


NumExpr = Union[Num, FuncTerm, NumOp]


@dataclass(frozen=True, slots=True)
class Atom:
    pred: Name
    args: tuple[Term, ...]
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Equals:
    left: Term
    right: Term
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Compare:
    """Numeric comparison over fluents (PDDL 2.1)."""

    op: str
    left: NumExpr
    right: NumExpr
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class And:
    parts: tuple["Formula", ...]
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Or:
    parts: tuple["Formula", ...]
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Not:
    part: "Formula"
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Imply:
    left: "Formula"
    right: "Formula"
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Quantified:
    """``(exists (params) body)`` / ``(forall (params) body)``; ``kind`` is the keyword."""

    kind: str
    params: tuple[Typed, ...]
    body: "Formula"
    span: Span = field(**_SPAN)


Formula = Union[Atom, Equals, Compare, And, Or, Not, Imply, Quantified]


def conjuncts(f: "Formula | None") -> list["Formula"]:
    """The top-level conjuncts of ``f``, nested ``and``s flattened (none for no formula)."""
    if f is None:
        return []
    if isinstance(f, And):
        return [x for p in f.parts for x in conjuncts(p)]
    return [f]

# ---------------------------------------------------------------------------------------------
# Effects


@dataclass(frozen=True, slots=True)
class AndEffect:
    parts: tuple["Effect", ...]
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class AddEffect:
    atom: Atom
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class DelEffect:
    atom: Atom
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class ForallEffect:
    params: tuple[Typed, ...]
    body: "Effect"
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class WhenEffect:
    condition: Formula
    body: "Effect"
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class NumericEffect:
    op: str            # increase, decrease, assign, scale-up, scale-down
    target: FuncTerm
    value: NumExpr
    span: Span = field(**_SPAN)


Effect = Union[AndEffect, AddEffect, DelEffect, ForallEffect, WhenEffect, NumericEffect]

# ---------------------------------------------------------------------------------------------
# tmpc expressions (inside :semantics and :define)


@dataclass(frozen=True, slots=True)
class ExprVar:
    name: Name
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class ExprName:
    """A bare name: an object/constant, a joint name, or a named number like ``pi``."""

    name: Name
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Call:
    op: Name
    args: tuple["Expr", ...]
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Binding:
    name: Name
    value: "Expr"
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Let:
    bindings: tuple[Binding, ...]
    body: "Expr"
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class If:
    cond: "Expr"
    then: "Expr"
    orelse: "Expr"
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class ExprQuant:
    kind: str
    params: tuple[Typed, ...]
    body: "Expr"
    span: Span = field(**_SPAN)


Expr = Union[Num, ExprVar, ExprName, Call, Let, If, ExprQuant]

# ---------------------------------------------------------------------------------------------
# Declarations


class Kind(str, Enum):
    DISCRETE = "discrete"
    KINEMATIC = "kinematic"
    GEOMETRIC = "geometric"


@dataclass(frozen=True, slots=True)
class KinematicSpec:
    """``link ?parent ?child``: while the atom is true, ``child`` is rigidly attached to ``parent``."""

    parent: Name
    child: Name
    style: str = field(compare=False, default="native")   # native | planet | tmit-star
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class PredicateDecl:
    name: Name
    params: tuple[Typed, ...]
    kind: Kind
    semantics: Expr | None = None
    kinematic: KinematicSpec | None = None
    #: geometric without a body: semantics come from a same-named Lua function (legacy).
    external: bool = False
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class FunctionDecl:
    name: Name
    params: tuple[Typed, ...]
    type: Name | None
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class DefineDecl:
    """A helper ``(:define (name ?p ...) body)``, inlined at each use."""

    name: Name
    params: tuple[Typed, ...]
    body: Expr
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Include:
    module: str
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Requirement:
    name: Name
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class TypeDecl:
    name: Name
    parent: TypeRef | None
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Action:
    name: Name
    params: tuple[Typed, ...]
    precondition: Formula | None
    effect: Effect | None
    span: Span = field(**_SPAN)
    #: in a semantics module: the object the action carries (it is split into a grasp and a
    #: release, docs/language.md "Semantics modules")
    carries: "Var | None" = None


@dataclass(frozen=True, slots=True)
class Derived:
    name: Name
    params: tuple[Typed, ...]
    body: Formula
    span: Span = field(**_SPAN)


class Dialect(str, Enum):
    """How unannotated predicates are read (see docs/language.md, "Dialects")."""

    PDDL = "pddl"            # classical: every predicate is discrete
    TMPC = "tmpc"            # :requirements :tmpc
    PLANET = "planet"        # `:discrete` / `:kinematic ((link ..) (unlink ..))`; bare = Lua
    TMIT_STAR = "tmit-star"  # `(kinematic (link ..) (unlink ..))`; bare = Lua


@dataclass(frozen=True, slots=True)
class Domain:
    name: Name
    requirements: tuple[Requirement, ...] = ()
    types: tuple[TypeDecl, ...] = ()
    constants: tuple[Typed, ...] = ()
    predicates: tuple[PredicateDecl, ...] = ()
    functions: tuple[FunctionDecl, ...] = ()
    includes: tuple[Include, ...] = ()
    defines: tuple[DefineDecl, ...] = ()
    actions: tuple[Action, ...] = ()
    derived: tuple[Derived, ...] = ()
    dialect: Dialect = Dialect.PDDL
    #: "domain" for planning domains, "module" for stdlib/helper modules, "semantics" for a
    #: semantics module (meanings for a classical domain's predicates and actions)
    form: str = "domain"
    span: Span = field(**_SPAN)
    #: a semantics module's `(:domain NAME)`: the domain it gives meaning to
    target: Name | None = None
    #: a semantics module's `(:hand FRAME ...)`: the robot frames that hold (``?hand`` in the
    #: module)
    hands: tuple[Name, ...] = ()


@dataclass(frozen=True, slots=True)
class NumericInit:
    target: FuncTerm
    value: Num
    span: Span = field(**_SPAN)


InitItem = Union[Atom, Equals, NumericInit]


@dataclass(frozen=True, slots=True)
class Metric:
    direction: str
    expr: NumExpr
    span: Span = field(**_SPAN)


@dataclass(frozen=True, slots=True)
class Problem:
    name: Name
    domain_name: Name | None
    requirements: tuple[Requirement, ...] = ()
    objects: tuple[Typed, ...] = ()
    init: tuple[InitItem, ...] = ()
    goal: Formula | None = None
    metric: Metric | None = None
    span: Span = field(**_SPAN)
