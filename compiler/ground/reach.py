"""Delete-relaxed reachability, incremental: units arrive while atoms are being reached.

A *unit* is a ground formula and the atoms it adds: an action (precondition, unconditional adds),
a conditional effect (precondition and condition, its adds) or an axiom (body, head). It *fires*
once its formula is relaxed-true — positive atoms reached; negated literals and geometric atoms
possibly true — and then reaches its adds. Units that are plain conjunctions of literals count
their missing atoms down; the others are re-evaluated when an atom they watch is reached.
"""

from __future__ import annotations

from typing import Callable

from tmpc.compiler.ground.formula import (
    GAnd,
    GFormula,
    GOr,
    atom_ids,
    conj,
    conjuncts,
    is_literal,
    relaxed_holds,
    small_dnf,
)


class Relaxed:
    """Reached atoms (``reached[i]`` for atom ``i`` of ``keys``) and fired units.

    ``on_reach(i)`` is called once for every atom as it is reached.
    """

    def __init__(self, keys: list, on_reach: Callable[[int], None]):
        self.keys, self.on_reach = keys, on_reach
        self.reached = bytearray()
        self.fired = bytearray()
        self.count = 0
        self._units: list[tuple[GFormula, list[int]]] = []
        self._simple: list[bool] = []
        self._parent: list[int] = []
        self._missing: list[int] = []
        self._watch: dict[int, list[int]] = {}
        self._queue: list[int] = []

    def grow(self) -> None:
        """Make ``reached`` cover every atom interned so far (``keys`` grows while grounding)."""
        if len(self.reached) < len(self.keys):
            self.reached.extend(bytes(len(self.keys) - len(self.reached)))

    def reach(self, atom: int) -> None:
        self.grow()
        if not self.reached[atom]:
            self.reached[atom] = 1
            self.count += 1
            self._queue.append(atom)
            self.on_reach(atom)

    def add(self, formula: GFormula, adds: list[int], parent: int = -1) -> int:
        """A new unit; it fires at once if its formula already holds. Returns its index.

        A disjunctive formula with a small DNF becomes one conjunctive child unit per disjunct
        (counted down instead of re-evaluated); the unit fires with its first child."""
        self.grow()
        u = len(self._units)
        self._units.append((formula, adds))
        self.fired.append(0)
        self._parent.append(parent)
        disjuncts = small_dnf(formula) if isinstance(formula, (GAnd, GOr)) and not all(
            is_literal(p) for p in conjuncts(formula)) else None
        if disjuncts is not None:
            self._simple.append(False)
            self._missing.append(0)
            for d in disjuncts:
                if not self.fired[u]:
                    self.add(conj(d), adds, u)
            return u
        missing = {a for a in atom_ids(formula, positive_only=True) if not self.reached[a]}
        simple = all(is_literal(p) for p in conjuncts(formula))
        self._simple.append(simple)
        self._missing.append(len(missing))
        for a in missing:
            self._watch.setdefault(a, []).append(u)
        if (not missing) if simple else relaxed_holds(formula, self.reached):
            self._fire(u)
        return u

    def _fire(self, u: int) -> None:
        if self.fired[u]:
            return
        self.fired[u] = 1
        if self._parent[u] >= 0:
            self._fire(self._parent[u])
            return
        for a in self._units[u][1]:
            self.reach(a)

    def propagate(self) -> None:
        """Fire every unit that the atoms reached so far enable, transitively."""
        while self._queue:
            for u in self._watch.pop(self._queue.pop(), ()):
                if self.fired[u]:
                    continue
                if self._simple[u]:
                    self._missing[u] -= 1
                    if self._missing[u] == 0:
                        self._fire(u)
                elif relaxed_holds(self._units[u][0], self.reached):
                    self._fire(u)
