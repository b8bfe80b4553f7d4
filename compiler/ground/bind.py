"""Parameter bindings of a schema (action or derived rule): typed domains, counting, enumeration.

Each parameter ranges over the objects of its type (any alternative of an ``either``), narrowed by
the schema's unary static conditions (``(depot ?d)`` in an untyped domain). The number of bindings
is counted, and checked against the limit, before anything is built: when the product of the
domain sizes is over the limit, :func:`count_joined` counts the bindings that survive a join over
the top-level static literals (``(adjacent ?from ?to)``, ``(successor ?n1 ?n0)``), so only a
schema whose *joined* bindings are over the limit is rejected.

Enumeration is a backtracking join (:class:`Join`). The schema's top-level positive literals (its
*anchors*) must hold in the :class:`FactIndex` — the static facts plus the fluent atoms reached so
far — so parameters are bound anchor by anchor, most-bound anchor first (then the one with fewest
facts), parameters no anchor mentions last; the candidates for a parameter are read off hash
indexes of the facts given the parameters bound before it, and every anchor, negative static
literal and equality is tested as soon as its parameters are bound. The join yields bindings in
its own order; the caller sorts them (ids are positional).
Bindings that fail a static precondition, or need an atom not reached yet, are never built.
"""

from __future__ import annotations

import math
from typing import Callable, Iterator

from tmpc.compiler.ground.lift import LEq, LFormula, LLit, top_conjuncts

Check = Callable[[list], bool]
Fact = tuple[str, tuple[str, ...]]


_NONE: frozenset = frozenset()


class FactIndex:
    """True facts (static, and fluent atoms once reached) by predicate, plus hash indexes built
    on demand: for a predicate, a set of bound argument positions and the positions of a wanted
    value, a dict from the bound arguments' objects to the values that occur with them."""

    def __init__(self, facts=()):
        self.facts: set[Fact] = set()
        self.by_pred: dict[str, list[tuple[str, ...]]] = {}
        self._tables: dict[tuple, dict[tuple[str, ...], set[str]]] = {}
        self._tables_of: dict[str, list[tuple]] = {}
        for f in facts:
            self.add(f)

    def add(self, fact: Fact) -> None:
        if fact in self.facts:
            return
        self.facts.add(fact)
        pred, args = fact
        self.by_pred.setdefault(pred, []).append(args)
        for key in self._tables_of.get(pred, ()):
            _file(self._tables[key], key[1], key[2], args)

    def values(self, pred: str, pattern: tuple, positions: list[int]):
        """Objects ``o`` such that some fact ``pred(args)`` matches ``pattern`` (an object key
        where fixed, None where free) and has ``o`` at every index in ``positions``. The set
        returned belongs to the index: do not change it."""
        fixed = tuple(i for i, v in enumerate(pattern) if v is not None)
        key = (pred, fixed, tuple(positions))
        table = self._tables.get(key)
        if table is None:
            table = self._tables[key] = {}
            self._tables_of.setdefault(pred, []).append(key)
            for args in self.by_pred.get(pred, ()):
                _file(table, fixed, key[2], args)
        return table.get(tuple(pattern[i] for i in fixed), _NONE)


def _file(table: dict, fixed: tuple[int, ...], positions: tuple[int, ...], args) -> None:
    first = args[positions[0]]
    if all(args[j] == first for j in positions[1:]):
        table.setdefault(tuple(args[i] for i in fixed), set()).add(first)


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


def checks(pre: LFormula, index: FactIndex, static: set[str],
           indexed: set[str]) -> list[tuple[tuple[int, ...], Check]]:
    """Tests with the parameters they read: positive literals must be in the index, negative
    static ones not; equalities hold. :func:`bindings` runs each once its parameters are bound."""
    out: list[tuple[tuple[int, ...], Check]] = []
    for lit in top_conjuncts(pre):
        if isinstance(lit, LEq):
            args = (lit.left, lit.right)
        elif isinstance(lit, LLit) and (lit.pred in static or
                                        (lit.positive and lit.pred in indexed)):
            args = lit.args
        else:
            continue
        out.append((tuple(a for a in args if isinstance(a, int)), _check(lit, index.facts)))
    return out


def join_order(n: int, joins: list[LLit], index: FactIndex) -> list[int]:
    """The order parameters are bound in: anchors most-bound first (then fewest facts), each
    contributing its unbound parameters; parameters no anchor mentions last."""
    order: list[int] = []
    bound: set[int] = set()
    rest = list(joins)
    while True:
        rest = [x for x in rest if any(type(a) is int and a not in bound for a in x.args)]
        if not rest:
            break
        best = min(rest, key=lambda x: (-sum(1 for a in x.args if type(a) is int and a in bound),
                                        len(index.by_pred.get(x.pred, ()))))
        for a in best.args:
            if type(a) is int and a not in bound:
                bound.add(a)
                order.append(a)
    return order + [k for k in range(n) if k not in bound]


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


class _Stop(Exception):
    pass


def count_joined(domains: list[list[str]], pre: LFormula, index: FactIndex, static: set[str],
                 cap: int) -> tuple[int, bool]:
    """The bindings of ``domains`` that satisfy the top-level static literals and equalities of
    ``pre``: ``(count, True)`` exactly, or ``(n, False)`` with ``n > cap`` once counting passes
    ``cap`` (it stops there).

    A join: the positive static literals are taken most-bound first (then fewest facts), each
    binding its parameters from the index given those bound before; parameters no static literal
    mentions come last and, when no test involves them, are multiplied in rather than enumerated.
    """
    n = len(domains)
    lits = [x for x in top_conjuncts(pre)
            if (isinstance(x, LLit) and x.pred in static) or isinstance(x, LEq)]
    pos = [x for x in lits if isinstance(x, LLit) and x.positive]
    order = join_order(n, pos, index)
    mentioned = {a for x in pos for a in x.args if type(a) is int}
    joined = sum(1 for k in order if k in mentioned)
    depth = {k: d for d, k in enumerate(order)}

    def at(args) -> int:
        return max((depth[a] + 1 for a in args if type(a) is int), default=0)

    tests: list[list[Check]] = [[] for _ in range(n + 1)]
    for x in lits:
        args = (x.left, x.right) if isinstance(x, LEq) else x.args
        tests[at(args)].append(_check(x, index.facts))
    per_depth = [[(x, [i for i, a in enumerate(x.args) if a == k]) for x in pos if k in x.args]
                 for k in order]
    b: list = [None] * n
    if not all(c(b) for c in tests[0]):
        return 0, True
    # free parameters no test involves are multiplied in
    tail = n
    while tail > joined and not tests[tail]:
        tail -= 1
    factor = math.prod(len(domains[k]) for k in order[tail:])
    if factor == 0 or tail == 0:
        return factor, True
    total = 0
    sets = [set(d) for d in domains]

    def rec(d: int) -> None:
        nonlocal total
        if d == tail:
            total += factor
            if total > cap:
                raise _Stop
            return
        k = order[d]
        cand = None
        for lit, positions in per_depth[d]:
            pattern = tuple(None if type(a) is int and depth[a] >= d else
                            b[a] if type(a) is int else a for a in lit.args)
            vals = index.values(lit.pred, pattern, positions)
            cand = vals if cand is None else cand & vals
            if not cand:
                return
        cand = domains[k] if cand is None else [o for o in cand if o in sets[k]]
        here = tests[d + 1]
        for o in cand:
            b[k] = o
            if all(c(b) for c in here):
                rec(d + 1)
        b[k] = None

    try:
        rec(0)
    except _Stop:
        return total, False
    return total, True


class Join:
    """The bindings of one schema (a tuple of object keys each) whose anchors ``joins`` are in
    ``index`` and that pass ``tests``. The parameter order (:func:`join_order`, from the index
    as it is when the join is made) is fixed; :meth:`run` enumerates against the index as it is
    then. Bindings come in no particular order (callers sort them)."""

    def __init__(self, domains: list[list[str]], tests: list[tuple[tuple[int, ...], Check]],
                 joins: list[LLit], index: FactIndex):
        n = self.n = len(domains)
        self.domains, self.index = domains, index
        self.order = order = join_order(n, joins, index)
        self.depth = depth = {k: d for d, k in enumerate(order)}
        self.here: list[list[Check]] = [[] for _ in range(n + 1)]
        for params, c in tests:
            self.here[max((depth[k] + 1 for k in params), default=0)].append(c)
        self.sets = [set(d) for d in domains]
        self.per_depth = [[(a.pred, [i for i, x in enumerate(a.args) if x == k],
                            [(x, type(x) is int and depth[x] >= d) for x in a.args])
                           for a in joins if k in a.args] for d, k in enumerate(order)]

    def run(self) -> Iterator[tuple[str, ...]]:
        n, order, here, index = self.n, self.order, self.here, self.index
        b: list = [None] * n
        if not all(c(b) for c in here[0]):
            return

        def candidates(d: int, k: int):
            cand = None
            for pred, positions, args in self.per_depth[d]:
                pattern = tuple(None if free else b[x] if type(x) is int else x
                                for x, free in args)
                vals = index.values(pred, pattern, positions)
                cand = vals if cand is None else cand & vals
                if not cand:
                    return ()
            if cand is None:
                return self.domains[k]
            dom = self.sets[k]
            return [o for o in cand if o in dom]

        def rec(d: int):
            if d == n:
                yield tuple(b)
                return
            k = order[d]
            tests_here = here[d + 1]
            for o in candidates(d, k):
                b[k] = o
                if all(c(b) for c in tests_here):
                    yield from rec(d + 1)
            b[k] = None

        yield from rec(0)


def bindings(domains: list[list[str]], tests: list[tuple[tuple[int, ...], Check]],
             joins: list[LLit], index: FactIndex) -> Iterator[tuple[str, ...]]:
    """:class:`Join` made and run once."""
    return Join(domains, tests, joins, index).run()
