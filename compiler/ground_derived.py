"""Derived predicates: stratification of the rules and evaluation of ground axioms.

A ground :class:`Axiom` says ``head`` holds when ``body`` does (several axioms may share a head:
one per rule and binding). Derived atoms are bits of the state like any other, but never set by
an effect: :meth:`DerivedEvaluator.__call__` clears them and recomputes them, stratum by stratum.

Stratification is per predicate: a rule whose body uses a derived predicate positively puts the
head in the same or a higher stratum, negatively in a strictly higher one. Within a stratum the
bodies are monotone in that stratum's atoms, so a least fixpoint exists; it is computed by one
pass over the axioms and then re-checking only axioms that watch an atom that just became true.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .ground_formula import Evaluator, GeoOracle, GFormula, atom_ids, compile_formula
from .ground_lift import LFormula, LLit, literals


@dataclass(frozen=True)
class Axiom:
    """``head`` (an atom id) is derived when ``body`` holds; ``stratum`` orders evaluation."""

    head: int
    body: GFormula
    stratum: int
    _eval: Evaluator = field(repr=False, compare=False)

    @classmethod
    def of(cls, head: int, body: GFormula, stratum: int) -> "Axiom":
        return cls(head, body, stratum, compile_formula(body))


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


class DerivedEvaluator:
    """Recomputes the derived bits of a state from the axioms."""

    def __init__(self, axioms: tuple[Axiom, ...], derived_ids: frozenset[int]):
        self.mask = sum(1 << i for i in derived_ids)
        self.strata: list[tuple[list[Axiom], dict[int, list[Axiom]]]] = []
        for s in sorted({a.stratum for a in axioms}):
            mine = [a for a in axioms if a.stratum == s]
            heads = {a.head for a in mine}
            watch: dict[int, list[Axiom]] = {}
            for a in mine:
                for i in set(atom_ids(a.body, positive_only=True)) & heads:
                    watch.setdefault(i, []).append(a)
            self.strata.append((mine, watch))

    def __call__(self, state: int, geo: GeoOracle | None = None) -> int:
        state &= ~self.mask
        for axioms, watch in self.strata:
            queue = []
            for a in axioms:
                if not (state >> a.head) & 1 and a._eval(state, geo):
                    state |= 1 << a.head
                    queue.append(a.head)
            while queue:
                for a in watch.get(queue.pop(), ()):
                    if not (state >> a.head) & 1 and a._eval(state, geo):
                        state |= 1 << a.head
                        queue.append(a.head)
        return state
