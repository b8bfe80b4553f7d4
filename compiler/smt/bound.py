"""An admissible lower bound on plan *length*: LM-cut (Helmert & Domshlak 2009) with unit costs.

The SAT planner deepens the horizon one step at a time, and proving that no plan of a length
exists is the expensive part: on clutter with 14 sticks the solver needs ~1 minute to refute
length 13 and more for every length up to 27, a pigeonhole-style counting argument CDCL is poor
at. LM-cut counts disjoint action landmarks instead (each stick needs its own pick-up and its own
put-down: 28) in milliseconds, and the planner starts at that horizon. Every length below the
bound has no plan, so the first plan found is still the shortest.

The relaxation keeps the bound admissible by only ever making the problem easier: delete effects,
negated literals, disjunctive parts of preconditions and goals, and geometric literals are
dropped; every conditional effect's adds count as unconditional adds; derived atoms are reached by
zero-cost axiom actions (one per disjunct of a small DNF, else the body's top-level positive
atoms). Stopping early (time budget) keeps the sum of the cuts found so far, still a lower bound.
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass

from tmpc.compiler.ground import GAtom, GroundProblem, conjuncts, small_dnf

INF = float("inf")


class _Relaxed:
    """STRIPS actions ``(pre, adds, cost)`` over atom ids plus ``init`` (id ``n``) and ``goal``
    (id ``n + 1``) atoms; action ``-1`` of the list is the goal action."""

    def __init__(self, problem: GroundProblem):
        n = len(problem.atoms)
        self.n_atoms = n + 2
        self.init_atom, self.goal_atom = n, n + 1
        pres: list[tuple[int, ...]] = []
        adds: list[tuple[int, ...]] = []
        costs: list[int] = []
        #: the ground action id of each relaxed action (-1: axiom or goal)
        self.action: list[int] = []

        def add(pre, eff, cost, action=-1):
            pres.append(tuple(sorted(pre)) or (self.init_atom,))
            adds.append(tuple(sorted(eff)))
            costs.append(cost)
            self.action.append(action)

        for a in problem.actions:
            eff = set(a.adds)
            for ce in a.conditional:
                eff |= ce.adds
            if eff:
                add(a.pre.pos, eff, 1, a.id)
        for ax in problem.axioms:
            disjuncts = small_dnf(ax.body, 16)
            if disjuncts is None:
                disjuncts = [tuple(c for c in conjuncts(ax.body) if type(c) is GAtom)]
            for d in disjuncts:
                add({x.id for x in d if type(x) is GAtom}, {ax.head}, 0)
        add(problem.goal.pos, {self.goal_atom}, 0)
        self.pres, self.adds, self.costs = pres, adds, costs
        self.init = [i for i in range(n) if (problem.init >> i) & 1] + [self.init_atom]
        self.by_pre: list[list[int]] = [[] for _ in range(self.n_atoms)]
        for j, pre in enumerate(pres):
            for p in pre:
                self.by_pre[p].append(j)

    def hmax(self) -> tuple[list[float], list[int]]:
        """h_max of every atom under the current costs, and the number of unreached
        preconditions per action (0: the action is reachable)."""
        h = [INF] * self.n_atoms
        missing = [len(p) for p in self.pres]
        heap = [(0, p) for p in self.init]
        for p in self.init:
            h[p] = 0
        heapq.heapify(heap)
        done = [False] * self.n_atoms
        while heap:
            v, p = heapq.heappop(heap)
            if done[p]:
                continue
            done[p] = True
            for j in self.by_pre[p]:
                missing[j] -= 1
                if missing[j] == 0:
                    w = v + self.costs[j]       # p is the last (hence highest) precondition
                    for e in self.adds[j]:
                        if w < h[e]:
                            h[e] = w
                            heapq.heappush(heap, (w, e))
        return h, missing

    def cut(self, h: list[float], missing: list[int]) -> list[int]:
        """The actions of one landmark cut (precondition choice: a highest-h_max precondition)."""
        live = [j for j in range(len(self.pres)) if missing[j] == 0]
        pcf = {j: max(self.pres[j], key=lambda p: h[p]) for j in live}
        adders: dict[int, list[int]] = {}
        for j in live:
            for e in self.adds[j]:
                adders.setdefault(e, []).append(j)
        zone = {self.goal_atom}
        todo = [self.goal_atom]
        while todo:
            e = todo.pop()
            for j in adders.get(e, ()):
                if self.costs[j] == 0 and pcf[j] not in zone:
                    zone.add(pcf[j])
                    todo.append(pcf[j])
        before = set(self.init)
        todo = list(self.init)
        by_pcf: dict[int, list[int]] = {}
        for j in live:
            by_pcf.setdefault(pcf[j], []).append(j)
        cut = []
        while todo:
            p = todo.pop()
            for j in by_pcf.get(p, ()):
                hits_zone = False
                for e in self.adds[j]:
                    if e in zone:
                        hits_zone = True
                    elif e not in before:
                        before.add(e)
                        todo.append(e)
                if hits_zone:
                    cut.append(j)
        return cut


def lmcut(problem: GroundProblem, budget_s: float = 1.0) -> Landmarks | None:
    """A lower bound on the length of every plan with the landmarks that prove it; None if the
    goal is unreachable even in the relaxation. Stops after ``budget_s`` seconds with what was
    found so far (still a bound)."""
    t0 = time.perf_counter()
    r = _Relaxed(problem)
    found: list[frozenset[int]] = []
    while True:
        h, missing = r.hmax()
        if h[r.goal_atom] == INF:
            return Landmarks(found) if found else None
        if h[r.goal_atom] == 0 or time.perf_counter() - t0 > budget_s:
            return Landmarks(found)
        cut = r.cut(h, missing)
        if not cut or min(r.costs[j] for j in cut) != 1:
            return Landmarks(found)     # cannot happen for a proper unit-cost cut
        found.append(frozenset(r.action[j] for j in cut))
        for j in cut:
            r.costs[j] = 0


@dataclass(frozen=True)
class Landmarks:
    """Disjoint action landmarks: every plan contains an action of each set (ground action
    ids), so no plan is shorter than their number. (With unit costs an action in one cut costs 0
    afterwards and never joins another, hence disjoint.)"""

    sets: list[frozenset[int]]

    @property
    def bound(self) -> int:
        return len(self.sets)


__all__ = ["lmcut", "Landmarks"]
