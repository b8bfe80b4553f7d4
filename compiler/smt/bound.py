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
atoms). Stopping early (time budget) keeps the sum of the cuts found so far, still a lower bound. The relaxation and the cut rounds are
:mod:`tmpc.compiler.ground.lmcut` (shared with the A* engine's heuristic).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from tmpc.compiler.ground import GroundProblem, LMCut


def lmcut(problem: GroundProblem, budget_s: float = 1.0) -> Landmarks | None:
    """A lower bound on the length of every plan with the landmarks that prove it; None if the
    goal is unreachable even in the relaxation. Stops after ``budget_s`` seconds with what was
    found so far (still a bound)."""
    h = LMCut(problem, unit=True)
    cuts: list[tuple[int, frozenset[int]]] = []
    value, _ = h.cuts(problem.init, cuts, deadline=time.perf_counter() + budget_s)
    if value == float("inf"):
        return None
    action = h.task.action
    # in a canonical order (by their smallest action id), not the order the cuts were found
    # in: the SAT encoding lists them in this order, and Z3's first model depends on it
    return Landmarks(sorted((frozenset(action[o] for o in cut) for _, cut in cuts), key=min))


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
