"""Lifted normal forms: action preconditions, effects and derived-rule bodies, ready to ground.

A lifted formula (:data:`LFormula`) is in negation normal form with quantifiers already expanded
over the typed objects of the problem and ``imply`` rewritten: only :class:`LAnd`, :class:`LOr`,
literals (:class:`LLit`, :class:`LEq`, :class:`LCmp`, each with a polarity) and the constants.
A term is an ``int`` (index of a schema parameter, bound at grounding) or a ``str`` (an object key).

Effects flatten to :class:`LEffect` entries (condition, literal) and :class:`LNumEffect` entries;
``forall`` effects are expanded, nested ``when`` conditions conjoined.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Union

from tmpc.lang import ast as A
from tmpc.lang.scope import type_keys as keys

Term = Union[int, str]


@dataclass(frozen=True, slots=True)
class LConst:
    value: bool


LTRUE, LFALSE = LConst(True), LConst(False)


@dataclass(frozen=True, slots=True)
class LLit:
    """``(pred args...)`` or its negation; ``pred`` is the predicate key."""

    pred: str
    args: tuple[Term, ...]
    positive: bool


@dataclass(frozen=True, slots=True)
class LEq:
    left: Term
    right: Term
    positive: bool


@dataclass(frozen=True, slots=True)
class LCmp:
    """A numeric comparison; ``left``/``right`` are lifted numeric expressions (see :func:`num`)."""

    op: str
    left: tuple
    right: tuple
    positive: bool


@dataclass(frozen=True, slots=True)
class LAnd:
    parts: tuple["LFormula", ...]


@dataclass(frozen=True, slots=True)
class LOr:
    parts: tuple["LFormula", ...]


LFormula = Union[LConst, LLit, LEq, LCmp, LAnd, LOr]


@dataclass(frozen=True, slots=True)
class LEffect:
    """One add (``positive``) or delete of ``pred(args)`` under ``condition``."""

    condition: LFormula
    pred: str
    args: tuple[Term, ...]
    positive: bool


@dataclass(frozen=True, slots=True)
class LNumEffect:
    op: str
    target: tuple          # ("f", key, args)
    value: tuple
    condition: LFormula
    span: object


class ExpansionTooLarge(Exception):
    """A quantifier expansion grew past the limit; ``where`` is the quantifier's span."""

    def __init__(self, where, size: int):
        super().__init__(size)
        self.where, self.size = where, size


def land(parts) -> LFormula:
    out = []
    for p in parts:
        if p == LTRUE:
            continue
        if p == LFALSE:
            return LFALSE
        out.extend(p.parts if isinstance(p, LAnd) else (p,))
    return LTRUE if not out else out[0] if len(out) == 1 else LAnd(tuple(out))


def lor(parts) -> LFormula:
    out = []
    for p in parts:
        if p == LFALSE:
            continue
        if p == LTRUE:
            return LTRUE
        out.extend(p.parts if isinstance(p, LOr) else (p,))
    return LFALSE if not out else out[0] if len(out) == 1 else LOr(tuple(out))


def size(f: LFormula) -> int:
    return 1 + sum(size(p) for p in f.parts) if isinstance(f, (LAnd, LOr)) else 1


class Lifter:
    """Turns AST formulas/effects into lifted normal forms.

    ``objects_of(type_keys)`` lists the object keys a quantified variable ranges over;
    ``limit`` bounds the size of any one expanded formula (:class:`ExpansionTooLarge`).
    """

    def __init__(self, objects_of: Callable[[tuple[str, ...]], list[str]], limit: int):
        self.objects_of, self.limit = objects_of, limit

    # ---- formulas ---------------------------------------------------------------------------
    def formula(self, f: A.Formula | None, env: dict[str, Term], negated: bool = False) -> LFormula:
        if f is None:
            return LTRUE
        if isinstance(f, A.Atom):
            return LLit(f.pred.key, tuple(term(t, env) for t in f.args), not negated)
        if isinstance(f, A.Equals):
            left, right = term(f.left, env), term(f.right, env)
            if isinstance(left, str) and isinstance(right, str):
                return LConst((left == right) != negated)
            return LEq(left, right, not negated)
        if isinstance(f, A.Compare):
            return LCmp(f.op, num(f.left, env), num(f.right, env), not negated)
        if isinstance(f, A.Not):
            return self.formula(f.part, env, not negated)
        if isinstance(f, (A.And, A.Or)):
            parts = [self.formula(p, env, negated) for p in f.parts]
            return land(parts) if isinstance(f, A.And) != negated else lor(parts)
        if isinstance(f, A.Imply):   # (imply l r) == (or (not l) r)
            parts = [self.formula(f.left, env, not negated), self.formula(f.right, env, negated)]
            return lor(parts) if not negated else land(parts)
        if isinstance(f, A.Quantified):
            return self.quantified(f, env, negated)
        raise TypeError(f"not a formula: {f!r}")

    def quantified(self, f: A.Quantified, env: dict[str, Term], negated: bool) -> LFormula:
        universal = (f.kind == "forall") != negated
        parts = []
        total = 0
        for inner in self.envs(f.params, env):
            part = self.formula(f.body, inner, negated)
            total += size(part)
            if total > self.limit:
                raise ExpansionTooLarge(f.span, total)
            parts.append(part)
        return land(parts) if universal else lor(parts)

    def envs(self, params: tuple[A.Typed, ...], env: dict[str, Term]):
        """Every extension of ``env`` binding ``params`` to typed objects."""
        if not params:
            yield env
            return
        first, rest = params[0], params[1:]
        for obj in self.objects_of(type_keys(first)):
            inner = dict(env)
            inner[first.name.key] = obj
            yield from self.envs(rest, inner)

    # ---- effects ----------------------------------------------------------------------------
    def effect(self, e: A.Effect | None, env: dict[str, Term], cond: LFormula = LTRUE,
               out: list | None = None, nums: list | None = None):
        """Flatten ``e``: returns (list of :class:`LEffect`, list of :class:`LNumEffect`)."""
        out = [] if out is None else out
        nums = [] if nums is None else nums
        if e is None:
            pass
        elif isinstance(e, A.AndEffect):
            for p in e.parts:
                self.effect(p, env, cond, out, nums)
        elif isinstance(e, (A.AddEffect, A.DelEffect)):
            out.append(LEffect(cond, e.atom.pred.key, tuple(term(t, env) for t in e.atom.args),
                               isinstance(e, A.AddEffect)))
        elif isinstance(e, A.ForallEffect):
            for inner in self.envs(e.params, env):
                self.effect(e.body, inner, cond, out, nums)
                if len(out) > self.limit:
                    raise ExpansionTooLarge(e.span, len(out))
        elif isinstance(e, A.WhenEffect):
            inner = land([cond, self.formula(e.condition, env)])
            if inner != LFALSE:
                self.effect(e.body, env, inner, out, nums)
        elif isinstance(e, A.NumericEffect):
            nums.append(LNumEffect(e.op, num(e.target, env), num(e.value, env), cond, e.span))
        return out, nums


def type_keys(t: A.Typed) -> tuple[str, ...]:
    return keys(t.type)


def term(t: A.Term, env: dict[str, Term]) -> Term:
    if isinstance(t, A.Var):
        return env[t.name.key]
    return t.name.key


def num(e: A.NumExpr, env: dict[str, Term]) -> tuple:
    """A lifted numeric expression: ``("n", value)``, ``("f", key, args)``, ``("op", op, parts)``."""
    if isinstance(e, A.Num):
        return ("n", e.value)
    if isinstance(e, A.FuncTerm):
        return ("f", e.name.key, tuple(term(t, env) for t in e.args))
    return ("op", e.op, tuple(num(a, env) for a in e.args))


def literals(f: LFormula):
    """Every literal of ``f`` (LLit, LEq, LCmp)."""
    if isinstance(f, (LAnd, LOr)):
        for p in f.parts:
            yield from literals(p)
    elif not isinstance(f, LConst):
        yield f


def top_conjuncts(f: LFormula) -> tuple[LFormula, ...]:
    return f.parts if isinstance(f, LAnd) else () if f == LTRUE else (f,)
