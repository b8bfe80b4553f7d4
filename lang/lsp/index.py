"""Every name in a program and what it refers to: the index behind hover, go to definition,
references, rename and semantic tokens.

An :class:`Occurrence` is one spelling of a name in a file: its kind (``predicate``, ``type``,
``object``, ``action``, ``helper``, ``function``, ``parameter``, ``domain``), its key (PDDL names
are case-insensitive), its span, whether it defines the name, and for parameters the scope that
binds it. Two occurrences with the same :attr:`Occurrence.target` are the same symbol.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import count

from tmpc.lang import ast as A
from tmpc.lang.program import Program
from tmpc.lang.source import Span
from tmpc.lang.symbols import BUILTINS, EXPR_SPECIAL_FORMS, NUMBER_CONSTANTS


@dataclass(frozen=True)
class Occurrence:
    kind: str
    key: str
    span: Span
    definition: bool = False
    #: the binding scope of a parameter (0 for global names)
    scope: int = 0
    #: the declaration node (PredicateDecl, Action, Typed, ...) for definitions
    node: object = field(default=None, compare=False, hash=False)

    @property
    def target(self) -> tuple[str, str, int]:
        return self.kind, self.key, self.scope


@dataclass
class Index:
    occurrences: list[Occurrence] = field(default_factory=list)
    #: predicate key -> declaration (for kinds and hovers)
    predicates: dict[str, A.PredicateDecl] = field(default_factory=dict)
    programs: list[Program] = field(default_factory=list)

    def at(self, path: str, offset: int) -> Occurrence | None:
        """The innermost occurrence at ``offset`` (a cursor just after a name counts)."""
        best = None
        for o in self.occurrences:
            if o.span.path == path and o.span.start <= offset <= o.span.end:
                if best is None or o.span.end - o.span.start < best.span.end - best.span.start:
                    best = o
        return best

    def definitions(self, occ: Occurrence) -> list[Occurrence]:
        return [o for o in self.occurrences if o.definition and o.target == occ.target]

    def references(self, occ: Occurrence) -> list[Occurrence]:
        seen, out = set(), []
        for o in self.occurrences:
            if o.target == occ.target and (o.span.path, o.span.start) not in seen:
                seen.add((o.span.path, o.span.start))
                out.append(o)
        return out

    def in_file(self, path: str) -> list[Occurrence]:
        return sorted((o for o in self.occurrences if o.span.path == path),
                      key=lambda o: o.span.start)


def build_index(programs: list[Program]) -> Index:
    idx = Index(programs=list(programs))
    w = _Walker(idx)
    seen: set[int] = set()
    for prog in programs:
        for d in (*prog.modules, prog.domain):
            if id(d) not in seen:
                seen.add(id(d))
                w.domain(d)
        if prog.problem is not None and id(prog.problem) not in seen:
            seen.add(id(prog.problem))
            w.problem(prog.problem)
    resolve_calls(idx)
    return idx


class _Walker:
    def __init__(self, idx: Index):
        self.idx = idx
        self._scopes = count(1)

    def add(self, kind: str, name: A.Name | None, definition: bool = False, scope: int = 0,
            node=None) -> None:
        if name is None or name.span is None:
            return
        self.idx.occurrences.append(Occurrence(kind, name.key, name.span, definition, scope,
                                               node))

    # ---- declarations ------------------------------------------------------------------------
    def domain(self, d: A.Domain) -> None:
        self.add("domain", d.name, True, node=d)
        for t in d.types:
            self.add("type", t.name, True, node=t)
            self.typeref(t.parent)
        for c in d.constants:
            self.add("object", c.name, True, node=c)
            self.typeref(c.type)
        for p in d.predicates:
            self.idx.predicates.setdefault(p.name.key, p)
            self.add("predicate", p.name, True, node=p)
            env = self.params(p.params)
            if p.kinematic is not None:
                for n in (p.kinematic.parent, p.kinematic.child):
                    self.var(n, env)
            if p.semantics is not None:
                self.expr(p.semantics, env)
        for f in d.functions:
            self.add("function", f.name, True, node=f)
            self.params(f.params)
        for h in d.defines:
            self.add("helper", h.name, True, node=h)
            self.expr(h.body, self.params(h.params))
        for a in d.actions:
            self.add("action", a.name, True, node=a)
            env = self.params(a.params)
            self.formula(a.precondition, env)
            self.effect(a.effect, env)
        for der in d.derived:
            self.add("predicate", der.name)
            self.formula(der.body, self.params(der.params))

    def problem(self, p: A.Problem) -> None:
        self.add("domain", p.domain_name)
        for o in p.objects:
            self.add("object", o.name, True, node=o)
            self.typeref(o.type)
        for item in p.init:
            if isinstance(item, A.NumericInit):
                self.add("function", item.target.name)
                for t in item.target.args:
                    self.term(t, {})
            else:
                self.formula(item, {})
        self.formula(p.goal, {})

    def typeref(self, t: A.TypeRef | None) -> None:
        if t is not None:
            for n in t.names:
                self.add("type", n)

    def params(self, params: tuple[A.Typed, ...], env: dict | None = None) -> dict:
        scope = next(self._scopes)
        env = dict(env or {})
        for p in params:
            env[p.name.key] = scope
            self.add("parameter", p.name, True, scope, node=p)
            self.typeref(p.type)
        return env

    def var(self, name: A.Name, env: dict) -> None:
        self.add("parameter", name, False, env.get(name.key, -1))

    # ---- formulas ----------------------------------------------------------------------------
    def term(self, t, env: dict) -> None:
        if isinstance(t, A.Var):
            self.var(t.name, env)
        elif isinstance(t, A.Const):
            self.add("object", t.name)

    def formula(self, f, env: dict) -> None:
        if f is None:
            return
        if isinstance(f, A.Atom):
            self.add("predicate", f.pred)
            for t in f.args:
                self.term(t, env)
        elif isinstance(f, A.Equals):
            self.term(f.left, env)
            self.term(f.right, env)
        elif isinstance(f, A.Compare):
            self.num(f.left, env)
            self.num(f.right, env)
        elif isinstance(f, (A.And, A.Or)):
            for x in f.parts:
                self.formula(x, env)
        elif isinstance(f, A.Not):
            self.formula(f.part, env)
        elif isinstance(f, A.Imply):
            self.formula(f.left, env)
            self.formula(f.right, env)
        elif isinstance(f, A.Quantified):
            self.formula(f.body, self.params(f.params, env))

    def num(self, e, env: dict) -> None:
        if isinstance(e, A.FuncTerm):
            self.add("function", e.name)
            for t in e.args:
                self.term(t, env)
        elif isinstance(e, A.NumOp):
            for x in e.args:
                self.num(x, env)

    def effect(self, e, env: dict) -> None:
        if e is None:
            return
        if isinstance(e, A.AndEffect):
            for x in e.parts:
                self.effect(x, env)
        elif isinstance(e, (A.AddEffect, A.DelEffect)):
            self.formula(e.atom, env)
        elif isinstance(e, A.ForallEffect):
            self.effect(e.body, self.params(e.params, env))
        elif isinstance(e, A.WhenEffect):
            self.formula(e.condition, env)
            self.effect(e.body, env)
        elif isinstance(e, A.NumericEffect):
            self.num(e.target, env)
            self.num(e.value, env)

    # ---- expressions -------------------------------------------------------------------------
    def expr(self, e, env: dict) -> None:
        if isinstance(e, A.ExprVar):
            self.var(e.name, env)
        elif isinstance(e, A.ExprName):
            if e.name.key not in NUMBER_CONSTANTS:
                self.add("object", e.name)
        elif isinstance(e, A.Call):
            key = e.op.key
            if key not in BUILTINS and key not in EXPR_SPECIAL_FORMS:
                # a helper, or a geometric predicate used inside another's body
                self.add("call", e.op)
            if key == "joint":
                return                      # a joint name, not an object
            for a in e.args:
                self.expr(a, env)
        elif isinstance(e, A.Let):
            inner = dict(env)
            scope = next(self._scopes)
            for b in e.bindings:
                self.expr(b.value, inner)
                inner[b.name.key] = scope
                self.add("parameter", b.name, True, scope, node=b)
            self.expr(e.body, inner)
        elif isinstance(e, A.If):
            for x in (e.cond, e.then, e.orelse):
                self.expr(x, env)
        elif isinstance(e, A.ExprQuant):
            self.expr(e.body, self.params(e.params, env))


def resolve_calls(idx: Index) -> None:
    """A ``call`` occurrence names a helper when one is declared, else a predicate."""
    helpers = {o.key for o in idx.occurrences if o.kind == "helper" and o.definition}
    idx.occurrences = [o if o.kind != "call" else
                       Occurrence("helper" if o.key in helpers else "predicate", o.key, o.span)
                       for o in idx.occurrences]
