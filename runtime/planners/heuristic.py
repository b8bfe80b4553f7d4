"""The FF heuristic behind the thesis's minimal heuristic interface (Def. 4).

``suggest(symbolic_state) -> [(action, priority)]`` is all the chapter-2 sampler (Algorithm 1) asks
of a heuristic. :class:`FFHeuristic` answers it with planet's priorities (docs/math.md §B) computed
from FF's relaxed planning graph; :class:`ScaledPriorities` is the sampler's table of entries
with the Fail/Success counts that turn those priorities into its weights
``P(a) / (1 + fail + gamma * success)`` (the unified planner draws from it).

**The relaxation.** Deletes are ignored. A condition is relaxed-true once its positive atoms are
reached; negated atoms and geometric literals count as possibly true (the same reading as
:func:`~tmpc.compiler.ground.formula.relaxed_holds`). Each action, each conditional effect (its
action's precondition and its condition) and each axiom is a *unit*: one or more alternative sets
of positive atoms (the disjuncts of a small DNF of its formula) and the atoms it adds. Actions and
conditional effects cost one layer, axioms none (a derived atom appears in the layer its body
does). Units whose formula has no small DNF are re-evaluated when an atom they watch is reached.

**Layers** are computed with the counter-based propagation of h_max: every unit counts its
missing atoms down as atoms are reached in layer order; the first unit to reach an atom is its
*supporter*. Propagation stops in the layer where the goal becomes relaxed-true; that layer is
h_max. **The relaxed plan** is extracted backwards from the goal (its positive atoms, plus those of
its earliest disjunct when it is disjunctive): a subgoal at level ``k`` is achieved by its
supporter; an action unit is scheduled in layer ``k - 1`` and other atoms it adds at level ``k``
need no further achiever (FF's "marked true"). h_FF counts the scheduled (action, layer) pairs, so
an action used in two layers (say, once more for a conditional effect that needs its own add)
counts twice: the plan applied layer by layer in the relaxation reaches the goal and h_FF >= h_max.

**Helpful actions** (FF): the actions applicable in the state (discrete view, geometry possibly
true) whose successor makes true an atom of the first-layer subgoals ``G_1``.
"""

from __future__ import annotations

import math
import time
from collections import OrderedDict
from dataclasses import dataclass
from typing import Protocol, Sequence

import numpy as np

from tmpc.compiler.ground import (
    GAnd,
    GAtom,
    GFalse,
    GFormula,
    GOr,
    GroundAction,
    GroundProblem,
    GTrue,
    atom_ids,
    bits,
    conj,
    small_dnf,
)

#: Priority of the entry that says "the goal is reached" (planet's ``goal_weight``).
GOAL_PRIORITY = 4.0
#: Non-helpful applicable actions get this fraction of the smallest helpful priority (planet).
NON_HELPFUL_FACTOR = 0.05
#: Weight of a success against a failure in the scaled priority (planet's ``success_scale``).
SUCCESS_SCALE = 100.0

#: One suggestion: an action (None: "the goal is reached here") and its priority (> 0).
Suggestion = tuple["GroundAction | None", float]

UNREACHED = 1 << 30              # level of an atom not reached (yet)
AXIOM_UNIT, GOAL_UNIT = -1, -2     # ``RelaxedTask.act`` of units that are not actions


class Heuristic(Protocol):
    """The minimal heuristic interface of thesis Def. 4."""

    def suggest(self, state: int) -> list[Suggestion]: ...


@dataclass
class HeuristicStats:
    """Counters for the planner's time report. ``seconds`` is wall time spent inside the public
    methods (nested calls are not counted twice)."""

    seconds: float = 0.0
    explorations: int = 0       # relaxed planning graphs built (cache misses)
    h_calls: int = 0
    suggest_calls: int = 0
    cache_hits: int = 0


@dataclass(frozen=True)
class RelaxedPlan:
    """An FF relaxed plan from one state.

    ``layers[i]``: the actions scheduled in layer ``i`` (applied together, in the relaxation, to
    the atoms of layers ``< i + 1``), by id. ``subgoals[k]``: the atoms that became subgoals at
    level ``k`` (``subgoals[0]`` is empty: atoms of the state need no achiever). ``h_max``: the
    number of layers, ``length``: h_FF.
    """

    layers: tuple[tuple[GroundAction, ...], ...]
    subgoals: tuple[frozenset[int], ...]

    @property
    def h_max(self) -> int:
        return len(self.layers)

    @property
    def length(self) -> int:
        return sum(len(layer) for layer in self.layers)

    @property
    def first_layer_subgoals(self) -> frozenset[int]:
        return self.subgoals[1] if len(self.subgoals) > 1 else frozenset()


class _LRU:
    """A dict with a size cap that forgets the least recently used entry."""

    def __init__(self, cap: int):
        self.cap, self.data = cap, OrderedDict()

    def get(self, key):
        v = self.data.get(key)
        if v is not None:
            self.data.move_to_end(key)
        return v

    def put(self, key, value) -> None:
        self.data[key] = value
        if len(self.data) > self.cap:
            self.data.popitem(last=False)


class Analysis:
    """What one exploration of a state yields: h (inf: dead end), h_max, the scheduled
    ``(action id, layer)`` pairs, the subgoals per level and ``G_1`` as a mask."""

    __slots__ = ("h", "h_max", "pairs", "subgoals", "g1")

    def __init__(self, h: float, h_max: float, pairs=(), subgoals=(), g1: int = 0):
        self.h, self.h_max, self.pairs, self.subgoals, self.g1 = h, h_max, pairs, subgoals, g1


# ---------------------------------------------------------------------------------------------
# The relaxed task: units and watch lists, built once per problem


class RelaxedTask:
    """The units of ``problem``'s delete relaxation, indexed for counter-based propagation.

    Per unit ``u``: ``pre[u]`` the positive atoms it needs (a tuple; for generic units the atoms
    it watches), ``adds[u]``, ``cost[u]`` (1 for actions and conditional effects, 0 for axioms
    and the goal), ``act[u]`` (an action id, ``AXIOM_UNIT``, or ``GOAL_UNIT`` for the goal's
    disjuncts: the units from ``goal0`` on) and ``formula[u]`` for generic units (None
    otherwise).
    """

    def __init__(self, problem: GroundProblem, dnf_limit: int = 64):
        self.n = len(problem.atoms)
        self.pre: list[tuple[int, ...]] = []
        self.adds: list[tuple[int, ...]] = []
        self.cost: list[int] = []
        self.act: list[int] = []
        self.formula: list[GFormula | None] = []
        self.dnf_limit = dnf_limit
        for a in problem.actions:
            self._add(a.pre.formula, a.adds, 1, a.id)
            for ce in a.conditional:
                self._add(conj((a.pre.formula, ce.condition)), ce.adds, 1, a.id)
        for ax in problem.axioms:
            self._add(ax.body, (ax.head,), 0, AXIOM_UNIT)
        self.goal0 = len(self.pre)      # units from here on are the goal's disjuncts
        self._add(problem.goal.formula, (), 0, GOAL_UNIT)
        self.watch1: list[list[int]] = [[] for _ in range(self.n)]     # units needing one atom
        self.watch: list[list[int]] = [[] for _ in range(self.n)]      # units needing several
        self.gwatch: list[list[int]] = [[] for _ in range(self.n)]
        self.free: list[int] = []       # counter units needing no atom: they fire in layer 0
        self.generic: list[int] = []    # units evaluated as formulas (checked in layer 0 too)
        for u, atoms in enumerate(self.pre):
            if self.formula[u] is not None:
                self.generic.append(u)
                for p in atoms:
                    self.gwatch[p].append(u)
            elif len(atoms) == 1:
                self.watch1[atoms[0]].append(u)
            elif atoms:
                for p in atoms:
                    self.watch[p].append(u)
            else:
                self.free.append(u)
        self.missing0 = [0 if f is not None else len(p) for p, f in zip(self.pre, self.formula)]

    def _add(self, formula: GFormula, adds, cost: int, act: int) -> None:
        adds = tuple(sorted(adds))
        if isinstance(formula, GFalse):
            return
        disjuncts = small_dnf(formula, self.dnf_limit) if isinstance(formula, (GAnd, GOr)) \
            else [() if isinstance(formula, GTrue) else (formula,)]
        if disjuncts is None:           # too many disjuncts: evaluate the formula itself
            self._unit(tuple(sorted(set(atom_ids(formula, positive_only=True)))), adds, cost,
                       act, formula)
            return
        sets = sorted({frozenset(x.id for x in d if type(x) is GAtom) for d in disjuncts},
                      key=lambda s: (len(s), sorted(s)))
        kept: list[frozenset[int]] = []
        for s in sets:                  # drop disjuncts that need a superset of another's atoms
            if not any(k <= s for k in kept):
                kept.append(s)
        for s in kept:
            self._unit(tuple(sorted(s)), adds, cost, act, None)

    def _unit(self, pre, adds, cost, act, formula) -> None:
        self.pre.append(pre)
        self.adds.append(adds)
        self.cost.append(cost)
        self.act.append(act)
        self.formula.append(formula)


def relaxed_level(f: GFormula, level: Sequence[int]) -> int:
    """Relaxed level of ``f``: the layer from which it is relaxed-true (``UNREACHED``: never)."""
    t = type(f)
    if t is GAtom:
        return level[f.id]
    if t is GAnd:
        return max((relaxed_level(p, level) for p in f.parts), default=0)
    if t is GOr:
        return min((relaxed_level(p, level) for p in f.parts), default=UNREACHED)
    return UNREACHED if t is GFalse else 0


def relaxed_witness(f: GFormula, level: Sequence[int], out: list[int]) -> None:
    """Append to ``out`` positive atoms that make ``f`` relaxed-true at its :func:`relaxed_level`
    (the earliest disjunct of every ``or``)."""
    t = type(f)
    if t is GAtom:
        out.append(f.id)
    elif t is GAnd:
        for p in f.parts:
            relaxed_witness(p, level, out)
    elif t is GOr:
        relaxed_witness(min(f.parts, key=lambda p: relaxed_level(p, level)), level, out)


# ---------------------------------------------------------------------------------------------
# The heuristic


class FFHeuristic:
    """h_FF, h_max, helpful actions and planet's suggestions for the states of ``problem``.

    States are the problem's ``int`` bitsets with derived atoms evaluated (as
    :meth:`GroundProblem.apply` returns them). Results are cached per state in LRU caches of
    ``cache_size`` entries. Not thread-safe.
    """

    def __init__(self, problem: GroundProblem, cache_size: int = 1 << 16):
        self.problem = problem
        self.task = RelaxedTask(problem)
        self.stats = HeuristicStats()
        self._analyses = _LRU(cache_size)
        self._suggestions = _LRU(cache_size)
        self._depth = 0
        self._t0 = 0.0
        #: per action: the masks of its literal conjuncts, and whether a formula remains
        self._tests = [(a.pre.pos_mask, a.pre.neg_mask, a, a.pre.extra is not None)
                       for a in problem.actions]

    # ---- public interface -------------------------------------------------------------------
    def h(self, state: int) -> float:
        """FF relaxed plan length: 0 exactly at goal states, ``math.inf`` when the goal is not
        reachable in the delete relaxation, at least 1 elsewhere (also when the relaxation holds
        the goal at once, as with a negated goal atom that is still true)."""
        self._enter()
        try:
            self.stats.h_calls += 1
            return self._analysis(state).h
        finally:
            self._leave()

    def h_max(self, state: int) -> float:
        """The number of relaxed layers until the goal (0 at goal states; inf: dead end)."""
        self._enter()
        try:
            return self._analysis(state).h_max
        finally:
            self._leave()

    def relaxed_plan(self, state: int) -> RelaxedPlan | None:
        """The FF relaxed plan from ``state`` (None when the goal is relaxed-unreachable)."""
        self._enter()
        try:
            an = self._analysis(state)
            if an.h == math.inf:
                return None
            depth = len(an.subgoals) - 1
            layers: list[list[GroundAction]] = [[] for _ in range(max(depth, 0))]
            for aid, layer in sorted(an.pairs, key=lambda x: (x[1], x[0])):
                layers[layer].append(self.problem.actions[aid])
            return RelaxedPlan(tuple(map(tuple, layers)), an.subgoals)
        finally:
            self._leave()

    def helpful_actions(self, state: int) -> list[GroundAction]:
        """Applicable actions (discrete view) whose successor makes an atom of ``G_1`` true,
        by id. Empty at goal states and dead ends."""
        self._enter()
        try:
            an = self._analysis(state)
            g1 = an.g1
            if not g1:
                return []
            gp = self.problem
            return [a for a in self._applicable(state) if gp.apply(state, a) & ~state & g1]
        finally:
            self._leave()

    def suggest(self, state: int) -> list[Suggestion]:
        """planet's prioritized actions for ``state``, by action id (thesis Def. 4).

        * goal state: ``[(None, 4.0)]`` — "the goal is reached, go there";
        * a successor that satisfies the goal: 4.0 (the goal weight, helpful or not);
        * helpful action ``a``: ``1 / h'^2`` with ``h' = h(apply(state, a))``;
        * other applicable actions: ``0.05 *`` the smallest helpful priority (when no helpful
          action has an entry, the smallest ``1 / h'^2`` of these actions stands in for it);
        * an action whose successor is a relaxed dead end (``h' = inf``): no entry.

        planet's code gives a goal-reaching action 1.0 and defines helpful actions as the
        relaxed plan's first-layer actions; here the goal weight 4.0 of its parameters and
        FF's helpful actions (every applicable action adding a ``G_1`` atom) are used.
        """
        self._enter()
        try:
            self.stats.suggest_calls += 1
            hit = self._suggestions.get(state)
            if hit is not None:
                self.stats.cache_hits += 1
                return list(hit)
            out = self._suggest(state)
            self._suggestions.put(state, tuple(out))
            return out
        finally:
            self._leave()

    # ---- internals --------------------------------------------------------------------------
    def _enter(self) -> None:
        if self._depth == 0:
            self._t0 = time.perf_counter()
        self._depth += 1

    def _leave(self) -> None:
        self._depth -= 1
        if self._depth == 0:
            self.stats.seconds += time.perf_counter() - self._t0

    def _applicable(self, state: int) -> list[GroundAction]:
        """Actions applicable in the discrete view (geometry possibly true), by id."""
        return [a for pm, nm, a, extra in self._tests
                if state & pm == pm and not state & nm and (not extra or a.pre.holds(state))]

    def _suggest(self, state: int) -> list[Suggestion]:
        gp = self.problem
        if gp.goal_satisfied(state):
            return [(None, GOAL_PRIORITY)]
        an = self._analysis(state)
        if an.h == math.inf:        # successors of a relaxed dead end are dead ends too
            return []
        g1 = an.g1
        rows = []                   # (action, h', helpful)
        for a in self._applicable(state):
            nxt = gp.apply(state, a)
            h2 = self._analysis(nxt).h
            if h2 != math.inf:
                rows.append((a, h2, bool(nxt & ~state & g1)))
        helpful = [_priority(h2) for _, h2, is_h in rows if is_h]
        ref = min(helpful) if helpful else min((_priority(h2) for _, h2, _ in rows), default=0.0)
        return [(a, _priority(h2) if is_h or h2 == 0 else NON_HELPFUL_FACTOR * ref)
                for a, h2, is_h in rows]

    def _analysis(self, state: int) -> Analysis:
        an = self._analyses.get(state)
        if an is not None:
            self.stats.cache_hits += 1
            return an
        self.stats.explorations += 1
        if self.problem.goal_satisfied(state):
            an = Analysis(0.0, 0.0, (), (frozenset(),), 0)
        else:
            an = self._explore(state)
        self._analyses.put(state, an)
        return an

    def _explore(self, state: int) -> Analysis:
        """Counter-based layered propagation from ``state``, then FF extraction."""
        t = self.task
        watch1, watch, gwatch, uadds, ucost = t.watch1, t.watch, t.gwatch, t.adds, t.cost
        level = [UNREACHED] * t.n
        sup = [-1] * t.n
        missing = t.missing0[:]
        witness: dict[int, list[int]] = {}     # generic units: the atoms they fired on
        layer = list(bits(state))
        for p in layer:
            level[p] = 0
        nxt: list[int] = []
        for u in t.free + [u for u in t.generic if relaxed_level(t.formula[u], level) == 0]:
            if t.formula[u] is not None:
                witness[u] = []
                relaxed_witness(t.formula[u], level, witness[u])
            if u >= t.goal0:
                return self._extract(state, level, sup, u, 0, witness)
            self._fire(u, 0, level, sup, layer, nxt)
        L = 0
        goal0 = t.goal0
        while layer or nxt:
            for p in layer:                 # the list grows while it is walked (axioms)
                if level[p] != L:
                    continue
                # The two counter loops below inline :meth:`_fire` on purpose (the same body
                # twice): a method call per unit is a large share of h() on every benchmark
                # problem (tests/bench/test_bench_heuristic.py). Keep both identical to _fire.
                for u in watch1[p]:         # units needing p alone fire now
                    if u >= goal0:
                        return self._extract(state, level, sup, u, L, witness)
                    c = ucost[u]
                    lv = L + c
                    for q in uadds[u]:
                        if level[q] > lv:
                            level[q] = lv
                            sup[q] = u
                            if c:
                                nxt.append(q)
                            else:
                                layer.append(q)
                for u in watch[p]:
                    m = missing[u] - 1
                    missing[u] = m
                    if m == 0:
                        if u >= goal0:
                            return self._extract(state, level, sup, u, L, witness)
                        c = ucost[u]
                        lv = L + c
                        for q in uadds[u]:
                            if level[q] > lv:
                                level[q] = lv
                                sup[q] = u
                                if c:
                                    nxt.append(q)
                                else:
                                    layer.append(q)
                for u in gwatch[p]:
                    if u in witness or relaxed_level(t.formula[u], level) > L:
                        continue
                    witness[u] = []
                    relaxed_witness(t.formula[u], level, witness[u])
                    if u >= goal0:
                        return self._extract(state, level, sup, u, L, witness)
                    self._fire(u, L, level, sup, layer, nxt)
            layer, nxt = nxt, []
            L += 1
        return Analysis(math.inf, math.inf)

    def _fire(self, u: int, L: int, level, sup, layer, nxt) -> None:
        # inlined twice in _explore's counter loops (a call per unit costs too much there)
        c = self.task.cost[u]
        lv = L + c
        for q in self.task.adds[u]:
            if level[q] > lv:
                level[q] = lv
                sup[q] = u
                (nxt if c else layer).append(q)

    def _extract(self, state: int, level, sup, goal_unit: int, depth: int,
                 witness: dict[int, list[int]]) -> Analysis:
        """FF's backward extraction from the goal unit (reached in layer ``depth``)."""
        t = self.task
        upre, uadds, uact = t.pre, t.adds, t.act
        queued = bytearray(t.n)     # became a subgoal
        done = bytearray(t.n)       # achieved at its level by a scheduled action
        agenda: list[list[int]] = [[] for _ in range(depth + 1)]

        def need(atoms) -> None:
            for r in atoms:
                if not queued[r] and level[r] > 0:
                    queued[r] = 1
                    agenda[level[r]].append(r)

        need(witness[goal_unit] if goal_unit in witness else upre[goal_unit])
        pairs: set[tuple[int, int]] = set()
        for k in range(depth, 0, -1):
            todo = agenda[k]
            i = 0
            while i < len(todo):                 # axioms may add same-level subgoals
                p = todo[i]
                i += 1
                if done[p]:
                    continue
                u = sup[p]
                a = uact[u]
                if a >= 0:
                    pairs.add((a, k - 1))
                    for q in uadds[u]:
                        if level[q] == k:
                            done[q] = 1
                need(witness[u] if u in witness else upre[u])
        subgoals = tuple(frozenset(g) for g in agenda)
        g1 = sum(1 << p for p in agenda[1]) if depth >= 1 else 0
        # a state that is not a goal state needs at least one action, even when the relaxation
        # is satisfied at once (a negated goal atom still true, say)
        return Analysis(float(max(len(pairs), 1)), float(max(depth, 1)), frozenset(pairs),
                         subgoals, g1)


def _priority(h2: float) -> float:
    """planet's priority of an action whose successor has h_FF ``h2`` (0: the goal)."""
    return GOAL_PRIORITY if h2 == 0 else 1.0 / (h2 * h2)


# ---------------------------------------------------------------------------------------------
# Scaled priorities (Algorithm 1)


class ScaledPriorities:
    """Algorithm 1's table: one entry per (symbolic state, action) suggestion, with its priority,
    its Fail/Success counts and its scaled priority
    ``P(a) = priority(a) / (1 + fail(a) + gamma * success(a))`` (docs/math.md §B; gamma >= 1).
    The unified planner samples from this table; there is no other implementation.

    Entries are numbered in the order they are added (:meth:`add`, or :meth:`expand`, which adds
    ``heuristic``'s suggestions for a state the first time it is asked). The goal entry
    ``(None, 4.0)`` is counted under the action ``None`` like any other. ``focus`` > 0 also
    multiplies a weight by ``exp(-focus * (after - min after))``, ``after`` the heuristic value
    after the entry's action (tmpc's focus on progress; 0: Algorithm 1 alone). ``strict=False``
    accepts any ``gamma`` (the unified planner takes planet's ``success_scale`` unchecked).
    """

    def __init__(self, heuristic: Heuristic | None = None, gamma: float = SUCCESS_SCALE,
                 focus: float = 0.0, *, strict: bool = True):
        if strict and gamma < 1:
            raise ValueError(f"gamma must be >= 1, got {gamma}")
        self.heuristic, self.gamma, self.focus = heuristic, float(gamma), float(focus)
        #: (state, action or None, priority) per entry
        self.entries: list[tuple[int, GroundAction | None, float]] = []
        self.after: list[float] = []        # heuristic value after the entry's action
        self.fail: list[float] = []
        self.success: list[float] = []
        self._index: dict[tuple[int, int], int] = {}
        self._of_state: dict[int, list[int]] = {}

    def __len__(self) -> int:
        return len(self.entries)

    @staticmethod
    def _key(state: int, action: GroundAction | None) -> tuple[int, int]:
        return state, -1 if action is None else action.id

    def add(self, state: int, action: GroundAction | None, priority: float,
            after: float = 0.0) -> int:
        """A new entry (its number) with no failures and no successes yet."""
        e = len(self.entries)
        self.entries.append((state, action, float(priority)))
        self.after.append(after)
        self.fail.append(0.0)
        self.success.append(0.0)
        self._index[self._key(state, action)] = e
        self._of_state.setdefault(state, []).append(e)
        return e

    def expand(self, state: int) -> list[int]:
        """The entries of ``state``, in suggestion order; the first time, the heuristic's
        suggestions for it are added."""
        if state not in self._of_state:
            if self.heuristic is None:
                raise ValueError("ScaledPriorities was made without a heuristic to suggest "
                                 "actions")
            self._of_state[state] = []
            for action, priority in self.heuristic.suggest(state):
                self.add(state, action, priority)
        return self._of_state[state]

    def entry(self, state: int, action: GroundAction | None) -> int:
        """The number of the entry for ``action`` in ``state`` (KeyError: not suggested there)."""
        if self.heuristic is not None:
            self.expand(state)
        return self._index[self._key(state, action)]

    def record_failure(self, entry: int) -> None:
        self.fail[entry] += 1.0

    def record_success(self, entry: int) -> None:
        self.success[entry] += 1.0

    def counts(self, entry: int) -> tuple[float, float]:
        """``(failures, successes)`` recorded for an entry."""
        return self.fail[entry], self.success[entry]

    def scale(self, priority, failures, successes):
        """The scaled priority (floats or arrays alike): the one formula of Algorithm 1."""
        return priority / (1.0 + failures + self.gamma * successes)

    def weights(self) -> np.ndarray:
        """Every entry's weight, in entry order: its scaled priority (times the focus factor)."""
        base = np.fromiter((e[2] for e in self.entries), float, len(self.entries))
        w = self.scale(base, np.asarray(self.fail), np.asarray(self.success))
        if self.focus > 0:
            h = np.asarray(self.after)
            w = w * np.exp(-self.focus * (h - h.min()))
        return w

    def scaled(self, state: int) -> list[Suggestion]:
        """``state``'s suggestions with their weights (suggestion order)."""
        ids = self.expand(state)
        w = self.weights()
        return [(self.entries[e][1], float(w[e])) for e in ids]

    def choose(self, rng: np.random.Generator, state: int | None = None) -> int | None:
        """An entry drawn with probability proportional to its weight, among every entry (or
        ``state``'s): one ``rng.choice`` (one uniform draw); uniform when the weights are not
        finite or sum to zero; None when there is no entry (a dead end)."""
        ids = None if state is None else self.expand(state)
        if not (len(self.entries) if ids is None else len(ids)):
            return None
        w = self.weights()
        if ids is not None:
            w = w[ids]
        if not np.isfinite(w).all() or w.sum() <= 0:
            w = np.ones_like(w)
        k = int(rng.choice(len(w), p=w / w.sum()))
        return k if ids is None else ids[k]


__all__ = ["FFHeuristic", "Heuristic", "HeuristicStats", "RelaxedPlan", "RelaxedTask",
           "ScaledPriorities", "Suggestion", "GOAL_PRIORITY", "NON_HELPFUL_FACTOR",
           "SUCCESS_SCALE"]
