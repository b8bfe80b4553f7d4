"""A* with the LM-cut heuristic on a ground problem: cost-optimal classical plans.

The search engine beside the SAT planner for `tmpc plan --engine astar` (docs/taskplan.md). It
works on the grounder's representation directly: states are ``int`` bitsets, derived atoms
included (:class:`~tmpc.compiler.ground.GroundProblem`), geometric literals count as satisfied.

* **Successors** come from a *key-atom index*: every action is filed under one positive
  precondition atom (the one of its predicate with the fewest true atoms in the initial state),
  so a state only looks at the actions keyed by its true atoms, then checks the full
  precondition by masks (``state & pos == pos and not state & neg``), plus the compiled formula
  when a disjunction remains. Plain STRIPS effects are two mask operations; actions with
  conditional effects, and every action of a domain with derived predicates, go through
  :meth:`GroundProblem.apply`.
* **Heuristic**: LM-cut (:mod:`tmpc.compiler.ground.lmcut`), admissible, not consistent; its
  value is cached per state. With integral costs it is the numba kernel
  (:meth:`LMCut.packed`, the same values), and a state's landmarks are one int32 array.
* **Search** as Fast Downward's ``astar(lmcut())``: the open list is ordered by ``f = g + h``,
  ties by lower ``h``, then first in, first out; the goal test is at expansion; a state reached
  again by a cheaper path is updated and, if it was already expanded, reopened (h is
  inconsistent, so this is needed for optimality); dead ends (``h = inf``) are never opened.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from heapq import heappop, heappush

from tmpc.compiler.ground import GroundAction, GroundProblem, LMCut, load_kernel

INF = float("inf")

SOLVED, EXHAUSTED, TIMEOUT = "solved", "exhausted", "timeout"


@dataclass
class SearchStats:
    expanded: int = 0
    reopened: int = 0
    generated: int = 0
    evaluated: int = 0
    dead_ends: int = 0
    h_init: float = 0
    h_seconds: float = 0.0
    seconds: float = 0.0
    #: the last f value expanded: no plan is cheaper (when the search ended without a plan)
    f_bound: float = 0

    @property
    def expansions_per_s(self) -> float:
        return self.expanded / self.seconds if self.seconds > 0 else 0.0


@dataclass
class SearchResult:
    """``actions`` (None unless solved) and ``cost``; ``exhausted``: no plan exists."""

    status: str
    actions: list[GroundAction] | None
    cost: float
    stats: SearchStats


class Successors:
    """All ``(action, successor)`` pairs of a state, by the key-atom index."""

    def __init__(self, problem: GroundProblem, unit: bool):
        self.problem = problem
        general = bool(problem.axioms)
        true_per_pred: dict[str, int] = {}
        for i, atom in enumerate(problem.atoms):
            if (problem.init >> i) & 1:
                true_per_pred[atom.predicate] = true_per_pred.get(atom.predicate, 0) + 1
        self.keyed: dict[int, list[tuple]] = {}
        self.always: list[tuple] = []
        for a in problem.actions:
            pre = a.pre
            entry = (pre.pos_mask, pre.neg_mask, pre if pre.extra is not None else None,
                     ~a.del_mask, a.add_mask, a, 1 if unit else a.cost,
                     general or bool(a.conditional))
            if pre.pos:
                key = min(sorted(pre.pos),
                          key=lambda p: true_per_pred.get(problem.atoms[p].predicate, 0))
                self.keyed.setdefault(key, []).append(entry)
            else:
                self.always.append(entry)

    def __call__(self, state: int) -> list[tuple[GroundAction, int, float]]:
        out = []
        keyed = self.keyed
        s = state
        lists = [self.always]
        while s:
            low = s & -s
            ops = keyed.get(low.bit_length() - 1)
            if ops is not None:
                lists.append(ops)
            s ^= low
        apply = self.problem.apply
        for ops in lists:
            for pm, nm, extra, keep, adds, a, c, general in ops:
                if state & pm != pm or state & nm:
                    continue
                if extra is not None and not extra.holds(state):
                    continue
                out.append((a, apply(state, a) if general else (state & keep) | adds, c))
        return out


class AStarPlanner:
    """``plan(time_limit)``: a cost-optimal plan (unit costs unless the domain uses action
    costs; ``unit=True`` forces them), or why there is none."""

    def __init__(self, problem: GroundProblem, unit: bool | None = None,
                 incremental: bool = True):
        self.problem = problem
        self.incremental = incremental
        self.unit = (not problem.uses_costs) if unit is None else unit
        self.h = LMCut(problem, unit=self.unit)
        self.successors = Successors(problem, self.unit)
        if self.h.compiled:                 # integral costs: numba's LM-cut, loaded before
            load_kernel()                   # the search's clock starts

    def plan(self, time_limit: float = INF) -> SearchResult:
        """The search; one function on purpose: it is the hot loop, and locals are Python's
        fastest names. Nodes are parallel lists indexed by state id."""
        t0 = time.perf_counter()
        deadline = t0 + time_limit
        st = SearchStats()
        p = self.problem
        succ, goal = self.successors, p.goal_satisfied
        cuts, incremental = self.h.cuts, self.incremental
        lms: dict[int, list] = {}           # landmarks of generated, unexpanded states
        index: dict[int, int] = {p.init: 0}
        states, g, hv, parent, via = [p.init], [0], [0.0], [-1], [None]
        closed_g: dict[int, float] = {}
        compiled = self.h.compiled
        packed = self.h.packed
        th = time.perf_counter()
        if compiled:
            lms[0] = packed(p.init)
            hv[0] = st.h_init = INF if lms[0][0] < 0 else int(lms[0][0])
        else:
            lms[0] = []
            hv[0] = st.h_init = cuts(p.init, lms[0])[0]
        st.h_seconds += time.perf_counter() - th
        st.evaluated = 1
        heap = [] if hv[0] == INF else [(hv[0], hv[0], 0, 0, 0)]
        tick = 1
        while heap:
            f, h, _, sid, gs = heappop(heap)
            if gs > g[sid] or closed_g.get(sid, INF) <= gs:
                continue                    # a stale entry
            if sid in closed_g:
                st.reopened += 1
            closed_g[sid] = gs
            st.f_bound = f
            state = states[sid]
            mine = lms.pop(sid, None) if incremental else None
            if goal(state):
                st.seconds = time.perf_counter() - t0
                plan = _path(sid, parent, via)
                return SearchResult(SOLVED, plan, gs, st)
            st.expanded += 1
            if time.perf_counter() > deadline:     # cheap next to one LM-cut
                st.seconds = time.perf_counter() - t0
                return SearchResult(TIMEOUT, None, INF, st)
            for a, t, c in succ(state):
                st.generated += 1
                ng = gs + c
                tid = index.get(t)
                if tid is None:
                    th = time.perf_counter()
                    if compiled:
                        lt = packed(t, mine, a.id)
                        ht = INF if lt[0] < 0 else int(lt[0])
                        if incremental:
                            lms[len(states)] = lt
                    elif incremental:
                        lms[len(states)] = lt = []
                        ht = cuts(t, lt, None, mine, a.id)[0]
                    else:
                        ht = cuts(t)[0]
                    st.h_seconds += time.perf_counter() - th
                    st.evaluated += 1
                    tid = len(states)
                    index[t] = tid
                    states.append(t)
                    g.append(ng)
                    hv.append(ht)
                    parent.append(sid)
                    via.append(a)
                    if ht == INF:
                        st.dead_ends += 1
                        lms.pop(tid, None)
                        continue
                elif ng < g[tid] and hv[tid] != INF:
                    g[tid], parent[tid], via[tid] = ng, sid, a
                    ht = hv[tid]
                else:
                    continue
                heappush(heap, (ng + ht, ht, tick, tid, ng))
                tick += 1
        st.seconds = time.perf_counter() - t0
        return SearchResult(EXHAUSTED, None, INF, st)


def _path(sid: int, parent: list[int], via: list) -> list[GroundAction]:
    out = []
    while parent[sid] >= 0:
        out.append(via[sid])
        sid = parent[sid]
    return out[::-1]


__all__ = ["AStarPlanner", "SearchResult", "SearchStats", "Successors", "SOLVED", "EXHAUSTED",
           "TIMEOUT"]
