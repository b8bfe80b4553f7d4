"""Greedy best-first task planning under the TMP planners' constraints, and the portfolio that
puts it in front of the SAT planner for first solutions.

The SAT planner (:class:`~tmpc.runtime.planners.taskplan.TaskPlanner`) gives the *shortest* plan
consistent with what sampling taught, but a long horizon over many objects can take Z3 seconds
to minutes to decide, and its first check at a horizon spends most of that in preprocessing that
neither its timeout nor an interrupt stops (Sort Clutter pb7: 28 steps, 12 s for a check capped
at 1 s; docs/planning.md). A first solution needs *a* plan, soon.

:class:`GreedyTaskPlanner` answers the same three calls (``next_plan``, ``exclude_prefix``,
``add_evidence``) by greedy best-first search on h_FF
(:class:`~tmpc.runtime.planners.heuristic.FFHeuristic`, geometry possibly true), with exactly the
SAT encoding's meaning of the constraints (:mod:`tmpc.compiler.smt.encode`):

* an excluded prefix ``a^1..a^n``: no plan starts with it;
* evidence: after the prefix ``a^1..a^n``, the geometric literal ``m`` (a use: predicate,
  arguments, polarity) is known to be ``value``. The knowledge carries over the following steps
  until one of them may change it (an action with a kinematic effect); a use of a literal known
  false fails, every other use is optimistically possible.

Evidence may also name its *blockers* (the movable objects a failed transition collided with):
it then lasts until one of them moves, and if none of them had moved in its prefix it holds in
every plan while none has moved (a blocker rule; docs/planning.md). An *atom rule* makes a
literal false wherever a set of atoms holds, whatever came before: blockers that were moved
away and put back where they stood block again (a kitchen's radish taken off its spot and put
back before the cabbage behind it is picked).

An *action rule* rules one ground action out wherever a set of atoms holds and none of a set
of objects has moved yet, whatever came before: a placement never reached (the left arm and
the far tray: no object need move, so never), or one that collided with the scene's fixed
objects where what it goes on stood on a given stack (its support chain: Blocks World's ceiling
over a tower on the table). A placement's literal does not name the hand, so these rules are
the action's, not the literal's.

Both constraints hang on a trie of prefixes. A search node is the symbolic state, the trie node
its path still follows (None once it left every constrained prefix), the literal values it
knows and which blockers have moved; nodes are deduplicated on all four, so the search is
complete: ``exhausted`` means no plan of at most ``max_steps`` steps satisfies the constraints.

:class:`PortfolioTaskPlanner` (the TMP planners' choice for first solutions) asks the SAT
planner first while its encoding is small: at most ``sat_clauses`` step clauses up to the
shortest horizon not yet proven impossible. It gets ``sat_budget`` seconds a call, each horizon
capped as ``horizon_cap`` says, and its plan is taken if it keeps the greedy planner's
constraints (which are stronger: blocker evidence lasts until a blocker moves; the rules are
clauses of the SAT planner too). Otherwise, or on a timeout, the greedy search answers; and only
it once a SAT check overran its cap by more than ``stall`` seconds or three calls in a row ran
out of their budget (on a loaded machine, a timing matter), except that a greedy search past
``greedy_budget`` expansions asks the SAT planner once more (and first again if it answers):
under constraints its heuristic cannot see, the greedy search can run for minutes where the SAT
planner answers in a second. On small problems the SAT planner's shortest plans are the better
guide (Hanoi-3: solved in 46 s from SAT's plans, unsolved in 150 s from the greedy planner's
plans of the same lengths); on large ones Z3's first check of a long horizon preprocesses
without heeding its timeout.
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Iterable

from tmpc.compiler.ground import GAnd, GAtom, GGeo, GNot, GOr, GroundAction, GroundProblem, GTrue
from tmpc.runtime.planners.heuristic import FFHeuristic
from tmpc.runtime.planners.taskplan import (
    EXHAUSTED,
    SOLVED,
    TIMEOUT,
    UNREACHABLE,
    PlanResult,
    TaskPlanner,
)

#: a literal use: (predicate, args, positive), names lower-cased
Use = tuple[str, tuple[str, ...], bool]


def _use(literal) -> Use:
    pred, args, positive = literal
    return pred.lower(), tuple(a.lower() for a in args), bool(positive)


def _holds(f, state: int, known: dict) -> bool:
    """``f`` in ``state``; a geometric literal is false only where ``known`` says so. (Not
    :func:`~tmpc.compiler.ground.formula.holds` with an oracle: an oracle gives an atom one
    value, so an unknown atom could not be possible both where it is used and where it is
    negated, as the SAT encoding's separate literal uses are.)"""
    t = type(f)
    if t is GAtom:
        return (state >> f.id) & 1 == 1
    if t is GAnd:
        return all(_holds(p, state, known) for p in f.parts)
    if t is GOr:
        return any(_holds(p, state, known) for p in f.parts)
    if t is GNot:
        if type(f.part) is GAtom:
            return not (state >> f.part.id) & 1
        return known.get(_use((f.part.predicate, f.part.args, False)), True)
    if t is GGeo:
        return known.get(_use((f.predicate, f.args, True)), True)
    return t is GTrue


def _uses(f, out: set) -> None:
    """The geometric literal uses of ``f`` into ``out``."""
    t = type(f)
    if t in (GAnd, GOr):
        for p in f.parts:
            _uses(p, out)
    elif t is GNot and type(f.part) is GGeo:
        out.add(_use((f.part.predicate, f.part.args, False)))
    elif t is GGeo:
        out.add(_use((f.predicate, f.args, True)))


class _Prefix:
    """A node of the trie of constrained prefixes."""

    __slots__ = ("children", "evidence", "excluded")

    def __init__(self) -> None:
        self.children: dict[int, _Prefix] = {}
        self.excluded = False
        #: use -> (value, the ids of the actions that may change it; None: every kinematic one)
        self.evidence: dict[Use, tuple[bool, frozenset | None]] = {}


class GreedyTaskPlanner:
    """Plans of a ground problem by greedy best-first search on h_FF, under excluded prefixes
    and geometric evidence (see the module docstring). ``next_plan`` has the SAT planner's
    signature; ``horizon_cap`` is accepted and ignored (there are no horizons)."""

    takes_blockers = True               # :meth:`add_evidence` takes ``blockers``

    def __init__(self, problem: GroundProblem, weight: float | None = None):
        self.problem = problem
        self.h = FFHeuristic(problem)
        self.root = _Prefix()
        used: set[Use] = set()
        #: per literal use, the ids of the actions whose precondition has it
        self.using: dict[Use, set[int]] = {}
        for a in problem.actions:
            mine: set[Use] = set()
            _uses(a.precondition, mine)
            used |= mine
            for u in mine:
                self.using.setdefault(u, set()).add(a.id)
        #: per action, the discrete part of its precondition: (action, atoms true, atoms
        #: false, whether more than those remains), tested without the formula where it can
        self.tests = [(a, a.pre.pos_mask, a.pre.neg_mask, a.pre.extra is not None)
                      for a in problem.actions]
        # successors: each action under the precondition atom fewest actions need (the
        # others, without a positive atom, always tried), so an expansion visits only the
        # actions one of whose atoms holds, not every ground action (Blocks World F: 190)
        need: dict[int, int] = {}
        for a in problem.actions:
            for atom in a.pre.pos:
                need[atom] = need.get(atom, 0) + 1
        self.under: dict[int, list[int]] = {}
        self.always: list[int] = []
        for a in problem.actions:
            if a.pre.pos:
                key = min(a.pre.pos, key=lambda atom: (need[atom], atom))
                self.under.setdefault(key, []).append(a.id)
            else:
                self.always.append(a.id)
        _uses(problem.goal.formula, used)
        self.used = frozenset(used)
        #: per action, the bit mask of the objects its kinematic effects move (nonzero: the
        #: action may change every geometric literal, the SAT encoding's default changers)
        names: dict[str, int] = {}
        self.moves: list[int] = []
        for a in problem.actions:
            m = 0
            for ke in list(a.kinematic) + [k for ce in a.conditional for k in ce.kinematic]:
                m |= 1 << names.setdefault(ke.child.lower(), len(names))
            self.moves.append(m)
        self.object_bit = names
        #: the objects some action moves (lower-cased): the only possible blockers
        self.movable = frozenset(names)
        #: blocker rules: use -> [mask of objects]; the use is false while none of them moved
        self.rules: dict[Use, list[int]] = {}
        self.rule_mask = 0
        #: atom rules: use -> [mask of atoms]; the use is false wherever all the atoms hold
        self.atom_rules: dict[Use, list[int]] = {}
        #: action rules: action id -> [(mask of objects, mask of atoms)]; the action is ruled
        #: out where all the atoms hold and none of the objects has moved
        self.action_rules: dict[int, list[tuple[int, int]]] = {}
        self.expansions = 0
        #: per state, :meth:`_goal_possible`
        self._goal_cache: dict[int, bool] = {}
        #: after the greedy search, weighted A* (depth + ``weight`` h_FF) for a shorter plan,
        #: within ``weighted_budget`` times the greedy search's expansions (at least
        #: ``weighted_floor``); None: the greedy plan
        self.weight: float | None = weight
        self.weighted_budget = 4
        self.weighted_floor = 2_000
        #: plans the weighted search shortened
        self.shortened = 0

    # ---- constraints ----------------------------------------------------------------------
    def _node(self, prefix: Iterable[GroundAction]) -> _Prefix:
        node = self.root
        for a in prefix:
            node = node.children.setdefault(a.id, _Prefix())
        return node

    def exclude_prefix(self, prefix: Iterable[GroundAction]) -> None:
        """No later plan starts with ``prefix`` (the empty prefix: no plan at all)."""
        self._node(prefix).excluded = True

    def add_evidence(self, prefix: Iterable[GroundAction], literal, value: bool,
                     blockers: Iterable[str] | None = None) -> bool:
        """After ``prefix``, the geometric ``literal`` is known to be ``value``; False (and
        nothing added) if no precondition or goal uses it. ``blockers`` (objects; with
        ``value`` False): the literal is false *because of* them, so it stays false until an
        action moves one of them (not merely until any kinematic action). If none of them
        moved in ``prefix``, that holds in every plan: the literal is false wherever none of
        them has moved yet (a blocker rule, whatever came before)."""
        use = _use(literal)
        if use not in self.used:
            return False
        prefix = list(prefix)
        if blockers is not None and not value:
            mask = self._object_mask(blockers)
            if mask:
                if not self._moved(prefix) & mask:
                    rules = self.rules.setdefault(use, [])
                    if mask not in rules:
                        rules.append(mask)
                        self.rule_mask |= mask
                    return True
                movers = frozenset(a.id for a in self.problem.actions
                                   if self.moves[a.id] & mask)
                self._node(prefix).evidence[use] = (False, movers)
                return True
        self._node(prefix).evidence[use] = (bool(value), None)
        return True

    def add_atom_rule(self, literal, atoms: Iterable[int]) -> bool:
        """The geometric ``literal`` is false wherever all of ``atoms`` (ids, at least one)
        hold, whatever came before; False, and nothing added, if no precondition or goal uses
        it or the rule is known."""
        use = _use(literal)
        mask = 0
        for atom in atoms:
            mask |= 1 << atom
        if use not in self.used or not mask:
            return False
        rules = self.atom_rules.setdefault(use, [])
        if mask in rules:
            return False
        rules.append(mask)
        return True

    def moved(self, prefix: Iterable[GroundAction]) -> set[str]:
        """The movable objects (lower-case) ``prefix`` moves."""
        mask = self._moved(prefix)
        return {name for name, bit in self.object_bit.items() if mask >> bit & 1}

    def add_action_rule(self, prefix: Iterable[GroundAction], action: GroundAction,
                        objects: Iterable[str] = (), atoms: Iterable[int] = ()) -> bool:
        """Rule ``action`` out wherever all of ``atoms`` (ids) hold and none of ``objects`` has
        moved (none given: wherever the atoms hold; neither: everywhere). False, and nothing
        added, if one of ``objects`` moved in ``prefix`` (where the failure was seen: the rule
        would not hold from the start) or the rule is known."""
        objs = self._object_mask(objects)
        if self._moved(prefix) & objs:
            return False
        mask = 0
        for atom in atoms:
            mask |= 1 << atom
        rules = self.action_rules.setdefault(action.id, [])
        if (objs, mask) in rules:
            return False
        rules.append((objs, mask))
        self.rule_mask |= objs
        return True

    def _object_mask(self, names: Iterable[str]) -> int:
        """The bit mask of the movable objects among ``names``."""
        mask = 0
        for name in names:
            bit = self.object_bit.get(name.lower())
            if bit is not None:
                mask |= 1 << bit
        return mask

    def _moved(self, prefix: Iterable[GroundAction]) -> int:
        """The bit mask of the objects ``prefix`` moves."""
        moved = 0
        for a in prefix:
            moved |= self.moves[a.id]
        return moved

    def _ruled_out(self, aid: int, state: int, moved: int) -> bool:
        """Does an action rule rule action ``aid`` out in ``state`` after ``moved``?"""
        rules = self.action_rules.get(aid)
        return bool(rules) and any(state & m == m and not moved & o for o, m in rules)

    def _known(self, known: dict, moved: int, state: int) -> dict:
        """The literal values a node knows: its evidence, the blocker rules whose blockers
        have not moved and the atom rules whose atoms hold in ``state`` (evidence from the
        node's own prefix wins)."""
        out = {u: v for u, (v, _) in known.items()} if known else {}
        for use, masks in self.rules.items():
            if use not in out and any(not moved & m for m in masks):
                out[use] = False
        for use, masks in self.atom_rules.items():
            if use not in out and any(state & m == m for m in masks):
                out[use] = False
        return out

    def satisfies(self, plan: list[GroundAction]) -> bool:
        """Does ``plan`` (applicable in the discrete view) keep every constraint: no excluded
        prefix, no use of a literal known false, the goal not known false at its end?"""
        return self.violation(plan) is None

    def violation(self, plan: list[GroundAction]) -> int | None:
        """The number of steps of ``plan`` through the first that breaks a constraint (0: the
        empty prefix is excluded; ``len(plan) + 1``: only the goal is known false at its end),
        or None if it keeps them all."""
        p = self.problem
        state, trie, known, moved = p.init, self.root, dict(self.root.evidence), 0
        if trie.excluded:
            return 0
        for k, a in enumerate(plan, start=1):
            values = self._known(known, moved, state)
            if values and not _holds(a.precondition, state, values):
                return k
            if self._ruled_out(a.id, state, moved):
                return k
            trie = trie.children.get(a.id) if trie is not None else None
            if trie is not None and trie.excluded:
                return k
            state, known = p.apply(state, a), self._step(known, a)
            moved |= self.moves[a.id]
            if trie is not None and trie.evidence:
                known = {**known, **trie.evidence}
        values = self._known(known, moved, state)
        return None if not values or _holds(p.goal.formula, state, values) else len(plan) + 1

    def _step(self, known: dict, a: GroundAction) -> dict:
        """``known`` after action ``a``: what ``a`` may change is forgotten."""
        if not known:
            return known
        kin = self.moves[a.id] != 0
        return {u: (v, m) for u, (v, m) in known.items()
                if not (a.id in m if m is not None else kin)}

    # ---- search -----------------------------------------------------------------------------
    def next_plan(self, max_steps: int = 200, time_limit: float | None = None,
                  min_steps: int = 0, horizon_cap: float | None = None,
                  budget: int | None = None) -> PlanResult:
        """A plan of ``min_steps..max_steps`` steps satisfying every constraint, found greedily
        (not the shortest), and then, with ``weight``, by weighted A* within ``weighted_budget``
        times the greedy search's expansions (its plan if it is shorter; goals are taken when
        generated, so its bound of ``weight`` times the shortest is loose by a step);
        ``exhausted`` if there is none, ``timeout`` at ``time_limit`` or after ``budget``
        expansions of the greedy search."""
        t0 = time.perf_counter()
        before = self.expansions
        res = self._search(max_steps, time_limit, min_steps, None, budget)
        if res.status != SOLVED or not self.weight:
            return res
        budget = max(self.weighted_floor, self.weighted_budget * (self.expansions - before))
        left = None if time_limit is None else time_limit - (time.perf_counter() - t0)
        if left is not None and left <= 0:
            return res
        short = self._search(max_steps, left, min_steps, self.weight, budget)
        if short.status == SOLVED and len(short.actions) < len(res.actions):
            self.shortened += 1
            return PlanResult(SOLVED, short.actions, len(short.actions),
                              seconds=time.perf_counter() - t0)
        return res

    def _search(self, max_steps: int, time_limit: float | None, min_steps: int,
                weight: float | None, budget: int | None) -> PlanResult:
        """Best-first search ordered by h_FF (``weight`` None: greedy, ties to the shallower)
        or by depth + ``weight`` h_FF (weighted A*), ``timeout`` after ``budget``
        expansions."""
        t0 = time.perf_counter()
        deadline = math.inf if time_limit is None else t0 + time_limit
        p = self.problem
        expanded = 0

        def result(status: str, plan=None) -> PlanResult:
            return PlanResult(status, plan, len(plan) if plan else 0,
                              seconds=time.perf_counter() - t0)

        if not p.goal_relaxed_reachable:
            return result(UNREACHABLE)
        if self.root.excluded:
            return result(EXHAUSTED)
        # per node: (state, trie node, evidence known, moved objects, parent, action id, depth,
        # the literal values known there)
        nodes: list[tuple] = []
        seen: set = set()
        heap: list = []
        relevant = self.rule_mask

        def push(state: int, trie, known: dict, moved: int, parent: int, aid: int,
                 depth: int) -> bool:
            """Add a node unless seen; True if it is a goal."""
            key = (state, id(trie) if trie is not None else 0,
                   frozenset(known.items()) if known else None, moved & relevant)
            if key in seen:
                return False
            seen.add(key)
            values = self._known(known, moved, state)
            node = (state, trie, known, moved, parent, aid, depth, values)
            if depth >= min_steps and self._goal_possible(state) and \
                    (not values or _holds(p.goal.formula, state, values)):
                nodes.append(node)
                return True
            h = self.h.h(state)
            if h == math.inf or depth >= max_steps:
                return False
            nodes.append(node)
            key = (h, depth) if weight is None else (depth + weight * h, h)
            heapq.heappush(heap, (*key, len(nodes) - 1))
            return False

        if push(p.init, self.root, dict(self.root.evidence), 0, -1, -1, 0):
            return result(SOLVED, [])
        while heap:
            if self.expansions % 64 == 0 and time.perf_counter() >= deadline or \
                    budget is not None and expanded >= budget:
                return result(TIMEOUT)
            self.expansions += 1
            expanded += 1
            i = heapq.heappop(heap)[2]
            state, trie, known, moved, _, _, depth, values = nodes[i]
            # the actions a literal known false may rule out (the others' geometric literals
            # are all possibly true)
            doubtful = set().union(*(self.using.get(u, ()) for u, v in values.items()
                                     if not v)) if values else ()
            for a, pos, neg, extra in self._candidates(state):
                if state & pos != pos or state & neg or \
                        extra and not a.pre.holds(state) or \
                        a.id in doubtful and not _holds(a.precondition, state, values):
                    continue
                if self.action_rules and self._ruled_out(a.id, state, moved):
                    continue
                child = trie.children.get(a.id) if trie is not None else None
                if child is not None and child.excluded:
                    continue
                nxt = p.apply(state, a)
                k = self._step(known, a)
                if child is not None and child.evidence:
                    k = {**k, **child.evidence}
                if push(nxt, child, k, moved | self.moves[a.id], i, a.id, depth + 1):
                    return result(SOLVED, self._path(nodes))
        return result(EXHAUSTED)

    def _goal_possible(self, state: int) -> bool:
        """Does the goal hold in ``state`` with every geometric literal possibly true? Known
        values only make literal uses false, so where it does not, it does not either (cached
        per state: Blocks World F's disjunctive goal took a fifth of the search's time)."""
        known = self._goal_cache.get(state)
        if known is None:
            known = self._goal_cache[state] = _holds(self.problem.goal.formula, state, {})
        return known

    def _candidates(self, state: int) -> list[tuple]:
        """The tests of the actions whose indexing atom holds in ``state`` (and those
        without one), in the order of their ids, as the search expands them."""
        ids = list(self.always)
        under, rest = self.under, state
        while rest:
            low = rest & -rest
            found = under.get(low.bit_length() - 1)
            if found:
                ids += found
            rest ^= low
        ids.sort()
        tests = self.tests
        return [tests[i] for i in ids]

    def _path(self, nodes: list) -> list[GroundAction]:
        out = []
        i = len(nodes) - 1
        while nodes[i][4] >= 0:
            out.append(self.problem.actions[nodes[i][5]])
            i = nodes[i][4]
        return out[::-1]

    plan = next_plan


class PortfolioTaskPlanner:
    """The SAT planner while its encoding is small and it answers in time, else the greedy
    planner (see the module docstring). Every constraint goes to both (rules too:
    :meth:`TaskPlanner.add_blocker_rule` and the like); a SAT plan that breaks one only the
    greedy planner holds is excluded in the SAT planner through the step that breaks it, and
    the SAT planner asked again."""

    def __init__(self, problem: GroundProblem, stall: float = 2.0, sat_budget: float = 2.0,
                 sat_clauses: int = 200_000, weight: float | None = None,
                 greedy_budget: int = 20_000, retry_budget: float = 10.0):
        self.problem = problem
        self.sat = TaskPlanner(problem, geometric=True)
        self.greedy = GreedyTaskPlanner(problem, weight)
        self.stall = stall
        self.sat_budget = sat_budget
        #: no SAT call when its shortest horizon holds more step clauses than this: Z3's first
        #: check of a long horizon preprocesses them without heeding its timeout (clutter pb7:
        #: 28 x 13,529 clauses, 12 s in a check capped at 1 s)
        self.sat_clauses = sat_clauses
        self.sat_stalled = False
        #: Z3 raised outside a check: the SAT planner is no longer asked (:meth:`_sat_call`)
        self.sat_broken = False
        #: consecutive calls the SAT planner ran out of its budget; at ``max_misses`` it is
        #: no longer asked
        self.sat_misses = 0
        self.max_misses = 3
        #: the planners whose plans were taken, by name
        self.answers = {"greedy": 0, "sat": 0}
        #: SAT plans that broke one of the greedy planner's constraints
        self.rejected = 0
        #: once the SAT planner is stalled, the greedy search's expansions before the SAT
        #: planner is asked once more, for ``retry_budget`` seconds (0: never), and asked
        #: first again if it answers: under constraints that leave its heuristic no plan the
        #: greedy search can run for minutes (Blocks World I v2, 250 s of a 300 s run, 45
        #: task plans in) where the SAT planner answers in a second; a greedy search usually
        #: takes 2,000-4,000 (2,500-10,000 a second)
        self.greedy_budget = greedy_budget
        self.retry_budget = retry_budget
        #: greedy searches that ran out of their budget and went to the SAT planner
        self.retries = 0
        #: the greedy search's budget now: 4 times larger after each retry the SAT planner
        #: did not answer, so where both are slow a task plan pays for few of them
        self._retry_at = greedy_budget

    @property
    def movable(self) -> frozenset[str]:
        return self.greedy.movable

    def _sat_call(self, fn, *args, **kwargs):
        """``fn(*args, **kwargs)`` of the SAT planner; None, and the SAT planner not asked again,
        if Z3 raised (an interrupt landing outside a check: its state may lack a constraint,
        and the greedy planner holds them all)."""
        if self.sat_broken:
            return None
        try:
            return fn(*args, **kwargs)
        except self.sat.z3.Z3Exception:
            self.sat_broken = self.sat_stalled = True
            return None

    def exclude_prefix(self, prefix: Iterable[GroundAction]) -> None:
        prefix = list(prefix)
        self._sat_call(self.sat.exclude_prefix, prefix)
        self.greedy.exclude_prefix(prefix)

    #: :meth:`add_evidence` takes ``blockers`` (the SAT planner's copy keeps the evidence
    #: at its prefix only; a shorter SAT plan is taken only if it keeps the greedy planner's
    #: constraints, :meth:`GreedyTaskPlanner.satisfies`)
    takes_blockers = True

    def add_evidence(self, prefix: Iterable[GroundAction], literal, value: bool,
                     blockers: Iterable[str] | None = None) -> bool:
        prefix = list(prefix)
        used = self._sat_call(self.sat.add_evidence, prefix, literal, value)
        if blockers is not None and not value:
            blockers = [b.lower() for b in blockers]
            if not self.greedy.moved(prefix) & set(blockers):
                self._sat_call(self.sat.add_blocker_rule, literal, blockers)
        return self.greedy.add_evidence(prefix, literal, value, blockers) or bool(used)

    def add_atom_rule(self, literal, atoms: Iterable[int]) -> bool:
        """The greedy planner's atom rule, and the SAT planner's where it has variables for
        its atoms."""
        atoms = list(atoms)
        self._sat_call(self.sat.add_atom_rule, literal, atoms)
        return self.greedy.add_atom_rule(literal, atoms)

    def moved(self, prefix: Iterable[GroundAction]) -> set[str]:
        """The greedy planner's :meth:`GreedyTaskPlanner.moved`."""
        return self.greedy.moved(prefix)

    def add_action_rule(self, prefix: Iterable[GroundAction], action: GroundAction,
                        objects: Iterable[str] = (), atoms: Iterable[int] = ()) -> bool:
        """The greedy planner's action rule, and the SAT planner's where the greedy planner
        takes it and the SAT planner has variables for its atoms."""
        prefix, objects, atoms = list(prefix), list(objects), list(atoms)
        if not self.greedy.add_action_rule(prefix, action, objects, atoms):
            return False
        self._sat_call(self.sat.add_action_rule, prefix, action, objects, atoms)
        return True

    def next_plan(self, max_steps: int = 200, time_limit: float | None = None,
                  min_steps: int = 0, horizon_cap: float | None = None) -> PlanResult:
        """The SAT planner's shortest plan while its encoding is small enough to answer in
        time (``sat_budget`` seconds, each horizon capped at ``horizon_cap``), if it keeps the
        greedy planner's constraints; else the greedy planner's plan. Once the SAT planner is
        stalled, a greedy search past ``greedy_budget`` expansions asks it once more
        (``retry_budget`` seconds; no longer stalled if it answers, else the budget 4 times
        larger) before searching on."""
        t0 = time.perf_counter()

        def left() -> float | None:
            return None if time_limit is None else max(0.0, time_limit - (time.perf_counter() - t0))

        bound = max(self.sat.impossible_below(), min_steps, 1)
        small = self.sat.encoding.sizes["step"][0] * bound <= self.sat_clauses
        if not self.sat_stalled and small:
            budget = self.sat_budget if time_limit is None else min(self.sat_budget, time_limit)
            res = self._sat_plan(max_steps, budget, min_steps, horizon_cap)
            if res.status == SOLVED:
                self.answers["sat"] += 1
                self.sat_misses = 0
                return res
            # (a horizon the rules make impossible in the SAT planner may yet have a plan the
            # greedy planner takes: there, evidence from a plan's own prefix beats a rule)
            if res.status == UNREACHABLE or res.status == EXHAUSTED and not self.sat.rules:
                return res
            if res.status != EXHAUSTED:
                self.sat_misses += 1                  # a timeout
                self.sat_stalled |= self.sat_misses >= self.max_misses
        elif small and not self.sat_broken and self.greedy_budget and self.retry_budget:
            res = self.greedy.next_plan(max_steps, left(), min_steps, budget=self._retry_at)
            if res.status == SOLVED:
                self.answers["greedy"] += 1
                return res
            if res.status != TIMEOUT or left() == 0.0:
                return res
            # out of its budget: the SAT planner once more, and asked first again if it
            # answers (without a check past its cap: the stall was the machine's moment)
            self.retries += 1
            self.sat_stalled, rest = False, left()
            res = self._sat_plan(max_steps, self.retry_budget if rest is None else
                                 min(self.retry_budget, rest), min_steps, horizon_cap)
            if res.status == SOLVED:
                self.answers["sat"] += 1
                self.sat_misses = 0
                return res
            self.sat_stalled = True
            self._retry_at *= 4
        res = self.greedy.next_plan(max_steps, left(), min_steps)
        if res.status == SOLVED:
            self.answers["greedy"] += 1
        return res

    def _sat_plan(self, max_steps: int, budget: float, min_steps: int,
                  horizon_cap: float | None) -> PlanResult:
        """The SAT planner's shortest plan within ``budget`` seconds that keeps the greedy
        planner's constraints, or its last answer (``timeout`` if none): a plan its weaker
        constraints let through (blocker evidence that lasts until a blocker moves, rules
        over atoms it has no variables for) teaches it the prefix (or, for the goal, the
        plan) that breaks one, and it is asked again. A check past ``horizon_cap`` by more
        than ``stall`` seconds stalls it."""
        t0 = time.perf_counter()
        cap = horizon_cap if horizon_cap is not None else budget
        while True:
            before = len(self.sat.stats)
            left = budget - (time.perf_counter() - t0)
            res = self._sat_call(self.sat.next_plan, max_steps, max(0.0, left), min_steps,
                                 horizon_cap) if left > 0 else None
            if res is None:                           # no time left, or Z3 raised
                res = PlanResult(TIMEOUT, None, 0)
            if any(st.solve_s > cap + self.stall for st in self.sat.stats[before:]):
                self.sat_stalled = True
            if res.status != SOLVED:
                return res
            k = self.greedy.violation(res.actions)
            if k is None:
                return res
            self.rejected += 1
            if k > len(res.actions):
                self._sat_call(self.sat.exclude_plan, res.actions)
            else:
                self._sat_call(self.sat.exclude_prefix, res.actions[:k])
            if self.sat_broken:
                return PlanResult(TIMEOUT, None, 0)

    plan = next_plan


__all__ = ["GreedyTaskPlanner", "PortfolioTaskPlanner"]
