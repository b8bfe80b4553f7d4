"""Derived predicates: stratification of the rules and evaluation of ground axioms.

A ground :class:`Axiom` says ``head`` holds when ``body`` does (several axioms may share a head:
one per rule and binding). Derived atoms are bits of the state like any other, but never set by
an effect: :meth:`DerivedEvaluator.__call__` clears them and recomputes them, stratum by stratum.

Stratification is per predicate: a rule whose body uses a derived predicate positively puts the
head in the same or a higher stratum, negatively in a strictly higher one. Within a stratum the
bodies are monotone in that stratum's atoms, so a least fixpoint exists. It is computed like
Datalog: a body with a small DNF becomes one rule per disjunct; a rule whose literals on *other*
atoms (base atoms, lower strata, geometry) hold is active and waits for its same-stratum atoms,
counted down as they become true. Other bodies are re-evaluated when a watched atom turns true.
"""

from __future__ import annotations

from dataclasses import dataclass

from tmpc.compiler.ground.formula import (
    Evaluator,
    GAtom,
    GeoOracle,
    GFormula,
    GGeo,
    GNot,
    atom_ids,
    compile_formula,
    holds,
    small_dnf,
)
from tmpc.compiler.ground.lift import LFormula, LLit, literals


@dataclass(frozen=True)
class Axiom:
    """``head`` (an atom id) is derived when ``body`` holds; ``stratum`` orders evaluation."""

    head: int
    body: GFormula
    stratum: int


def stratify(rules: dict[str, list[LFormula]]) -> tuple[dict[str, int], str | None]:
    """Stratum per derived predicate key; second item: a predicate on a cycle through negation
    (then the strata are meaningless)."""
    edges = []  # (body pred, head pred, strict)
    for head, bodies in rules.items():
        for body in bodies:
            for lit in literals(body):
                if isinstance(lit, LLit) and lit.pred in rules:
                    edges.append((lit.pred, head, not lit.positive))
    strata = {p: 0 for p in rules}
    changed = True
    while changed:
        changed = False
        for q, p, strict in edges:
            need = strata[q] + (1 if strict else 0)
            if strata[p] < need:
                strata[p] = need
                changed = True
                if need > len(rules):
                    return strata, p
    return strata, None


@dataclass(frozen=True, slots=True)
class _Rule:
    """One disjunct of an axiom body. Its literals on atoms outside the stratum: ``pos``/``neg``
    masks and geometric literals ``geo``; ``waits``: the same-stratum atoms it needs."""

    head: int
    pos: int
    neg: int
    geo: tuple
    waits: tuple[int, ...]

    def active(self, state: int, oracle: GeoOracle | None) -> bool:
        if state & self.pos != self.pos or state & self.neg:
            return False
        return oracle is None or all(holds(g, state, oracle) for g in self.geo)


class _Stratum:
    def __init__(self, axioms: list[Axiom]):
        heads = {a.head for a in axioms}
        self.rules: list[_Rule] = []
        #: axioms without a small DNF, with a compiled body
        self.generic: list[tuple[Axiom, Evaluator]] = []
        for a in axioms:
            disjuncts = small_dnf(a.body)
            if disjuncts is None:
                self.generic.append((a, compile_formula(a.body)))
                continue
            for lits in disjuncts:
                pos = {x.id for x in lits if isinstance(x, GAtom)}
                neg = {x.part.id for x in lits if isinstance(x, GNot) and
                       isinstance(x.part, GAtom)}
                geo = tuple(x for x in lits if isinstance(x, GGeo) or
                            (isinstance(x, GNot) and isinstance(x.part, GGeo)))
                self.rules.append(_Rule(a.head, _mask(pos - heads), _mask(neg), geo,
                                        tuple(sorted(pos & heads))))
        self.rule_watch: dict[int, list[int]] = {}
        for k, r in enumerate(self.rules):
            for i in r.waits:
                self.rule_watch.setdefault(i, []).append(k)
        self.watch: dict[int, list[tuple[Axiom, Evaluator]]] = {}
        for a, ev in self.generic:
            for i in set(atom_ids(a.body, positive_only=True)) & heads:
                self.watch.setdefault(i, []).append((a, ev))

    def run(self, state: int, geo: GeoOracle | None) -> int:
        missing: dict[int, int] = {}
        ready = []
        for k, r in enumerate(self.rules):
            if r.active(state, geo):
                if r.waits:
                    missing[k] = len(r.waits)
                else:
                    ready.append(r.head)
        ready += [a.head for a, ev in self.generic if ev(state, geo)]
        queue = []
        for h in ready:
            if not (state >> h) & 1:
                state |= 1 << h
                queue.append(h)
        while queue:
            h = queue.pop()
            for k in self.rule_watch.get(h, ()):
                if k in missing:
                    missing[k] -= 1
                    if missing[k] == 0 and not (state >> self.rules[k].head) & 1:
                        state |= 1 << self.rules[k].head
                        queue.append(self.rules[k].head)
            for a, ev in self.watch.get(h, ()):
                if not (state >> a.head) & 1 and ev(state, geo):
                    state |= 1 << a.head
                    queue.append(a.head)
        return state


class DerivedEvaluator:
    """Recomputes the derived bits of a state from the axioms."""

    def __init__(self, axioms: tuple[Axiom, ...], derived_ids: frozenset[int]):
        self.mask = sum(1 << i for i in derived_ids)
        self.strata = [_Stratum([a for a in axioms if a.stratum == s])
                       for s in sorted({a.stratum for a in axioms})]

    def __call__(self, state: int, geo: GeoOracle | None = None) -> int:
        state &= ~self.mask
        for stratum in self.strata:
            state = stratum.run(state, geo)
        return state


def _mask(ids) -> int:
    return sum(1 << i for i in ids)
