"""Task plans and transitions: the SAT task planner's plans, the transitions of their steps
with their success and failure counts, and what a plan's attempts teach the next one.

:class:`~tmpc.runtime.planners.taskplan.TaskPlanner` (geometric literals get blockers) gives the
shortest plan consistent with what was learnt. Each of its steps becomes a *transition* of the
step's symbolic state: ``(action, successor state)`` with success/failure counts. Before the
next plan is asked for, the last plan's prefix up to and including its first transition
without a success is excluded, and **blockers** are pinned (thesis §4.3.5): a transition that
succeeded shows its geometric literals hold after its prefix; one that never succeeded, with a
literal false at its best attempt (the projection closest to the precondition), shows that
literal false there. Pinned literals remove every plan that needs them at that point without
first running an action that may change them, not only the excluded prefix.

With a task planner that takes them (the greedy portfolio), a failed transition teaches more
than its prefix (docs/planning.md, "Anchors and state rules"). If some of its attempts collided
with movable objects alone (its *blockers*), its literals stay false until one of them moves;
and if the blockers stand where they stood at the start although one of them moved (taken up
and put back: a kitchen's radish on its spot), false wherever they stand there again
(:meth:`TaskPlans.put_back`). Otherwise, after at least :data:`RULE_FAILURES` failed attempts:

* never reached, its closest attempt a real miss: until one of the movable objects its literal
  names moves (the *anchors*: the object grasped, the one placed on; not what the hand holds),
  a grasp's literal is false (Blocks World E's right arm cannot reach `d`) and a placement is
  ruled out (with no anchors, for good: the left arm and the far tray). If the plan had put
  an anchor where it stands, that rule cannot hold; never reached at :data:`REACH_PLACES`
  places of its anchors (counted over every symbolic state where the action found them on
  the same support chain), the grasp or placement is then ruled out wherever they stand on
  that chain (a *reach rule*: Blocks World F's left arm cannot stack on `a` on the red tray,
  wherever on it the right arm put `a`; 144 of a run's 397 task plans failed there before,
  each excluded alone);
* every kept collided attempt hit the scene's fixed objects or nothing but the robot (the
  action's own objects excepted, as for blockers; one fixed hit at least,
  :meth:`TaskPlans.fixed_only`): the placement is ruled out wherever the object it goes on
  stands on the same stack (a *state rule* over its support chain: Blocks World's ceiling
  stops a tower of that height on the table, however it was built), until one of the
  movable objects some attempts hit as well moves.

A plan stuck at a transition one of these rules will rule out ends at once
(:meth:`TaskPlans.hopeless`), not after its batch budget, unless its attempts came close
(within :data:`MISS`): more batches may get there.

A placement's literal (``on~means e d``) does not name the hand, so its rules are the ground
action's (:meth:`~tmpc.runtime.planners.greedy.GreedyTaskPlanner.add_action_rule`): what one
arm cannot reach, the other may.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from tmpc.lang.semantics_module import MEANS_SUFFIX as MEANS
from tmpc.runtime.planners.greedy import PortfolioTaskPlanner
from tmpc.runtime.planners.optimal.options import OptimalOptions
from tmpc.runtime.planners.taskplan import SOLVED, TaskPlanner
from tmpc.runtime.problem import Mode, PlanningProblem

#: collided attempts a transition keeps for its blockers (16: a radish in front of a kitchen
#: cabbage is the only thing hit in 1 of 11 of the cabbage's collided grasps, the rest also hit
#: the shelf)
KEEP_COLLIDED = 16
#: failed attempts (none succeeded) before a transition's failure becomes an anchor or a state
#: rule: two of the decoupled planner's steps of 3 rounds of 16 projections (one unlucky step,
#: 1 in 12 for Blocks World E's left-arm grasp of `d`, must not rule a grasp out for good)
RULE_FAILURES = 96
#: failed attempts, every kept one against the scene's fixed objects, before a placement that
#: a state rule will rule out ends its plan (:meth:`TaskPlans.hopeless`): about one batch of
#: Blocks World E (a fifth block under the ceiling: 2,000-3,750 attempts a plan before)
FIXED_FAILURES = 5 * RULE_FAILURES
#: a blocker within this (metres) of where it stood at the start was put back there
PUT_BACK = 0.01
#: a never-reached transition's closest attempt this far (its distance) is a real miss, not a
#: projection that ran out of iterations
MISS = 0.02
#: failed attempts, none of which held, after which a transition is unreached however close
#: its closest attempt came: Blocks World F's left arm stacking on `a` on the red tray came
#: within 2 cm in 864 attempts and never held
MISS_FAILURES = 4 * RULE_FAILURES
#: distinct places (:data:`PLACE_GRID`) of an unreached action's anchors over its failed
#: attempts, in every symbolic state where they stand on the same support chain, before its
#: failure holds wherever they stand on that chain (a *reach rule*,
#: :meth:`TaskPlans.anchor_rules`)
REACH_PLACES = 4
#: the grid (metres) of the anchors' places a transition counts
PLACE_GRID = 0.02


@dataclass(eq=False)
class Transition:
    """An action of a symbolic state that task plans asked for (``action`` None: the goal's
    geometric literals, in a goal state)."""

    sym: int
    action: object | None
    to_sym: int
    successes: int = 0
    failures: int = 0
    #: (distance, mode, q) of the failed attempt closest to the precondition
    best_fail: tuple | None = None
    #: successes per source mode
    by_mode: dict = field(default_factory=dict)
    #: the last few attempts where the precondition held but the configuration collided,
    #: ``(mode, q)``: what blocked it (:meth:`TaskPlans.blockers`)
    collided: list = field(default_factory=list)
    #: the places (:data:`PLACE_GRID` cells) of the objects the action names and the robot
    #: does not hold, over the failed attempts (up to :data:`REACH_PLACES`)
    places: set = field(default_factory=set)
    #: the mode whose place was counted last (places are counted once per mode)
    place_mode: int = -1

    def count(self, mode_id: int) -> None:
        """One more success, from mode ``mode_id``."""
        self.successes += 1
        self.by_mode[mode_id] = self.by_mode.get(mode_id, 0) + 1

    @property
    def unreached(self) -> bool:
        """Never held anywhere (no collided attempt) and its closest attempt a real miss
        (:data:`MISS`), or no attempt held in :data:`MISS_FAILURES` however close they came."""
        return self.missed or (not self.collided and self.best_fail is not None
                               and self.failures >= MISS_FAILURES)

    @property
    def missed(self) -> bool:
        """Never held anywhere (no collided attempt) and its closest attempt a real miss
        (:data:`MISS`): :attr:`unreached` without the count of close attempts, which says
        nothing about whether more sampling gets there (:meth:`TaskPlans.hopeless`)."""
        return not self.collided and self.best_fail is not None and self.best_fail[0] >= MISS

    def record_failure(self, mode: Mode, q: np.ndarray, held: bool, distance: float) -> None:
        """A failed attempt at ``q`` (``held``: the precondition held there, a collision
        failed it); the best one (smallest distance, the precondition false) is kept for the
        blocker evidence :meth:`TaskPlans.learn` derives."""
        self.failures += 1
        if self.action is not None and len(self.places) < REACH_PLACES and \
                mode.id != self.place_mode:
            self.place_mode = mode.id
            self.places.add(self._place(mode))
        if self.action is not None and held:
            self.collided.append((mode, np.array(q)))
            del self.collided[:-KEEP_COLLIDED]
        if self.action is not None and not held and (self.best_fail is None
                                                     or distance < self.best_fail[0]):
            self.best_fail = (distance, mode, q)

    def _place(self, mode: Mode) -> tuple:
        """Where the objects the action names stand in ``mode`` (grid cells), those the robot
        holds left out."""
        held = {h.lower() for h in (mode.held or {})}
        poses = {k.lower(): T for k, T in mode.poses.items()}
        return tuple((x, tuple(np.floor(np.asarray(poses[x])[:3, 3] / PLACE_GRID).astype(int)))
                     for x in (a.lower() for a in self.action.args)
                     if x in poses and x not in held)


class TaskPlans:
    """The task planner, the current plan and its transitions, and every transition known per
    symbolic state (``transitions``: kept across task plans)."""

    def __init__(self, problem: PlanningProblem, options: OptimalOptions, counts: dict):
        self.p = problem
        self.opt = options
        self.counts = counts
        self.tp: TaskPlanner | None = None
        self.transitions: dict[int, list[Transition]] = {}
        self.plan: list | None = None
        self.plan_transitions: list[Transition] = []
        self.exhausted = False
        #: the symbolic predicates with a placement meaning (``P~means``), on first use
        self._placing: set[str] | None = None
        #: :meth:`fixed_rule_due` per transition: (failures // RULE_FAILURES, answer)
        self._fixed_due: dict[int, tuple[int, bool]] = {}
        #: the places an unreached action's anchors were tried at, per (action id, support
        #: chain), over every symbolic state the chain holds in (:meth:`anchor_rules`)
        self.reach_places: dict[tuple[int, tuple[int, ...]], set] = {}
        #: the literals :meth:`probe_alike` projected, ``(predicate, args)``
        self._probed: set[tuple] = set()

    def task_planner(self) -> TaskPlanner:
        """The task planner ``task_planner`` names (``auto``: the SAT-or-greedy portfolio to a
        first solution, else SAT), built on first use (or by the run's warm-up)."""
        if self.tp is None:
            kind = self.opt.task_planner
            if kind == "auto":
                kind = "greedy" if self.opt.first_solution else "sat"
            if kind == "greedy":
                self.tp = PortfolioTaskPlanner(self.p.ground,
                                               weight=self.opt.task_weight or None)
            else:
                self.tp = TaskPlanner(self.p.ground, geometric=True)
        return self.tp

    def next_plan(self, deadline: float) -> bool:
        """Learn from the last plan (exclusion, blockers) and ask for the next one; False when
        there is none (the graph keeps growing with the transitions known)."""
        t = time.perf_counter()
        try:
            if self.tp is None:
                self.task_planner()
            elif self.plan is not None:
                self.learn()
            if self.exhausted:
                return False
            left = None if math.isinf(deadline) else max(0.0, deadline - time.perf_counter())
            cap = self.opt.horizon_cap if self.opt.first_solution else None
            res = self.tp.next_plan(self.opt.max_steps, left, min_steps=self.opt.min_steps,
                                    horizon_cap=cap)
        finally:
            self.p.timers.task_planning += time.perf_counter() - t
        if res.status != SOLVED:
            self.exhausted = res.status != "timeout"
            self.plan = None
            return False
        self.counts["task_plans"] += 1
        shortened = getattr(getattr(self.tp, "greedy", self.tp), "shortened", 0)
        if shortened:
            self.counts["task_plans_shortened"] = shortened
        if getattr(self.tp, "rejected", 0):
            # SAT plans that broke a constraint only the greedy planner holds
            self.counts["sat_plans_rejected"] = self.tp.rejected
        if getattr(self.tp, "retries", 0):
            # greedy searches past their budget that asked the stalled SAT planner again
            self.counts["sat_retries"] = self.tp.retries
        self.plan = list(res.actions)
        self.plan_transitions = []
        sym = self.p.ground.init
        for action in self.plan:
            to = self.p.ground.apply(sym, action)
            self.plan_transitions.append(self.transition(sym, action, to))
            sym = to
        if self.p.goal_formula() is not None:
            self.transition(sym, None, sym)
        return True

    def hopeless(self) -> bool:
        """Is the current plan stuck where more sampling of it will not get: its first
        transition without a success failed :data:`RULE_FAILURES` times, never held and its
        closest attempt a real miss (:data:`MISS`; :attr:`Transition.missed`, not
        :data:`MISS_FAILURES` close ones: Blocks World D v8's second plan, ended so, left its
        third to plan from 18,686 vertices in 30 s, where it plans from 8,107 in 7 s
        otherwise), or :data:`FIXED_FAILURES` times with a state rule due
        (:meth:`fixed_rule_due`)? That is what :meth:`learn` and :meth:`anchor_rules` learn
        when the plan ends, so it ends now rather than after its batch budget. Blocks World E
        spent 65 s of one batch on 1,500 grasps of `b` out of the right arm's reach, and up to
        3,750 attempts a plan at a fifth block under the table's ceiling. A transition that
        fails often for other reasons is not given up: the full kitchen's grasp of a cabbage
        behind its radish holds in rare configurations, and a plan ended after 960 of its
        failures (fifteenth session, removed) never planned kitchen v0 and v1, which plan
        without it."""
        if self.plan is None or not getattr(self.tp, "takes_blockers", False):
            return False
        tr = next((tr for tr in self.plan_transitions if tr.successes == 0), None)
        if tr is None or tr.action is None or tr.failures < RULE_FAILURES:
            return False
        if not tr.collided:
            return tr.missed
        return tr.failures >= FIXED_FAILURES and self.fixed_rule_due(tr)

    def fixed_rule_due(self, tr: Transition) -> bool:
        """Would :meth:`anchor_rules` learn a state rule from ``tr`` now: a placement on a
        movable object whose kept collided attempts (all :data:`KEEP_COLLIDED` of them) each
        hit the scene's fixed objects? Checked once per :data:`RULE_FAILURES` failures (16
        collision checks)."""
        key = tr.failures // RULE_FAILURES
        known = self._fixed_due.get(id(tr))
        if known is not None and known[0] == key:
            return known[1]
        due = len(tr.collided) >= KEEP_COLLIDED and \
            self.fixed_only(self.attempt_hits(tr)) and \
            any(placement and anchors and self.support_chain(tr.sym, anchors)
                for _, anchors, placement in self.anchored(tr))
        self._fixed_due[id(tr)] = (key, due)
        return due

    def transition(self, sym: int, action, to: int) -> Transition:
        """The transition ``(action, to)`` of symbolic state ``sym``, made when new."""
        known = self.transitions.setdefault(sym, [])
        for tr in known:
            if tr.action is action and tr.to_sym == to:
                return tr
        tr = Transition(sym, action, to)
        known.append(tr)
        return tr

    def learn(self) -> None:
        """Exclude the last plan's prefix through its first transition without a success (all
        of it if every one succeeded) and pin the blockers its transitions showed."""
        plan, trs = self.plan, self.plan_transitions
        k = next((i for i, tr in enumerate(trs) if tr.successes == 0), len(trs))
        for i, tr in enumerate(trs[:k + 1]):
            lits = ([(lit, True) for lit in tr.action.pre_geometric] if tr.successes else
                    [(lit, False) for lit in self.false_literals(tr)])
            for lit, value in lits:
                if self.tp.add_evidence(plan[:i], lit, value):
                    self.counts["evidence"] += 1
            if not tr.successes and getattr(self.tp, "takes_blockers", False):
                # the precondition held but configurations collided with movable objects
                # alone: the literals stay false until one of those moves
                hits = self.attempt_hits(tr)
                blockers = self.blockers(tr, hits)
                if blockers:
                    for lit in tr.action.pre_geometric:
                        if self.tp.add_evidence(plan[:i], lit, False, blockers):
                            self.counts["blockers"] = self.counts.get("blockers", 0) + 1
                    atoms = self.put_back(plan[:i], tr, blockers)
                    for lit in tr.action.pre_geometric if atoms else ():
                        if self.tp.add_atom_rule(lit, atoms):
                            self.counts["put_back"] = self.counts.get("put_back", 0) + 1
                elif tr.failures >= RULE_FAILURES:
                    self.anchor_rules(plan[:i], tr, hits)
        self.tp.exclude_prefix(plan[:min(len(plan), k + 1)])
        self.plan = None

    def anchor_rules(self, prefix: list, tr: Transition, hits: list | None = None) -> None:
        """What a transition that failed for reasons no movable object explains teaches (the
        module docstring). Never reached, a real miss (:data:`MISS` at its closest): a grasp's
        literal false until one of its anchors moves; a placement ruled out until one of its
        anchors moves (none: for good). Every kept collided attempt against the scene's fixed
        objects: the placement ruled out wherever the support chain of what it goes on holds,
        until a movable object some of them hit as well moves. A placement's literal does not
        name the hand, so its rules are the action's. ``hits``: :meth:`attempt_hits` of
        ``tr``, if known."""
        tp = self.task_planner()
        unreached = tr.unreached
        hits = self.attempt_hits(tr) if hits is None else hits
        fixed = self.fixed_only(hits)
        # movable objects some attempts hit besides the fixed ones: the rule holds until one
        # of them moves (none: wherever the chain holds)
        movers = sorted(set().union(*(hit[0] for hit in hits))) if fixed else []
        moved = tp.moved(prefix)
        for lit, anchors, placement in self.anchored(tr):
            if unreached and anchors and moved.intersection(x.lower() for x in anchors):
                # the anchors were put where they stand: unreached at REACH_PLACES places of
                # them on one support chain (over the states it holds in), it is unreached
                # wherever they stand on that chain
                chain = self.support_chain(tr.sym, anchors)
                if chain and self.seen_at_places(tr, chain) and (
                        tp.add_action_rule(prefix, tr.action, (), atoms=chain) if placement
                        else tp.add_atom_rule(lit, chain)):
                    self.counts["reach_rules"] = self.counts.get("reach_rules", 0) + 1
            elif unreached and (tp.add_action_rule(prefix, tr.action, anchors) if placement
                                else anchors and tp.add_evidence(prefix, lit, False, anchors)):
                self.counts["anchors"] = self.counts.get("anchors", 0) + 1
            if self.opt.probe_reach and tr.missed and not placement and anchors:
                self.probe_alike(prefix, tr, lit)
            if fixed and placement and anchors:
                chain = self.support_chain(tr.sym, anchors)
                # what the chain stands on cannot move while it holds: not a mover
                below = {x.lower() for i in chain for x in self.p.ground.atoms[i].args}
                others = [x for x in movers if x not in below]
                if chain and moved.intersection(others):
                    # the plan moved one: at REACH_PLACES places of the anchors on the chain,
                    # the placement is ruled out wherever the chain holds
                    others = () if self.seen_at_places(tr, chain) else None
                if chain and others is not None and \
                        tp.add_action_rule(prefix, tr.action, others, atoms=chain):
                    self.counts["state_rules"] = self.counts.get("state_rules", 0) + 1
            elif fixed and placement and tp.add_action_rule(prefix, tr.action, movers):
                # on a fixed support: nothing the plan moves changes it but the movers
                self.counts["fixed_rules"] = self.counts.get("fixed_rules", 0) + 1

    def probe_alike(self, prefix: list, tr: Transition, lit) -> None:
        """``probe_reach``: ``tr``'s grasp literal ``lit`` never held and missed by a real
        miss, so the same literal of every other movable object (the same predicate, the same
        arguments but that object) that ``prefix`` did not move, the robot does not hold and
        that stands where it started in the mode of ``tr``'s closest attempt is projected
        there:
        :data:`RULE_FAILURES` starts (that attempt's configuration and uniform ones), the
        first ground action with that literal as its only positive geometric one. Missed
        there too (none held, none within :data:`MISS`), it is false until the object moves
        (the anchor rule its own failures would teach, whatever came before). Each literal
        is probed once a run. Blocks World: the arm on the other side misses every block of
        a tower, and each cost a task plan to learn."""
        tp = self.task_planner()
        _, mode, q = tr.best_fail
        movable = tp.movable
        held = {h.lower() for h in (mode.held or {})}
        moved = tp.moved(prefix)
        # where the objects stand in that mode and at the start (the attempt may be another
        # plan's, which moved them and put them back on the same support)
        now = {k.lower(): T for k, T in mode.poses.items()}
        first = {k.lower(): T for k, T in self.p.initial.poses.items()}
        own = [i for i, a in enumerate(lit.args) if a.lower() in movable]
        if len(own) != 1:
            return
        k = own[0]
        for action in self.p.ground.actions:
            geo = [g for g in action.pre_geometric if g.positive]
            if len(geo) != 1 or not self.p.has_geometry(action):
                continue
            other = geo[0]
            y = other.args[k].lower() if len(other.args) == len(lit.args) else None
            if other.predicate != lit.predicate or y is None or y == lit.args[k].lower() or \
                    y not in movable or y in moved or y in held or \
                    any(a != b for i, (a, b) in enumerate(zip(other.args, lit.args)) if i != k) \
                    or y not in now or y not in first or \
                    not np.array_equal(np.asarray(now[y]), np.asarray(first[y])):
                continue
            key = (other.predicate, tuple(other.args))
            if key in self._probed:
                continue
            self._probed.add(key)
            rng = np.random.default_rng([action.id, 7])
            starts = np.vstack([np.asarray(q, float)[None],
                                self.p.uniform(rng, RULE_FAILURES - 1)])
            _, holds, dist = self.p.project_raw(mode, action, starts)
            self.counts["probes"] = self.counts.get("probes", 0) + 1
            if not holds.any() and float(dist.min()) >= MISS and \
                    tp.add_evidence(prefix, other, False, [y]):
                self.counts["probe_rules"] = self.counts.get("probe_rules", 0) + 1

    @staticmethod
    def fixed_only(hits: list) -> bool:
        """Did ``hits`` (:meth:`attempt_hits`), the kept collided attempts of a transition
        with no blockers, fail for reasons no movable object explains: each hit the scene's
        fixed objects or nothing but the robot itself, what it holds and the action's own
        objects, and one at least a fixed object? An attempt of the second kind says nothing
        about the other movable objects either way. Counted against the rule before, one
        such attempt in 16 kept Blocks World E's left arm stacking a fourth block under the
        table's ceiling from its state rule, and the task planner proposed that tower in 20
        more plans (docs/planning.md, "Anchors and state rules")."""
        return any(fixed for _, fixed in hits) and all(fixed or not hit for hit, fixed in hits)

    def seen_at_places(self, tr: Transition, chain: list[int]) -> bool:
        """Have ``tr``'s action's attempts, in every symbolic state where its anchors stood
        on ``chain``, been at :data:`REACH_PLACES` places of them (``tr``'s counted in)?"""
        places = self.reach_places.setdefault((tr.action.id, tuple(sorted(chain))), set())
        places |= tr.places
        return len(places) >= REACH_PLACES

    def anchored(self, tr: Transition) -> list[tuple]:
        """``(literal, anchors, placement?)`` for each positive geometric literal of ``tr``'s
        action: its anchors are the movable objects it names that the robot does not hold in
        ``tr``'s attempts (the block grasped, the one placed on), and a placement's literal is
        a meaning (``P~means``)."""
        movable = self.task_planner().movable
        held = {h.lower() for mode in self._modes(tr) for h in (mode.held or {})}
        return [(lit, [x for x in lit.args if x.lower() in movable and x.lower() not in held],
                 lit.predicate.endswith(MEANS))
                for lit in tr.action.pre_geometric if lit.positive]

    def put_back(self, prefix: list, tr: Transition, blockers: list[str]) -> list[int]:
        """The atoms that say where ``blockers`` stand (:meth:`support_chain`) if some of them
        moved in ``prefix`` and every one stands where it stood at the start: the same
        placement atoms, and in every mode of ``tr``'s collided attempts a position within
        :data:`PUT_BACK` of its first (a turn is free: a radish is round, and a stable pose
        about a vertical axis may come back turned). They block again there, whatever came
        before; otherwise none (blockers that never moved are the blocker rule's)."""
        moved = self.task_planner().moved(prefix)
        if not blockers or not moved.intersection(blockers):
            return []
        atoms = self.support_chain(tr.sym, blockers)
        start = set(self.support_chain(self.p.ground.init, blockers))
        if not atoms or set(atoms) != start:
            return []
        first = {k.lower(): T for k, T in self.p.initial.poses.items()}
        for mode, _ in tr.collided:
            now = {k.lower(): T for k, T in mode.poses.items()}
            for b in blockers:
                a, c = first.get(b), now.get(b)
                if a is None or c is None:
                    return []
                if np.linalg.norm(np.asarray(a)[:3, 3] - np.asarray(c)[:3, 3]) > PUT_BACK:
                    return []
        return atoms

    @staticmethod
    def _modes(tr: Transition) -> list[Mode]:
        """The modes of ``tr``'s kept attempts."""
        modes = [mode for mode, _ in tr.collided]
        if tr.best_fail is not None:
            modes.append(tr.best_fail[1])
        return modes

    def collisions(self, mode: Mode, q: np.ndarray, own=frozenset()) -> tuple[set[str], bool]:
        """What the configuration ``q`` in ``mode`` collides with: the movable objects (ones
        some action moves: the task planner's ``movable``) it hits, ``own`` ones (lower-case:
        the action's) and what the robot holds excepted, and whether it hits an object none
        moves, its own included (a grasp against the bench it picks from; a robot link against
        itself is neither)."""
        movable = self.task_planner().movable
        skip = {h.lower() for h in (mode.held or {})} | set(own)
        scene = {k.lower() for k in mode.poses}
        hit, fixed = set(), False
        for a, b, _ in self.p.collision.check(q, poses=mode.poses, attached=mode.held).pairs:
            for x in (a.lower(), b.lower()):
                if x not in movable:
                    fixed |= x in scene
                elif x not in skip:
                    hit.add(x)
        return hit, fixed

    def support_chain(self, sym: int, objects: list[str]) -> list[int]:
        """The atoms of state ``sym`` that say what ``objects`` stand on, down to the scene's
        fixed objects: ``(P x y)`` with a placement meaning (a ``P~means``), then y's."""
        g = self.p.ground
        movable = self.task_planner().movable
        if self._placing is None:
            self._placing = {lit.predicate[:-len(MEANS)] for a in g.actions
                             for lit in a.pre_geometric if lit.predicate.endswith(MEANS)}
        out: list[int] = []
        todo, seen = [x.lower() for x in objects], set()
        while todo:
            x = todo.pop()
            if x in seen:
                continue
            seen.add(x)
            for i, atom in enumerate(g.atoms):
                if (sym >> i) & 1 and atom.predicate in self._placing and atom.args and \
                        atom.args[0].lower() == x:
                    out.append(i)
                    todo += [y.lower() for y in atom.args[1:] if y.lower() in movable]
        return out

    def attempt_hits(self, tr: Transition) -> list[tuple[set[str], bool]]:
        """:meth:`collisions` of each of ``tr``'s kept collided attempts, the action's own
        objects excepted."""
        own = {x.lower() for x in tr.action.args}
        return [self.collisions(mode, q, own) for mode, q in tr.collided]

    def blockers(self, tr: Transition, hits: list | None = None) -> list[str]:
        """The movable objects (ones some action moves: the portfolio's ``movable``) that
        ``tr``'s collided attempts hit where they hit nothing else, the action's own arguments
        and what the robot holds excepted (:meth:`collisions`): the attempts that moving those
        objects would make valid. An attempt that also hit an object none moves says nothing
        about them (a grasp from behind a kitchen cabbage hits the shelf's back). ``hits``:
        :meth:`attempt_hits` of ``tr``, if known."""
        out: set[str] = set()
        for hit, fixed in self.attempt_hits(tr) if hits is None else hits:
            if not fixed:
                out |= hit
        return sorted(out)

    def false_literals(self, tr: Transition) -> list:
        """The geometric literals of ``tr``'s action that are false at its best failed
        attempt (none if its precondition never failed there: only collisions did)."""
        if tr.best_fail is None:
            return []
        _, mode, q = tr.best_fail
        geo = self.p.geo_oracle(mode, q)
        return [lit for lit in tr.action.pre_geometric
                if geo(lit.predicate, lit.args) != lit.positive]
