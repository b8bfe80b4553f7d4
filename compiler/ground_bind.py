"""Parameter bindings of a schema (action or derived rule): typed domains, counting, enumeration.

Each parameter ranges over the objects of its type (any alternative of an ``either``), narrowed by
the schema's unary static conditions (``(depot ?d)`` in an untyped domain). The number of bindings
is the product of these domain sizes; it is counted, and checked against the limit, before
anything is built.

Enumeration is a backtracking join. The schema's top-level positive literals (its *anchors*) must
hold in the :class:`FactIndex` — the static facts plus the fluent atoms reached so far — so the
candidates for a parameter are read off the index given the parameters bound before it, and
every anchor, negative static literal and equality is tested as soon as its parameters are bound.
Bindings that fail a static precondition, or need an atom not reached yet, are never built.
"""

from __future__ import annotations

import math
from typing import Callable, Iterator

from .ground_lift import LEq, LFormula, LLit, top_conjuncts

Check = Callable[[list], bool]
Fact = tuple[str, tuple[str, ...]]


class FactIndex:
    """True facts (static, and fluent atoms once reached) by predicate and argument position."""

    def __init__(self, facts=()):
        self.facts: set[Fact] = set()
        self.by_pos: dict[tuple[str, int, str], list[tuple[str, ...]]] = {}
        self.by_pred: dict[str, list[tuple[str, ...]]] = {}
        for f in facts:
            self.add(f)

    def add(self, fact: Fact) -> None:
        if fact in self.facts:
            return
        self.facts.add(fact)
        pred, args = fact
        self.by_pred.setdefault(pred, []).append(args)
        for i, a in enumerate(args):
            self.by_pos.setdefault((pred, i, a), []).append(args)

    def values(self, pred: str, pattern: tuple, positions: list[int]) -> set[str]:
        """Objects ``o`` such that some fact ``pred(args)`` matches ``pattern`` (an object key
        where fixed, None where free) and has ``o`` at every index in ``positions``."""
        fixed = [(i, v) for i, v in enumerate(pattern) if v is not None]
        if fixed:
            rows = min((self.by_pos.get((pred, i, v), ()) for i, v in fixed), key=len)
        else:
            rows = self.by_pred.get(pred, ())
        first, rest = positions[0], positions[1:]
        return {r[first] for r in rows
                if all(r[i] == v for i, v in fixed) and all(r[j] == r[first] for j in rest)}


def _max_param(args) -> int:
    return max((a for a in args if isinstance(a, int)), default=-1)


def _resolver(args):
    """A function binding -> object tuple for a lifted argument tuple."""
    return lambda b: tuple(b[a] if type(a) is int else a for a in args)


def _check(lit, facts: set) -> Check:
    if isinstance(lit, LEq):
        left, right, pos = lit.left, lit.right, lit.positive
        get_l = (lambda b: b[left]) if isinstance(left, int) else (lambda b: left)
        get_r = (lambda b: b[right]) if isinstance(right, int) else (lambda b: right)
        return lambda b: (get_l(b) == get_r(b)) == pos
    resolve, key, pos = _resolver(lit.args), lit.pred, lit.positive
    return lambda b: ((key, resolve(b)) in facts) == pos


def anchors(pre: LFormula, indexed: set[str]) -> list[LLit]:
    """Top-level positive literals of predicates in ``indexed`` (static, fluent, derived)."""
    return [lit for lit in top_conjuncts(pre)
            if isinstance(lit, LLit) and lit.positive and lit.pred in indexed]


def checks(pre: LFormula, index: FactIndex, static: set[str], indexed: set[str],
           n: int) -> list[list[Check]]:
    """Tests by depth: ``out[k+1]`` runs once parameter ``k`` is bound, ``out[0]`` before any.
    Positive literals must be in the index, negative static ones not; equalities hold."""
    out: list[list[Check]] = [[] for _ in range(n + 1)]
    for lit in top_conjuncts(pre):
        if isinstance(lit, LEq):
            out[_max_param((lit.left, lit.right)) + 1].append(_check(lit, index.facts))
        elif isinstance(lit, LLit) and (lit.pred in static or
                                        (lit.positive and lit.pred in indexed)):
            out[_max_param(lit.args) + 1].append(_check(lit, index.facts))
    return out


def narrow(domains: list[list[str]], pre: LFormula, index: FactIndex,
           static: set[str]) -> list[list[str]]:
    """Apply unary positive static conjuncts ``(p ?x)`` to the domain of ``?x``."""
    out = [list(d) for d in domains]
    for lit in top_conjuncts(pre):
        if isinstance(lit, LLit) and lit.positive and lit.pred in static \
                and len(lit.args) == 1 and isinstance(lit.args[0], int):
            i = lit.args[0]
            out[i] = [o for o in out[i] if (lit.pred, (o,)) in index.facts]
    return out


def count(domains: list[list[str]]) -> int:
    return math.prod(len(d) for d in domains)


def bindings(domains: list[list[str]], tests: list[list[Check]], joins: list[LLit],
             index: FactIndex) -> Iterator[tuple[str, ...]]:
    """Every binding (a tuple of object keys) whose anchors ``joins`` are in ``index`` and that
    passes ``tests``; in domain order."""
    n = len(domains)
    b: list = [None] * n
    if not all(c(b) for c in tests[0]):
        return
    per_param = [[(a, [i for i, x in enumerate(a.args) if x == k]) for a in joins if k in a.args]
                 for k in range(n)]

    def candidates(k: int) -> list[str]:
        cand = domains[k]
        for lit, positions in per_param[k]:
            pattern = tuple(None if type(x) is int and x >= k else
                            b[x] if type(x) is int else x for x in lit.args)
            vals = index.values(lit.pred, pattern, positions)
            cand = [o for o in cand if o in vals]
            if not cand:
                break
        return cand

    def rec(k: int):
        if k == n:
            yield tuple(b)
            return
        here = tests[k + 1]
        for o in candidates(k):
            b[k] = o
            if all(c(b) for c in here):
                yield from rec(k + 1)

    yield from rec(0)
