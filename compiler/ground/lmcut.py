"""LM-cut (Helmert & Domshlak 2009) over a ground problem's delete relaxation, for any state.

One implementation serves two users: the SAT planner's length bound (unit costs, initial state:
:func:`tmpc.compiler.smt.bound.lmcut`) and the A* engine's heuristic (action costs, every
expanded state: :mod:`tmpc.runtime.planners.astar`).

The relaxation only ever makes the problem easier, so the value is admissible: delete effects,
negated literals, disjunctive parts of preconditions and goals and geometric literals are dropped;
every conditional effect's adds count as unconditional adds; derived atoms are reached by
zero-cost axiom operators (one per disjunct of a small DNF, else the body's top-level positive
atoms). Two artificial facts: ``true`` (the precondition of operators without one) and ``goal``
(added by a zero-cost operator whose preconditions are the goal's positive atoms).

Per state, as Fast Downward's ``lm_cut_landmarks.cc`` does it: one full h_max exploration
(Dijkstra), then per cut round the goal plateau (facts that reach the goal through zero-cost
operators via their h_max supporters), the forward exploration from the state that stops at the
plateau (the operators crossing into it are the cut), the cut's cost subtracted, and an
*incremental* h_max update from the cut's operators only (costs only decrease, so values only
decrease). Costs are integers when every action cost is integral.

For integral costs the A* engine runs the same algorithm compiled by numba
(:mod:`tmpc.compiler.ground.lmcut_kernel`, :meth:`LMCut.packed`): the same values and cuts, 20-50x
faster. This Python version stays for the two cases the kernel does not cover: non-integral costs
(its bucket queue needs integers) and the SAT planner's bound, which stops at a deadline; a test
holds the two equal on sampled states.
"""

from __future__ import annotations

import time
from heapq import heappop, heappush

from tmpc.compiler.ground.formula import GAtom, conjuncts, small_dnf
from tmpc.compiler.ground.problem import GroundProblem

INF = float("inf")


class RelaxedTask:
    """Operators ``(pre, eff, cost)`` over fact ids: the problem's atoms ``0..n-1``, then
    ``true`` (``n``) and ``goal`` (``n + 1``). ``action[o]`` is the ground action id of operator
    ``o`` (-1 for axiom and goal operators)."""

    def __init__(self, problem: GroundProblem, unit: bool = True):
        n = len(problem.atoms)
        self.n_facts = n + 2
        self.true_fact, self.goal_fact = n, n + 1
        self.pre: list[tuple[int, ...]] = []
        self.eff: list[tuple[int, ...]] = []
        self.cost: list[int | float] = []
        self.action: list[int] = []
        for a in problem.actions:
            eff = set(a.adds)
            for ce in a.conditional:
                eff |= ce.adds
            if eff:
                self._add(a.pre.pos, eff, 1 if unit else _cost(a.cost), a.id)
        for ax in problem.axioms:
            disjuncts = small_dnf(ax.body, 16)
            if disjuncts is None:
                disjuncts = [tuple(c for c in conjuncts(ax.body) if type(c) is GAtom)]
            for d in disjuncts:
                self._add({x.id for x in d if type(x) is GAtom}, {ax.head}, 0)
        self._add(problem.goal.pos, {self.goal_fact}, 0)
        self._prune()
        self.pre_of: list[list[int]] = [[] for _ in range(self.n_facts)]
        self.eff_of: list[list[int]] = [[] for _ in range(self.n_facts)]
        for o, (pre, eff) in enumerate(zip(self.pre, self.eff)):
            for p in pre:
                self.pre_of[p].append(o)
            for e in eff:
                self.eff_of[e].append(o)
        self.n_pre = [len(p) for p in self.pre]
        self.integral = all(type(c) is int for c in self.cost)

    def _prune(self) -> None:
        """Keep the operators that add a fact the goal needs (backward from ``goal`` through
        preconditions), each with only such effects: h_max and the cuts of the goal are the
        same without the others."""
        needed = {self.goal_fact}
        adders: dict[int, list[int]] = {}
        for o, eff in enumerate(self.eff):
            for e in eff:
                adders.setdefault(e, []).append(o)
        todo = [self.goal_fact]
        while todo:
            for o in adders.get(todo.pop(), ()):
                for p in self.pre[o]:
                    if p not in needed:
                        needed.add(p)
                        todo.append(p)
        keep = [o for o, eff in enumerate(self.eff) if any(e in needed for e in eff)]
        self.pre = [self.pre[o] for o in keep]
        self.eff = [tuple(e for e in self.eff[o] if e in needed) for o in keep]
        self.cost = [self.cost[o] for o in keep]
        self.action = [self.action[o] for o in keep]
        #: the facts h depends on, as a bitset over the problem's atoms
        self.relevant_mask = sum(1 << p for p in needed if p < self.true_fact)

    def _add(self, pre, eff, cost, action: int = -1) -> None:
        self.pre.append(tuple(sorted(pre)) or (self.true_fact,))
        self.eff.append(tuple(sorted(eff)))
        self.cost.append(cost)
        self.action.append(action)


def _cost(c: float) -> int | float:
    return int(c) if float(c).is_integer() else float(c)


class LMCut:
    """``h(state)``: the LM-cut value of a state bitset (``INF`` for a relaxed dead end);
    :meth:`cuts` also returns the landmarks and can start from a parent state's; :meth:`packed`
    is the compiled version. Keeps no state between calls (:meth:`packed` reuses one scratch
    workspace: one instance is not for concurrent threads)."""

    def __init__(self, problem: GroundProblem, unit: bool | None = None):
        self.task = RelaxedTask(problem, not problem.uses_costs if unit is None else unit)
        #: the operator of each ground action (actions without adds have none)
        self.op_of_action = {a: o for o, a in enumerate(self.task.action) if a >= 0}
        self._compiled = None

    def __call__(self, state: int) -> int | float:
        return self.cuts(state, None)[0]

    def cuts(self, state: int, landmarks: list | None = None, deadline: float | None = None,
             reuse: list | None = None, applied: int = -1) -> tuple[int | float, bool]:
        """(h, complete): the sum of the cut costs, appending ``(cost, operators)`` per cut to
        ``landmarks`` when given. Past ``deadline`` (perf_counter) it stops early with
        ``complete=False`` and the sum so far (still a lower bound).

        ``reuse``, ``applied``: the landmarks of a parent state and the ground action that led
        here (incremental LM-cut, Pommerening & Helmert 2013). Every parent landmark without
        that action is a landmark here too (a plan from here, prefixed with the action, is one
        from the parent); they are kept with their costs, and LM-cut runs on the costs left, a
        cost partitioning, so the sum stays admissible while needing far fewer cut rounds."""
        t = self.task
        pre, eff, pre_of, eff_of = t.pre, t.eff, t.pre_of, t.eff_of
        goal, n_facts = t.goal_fact, t.n_facts
        cost = t.cost[:]
        total = 0
        if reuse:
            a = self.op_of_action.get(applied, -1)
            for lm in reuse:
                m, ops = lm
                if a in ops:
                    continue
                total += m
                for o in ops:
                    cost[o] -= m
                if landmarks is not None:
                    landmarks.append(lm)
        h = [INF] * n_facts
        supp = [-1] * len(pre)              # h_max supporter of each reached operator
        scost = [0] * len(pre)              # its h_max when it was chosen
        #: operators each fact supports (or once did: check supp)
        sup: list[list[int]] = [[] for _ in range(n_facts)]
        init = [t.true_fact]
        s = state & t.relevant_mask
        while s:
            low = s & -s
            init.append(low.bit_length() - 1)
            s ^= low
        (_explore_buckets if t.integral else _explore)(init, h, cost, supp, scost, sup,
                                                       t.n_pre[:], pre_of, eff)
        if h[goal] == INF:
            return INF, True
        while h[goal] != 0:
            if deadline is not None and time.perf_counter() > deadline:
                return total, False
            cut = _cut(init, cost, supp, sup, eff, eff_of, goal, n_facts)
            m = min(cost[o] for o in cut)
            total += m
            for o in cut:
                cost[o] -= m
            if landmarks is not None:
                landmarks.append((m, frozenset(cut)))
            _decrease(cut, h, cost, supp, scost, sup, pre, eff)
        return total, True

    @property
    def compiled(self) -> bool:
        """Whether :meth:`packed` is available (every cost integral)."""
        return self.task.integral

    def packed(self, state: int, parent=None, applied: int = -1):
        """The compiled LM-cut (integral costs only): the state's landmarks packed in one
        ``int32`` array ``[h, n, (cost, k, op_1..op_k) * n]``, ``h = -1`` for a relaxed dead
        end. ``parent`` (a parent's packed landmarks) and ``applied`` (the ground action from
        it) as in :meth:`cuts`."""
        if self._compiled is None:
            self._prepare(1)
        kernel, task, cost, mask, nbytes, none, ws, sizes = self._compiled
        bits = (state & mask).to_bytes(nbytes, "little")
        parent = none if parent is None else parent
        op = self.op_of_action.get(applied, -1)
        out = kernel(task, cost, bits, parent, op, ws, sizes)
        while out[0] == -2:                 # a workspace region was too small: double them
            self._prepare(2 * self._scale)
            kernel, task, cost, mask, nbytes, none, ws, sizes = self._compiled
            out = kernel(task, cost, bits, parent, op, ws, sizes)
        return out

    def _prepare(self, scale: int) -> None:
        # numba (and numpy) load only here: start-up time of everything that does not run A*
        from tmpc.compiler.ground import lmcut_kernel

        assert self.task.integral, "the compiled LM-cut needs integral costs"
        self._scale = scale
        self._compiled = lmcut_kernel.prepare(self.task, scale)


def load_kernel() -> None:
    """Load the compiled LM-cut now (compile it, the first time on a machine: seconds of CPU), so
    that the first state a search evaluates does not pay it; A* calls it before its clock."""
    from tmpc.compiler.ground import lmcut_kernel   # numba: only where A* runs

    lmcut_kernel.load()


def _explore_buckets(init, h, cost, supp, scost, sup, unsat, pre_of, eff) -> None:
    """:func:`_explore` for integer costs: Dijkstra with one bucket per h_max value (a fact
    appended while its bucket is being read is read in the same pass)."""
    for p in init:
        h[p] = 0
    buckets = [list(init)]
    v = 0
    while v < len(buckets):
        for p in buckets[v]:
            if h[p] != v:
                continue                    # improved since it was filed here
            for o in pre_of[p]:
                unsat[o] -= 1
                if unsat[o] == 0:
                    supp[o] = p
                    sup[p].append(o)
                    scost[o] = v
                    w = v + cost[o]
                    for e in eff[o]:
                        if w < h[e]:
                            h[e] = w
                            while len(buckets) <= w:
                                buckets.append([])
                            buckets[w].append(e)
        v += 1


def _explore(init, h, cost, supp, scost, sup, unsat, pre_of, eff) -> None:
    """Full h_max by Dijkstra from the facts ``init``; an operator's supporter is its last
    precondition reached (one of highest h_max)."""
    heap = []
    for p in init:
        h[p] = 0
        heap.append((0, p))
    while heap:
        v, p = heappop(heap)
        if v > h[p]:
            continue
        for o in pre_of[p]:
            unsat[o] -= 1
            if unsat[o] == 0:
                supp[o] = p
                sup[p].append(o)
                scost[o] = v
                w = v + cost[o]
                for e in eff[o]:
                    if w < h[e]:
                        h[e] = w
                        heappush(heap, (w, e))


def _cut(init, cost, supp, sup, eff, eff_of, goal, n_facts) -> list[int]:
    """The operators of one landmark cut: from the state's facts through supporters, those that
    reach the goal plateau."""
    zone = bytearray(n_facts)
    stack = [goal]
    while stack:
        p = stack.pop()
        if zone[p]:
            continue
        zone[p] = 1
        for o in eff_of[p]:
            if cost[o] == 0 and supp[o] >= 0:
                stack.append(supp[o])
    before = bytearray(n_facts)
    for p in init:
        before[p] = 1
    stack = list(init)
    cut = []
    in_cut = set()
    while stack:
        p = stack.pop()
        for o in sup[p]:
            if supp[o] != p:
                continue
            es = eff[o]
            for e in es:
                if zone[e]:
                    if o not in in_cut:       # sup[p] may name o twice
                        in_cut.add(o)
                        cut.append(o)
                    break
            else:
                for e in es:
                    if not before[e]:
                        before[e] = 1
                        stack.append(e)
    return cut


def _decrease(cut, h, cost, supp, scost, sup, pre, eff) -> None:
    """Incremental h_max after the costs of ``cut`` went down (Fast Downward's
    ``first_exploration_incremental``)."""
    heap = []
    for o in cut:
        w = scost[o] + cost[o]
        for e in eff[o]:
            if h[e] > w:
                h[e] = w
                heappush(heap, (w, e))
    while heap:
        v, p = heappop(heap)
        if v > h[p]:
            continue
        for o in sup[p]:                    # (not pre_of[p]: only p's supported ones)
            if supp[o] != p or scost[o] <= v:
                continue
            best, bp = -1, -1
            for q in pre[o]:
                if h[q] > best:
                    best, bp = h[q], q
            if bp != p:
                supp[o] = bp
                sup[bp].append(o)
            if best != scost[o]:
                scost[o] = best
                w = best + cost[o]
                for e in eff[o]:
                    if h[e] > w:
                        h[e] = w
                        heappush(heap, (w, e))


def unpack(packed) -> tuple[int | float, list[tuple[int, frozenset[int]]]]:
    """(h, landmarks) of :meth:`LMCut.packed`'s array, as :meth:`LMCut.cuts` gives them."""
    h = INF if packed[0] < 0 else int(packed[0])
    out, i = [], 2
    for _ in range(int(packed[1])):
        m, k = int(packed[i]), int(packed[i + 1])
        out.append((m, frozenset(int(o) for o in packed[i + 2: i + 2 + k])))
        i += 2 + k
    return h, out


__all__ = ["LMCut", "RelaxedTask", "INF", "load_kernel", "unpack"]
