"""The ``decoupled`` planner's loop: a task plan, transition configurations from the
projection sampler, a motion planner between them, backtracking to new transition samples and
then to the next task plan.

Task plans come from :class:`~tmpc.runtime.planners.optimal.tasks.TaskPlans` exactly as the
optimal planner uses them to its first solution (the SAT planner's shortest plan while its
encoding is small, else the greedy search: :mod:`tmpc.runtime.planners.greedy`): consistent with
what was learnt, the last plan's prefix through its first step that never succeeded excluded
and blockers pinned before the next one (thesis §4.3.5; blocker rules for collisions with
movable objects). A plan is followed depth first: at each step, up to ``samples`` transition
configurations are projected onto the action's geometric precondition (the first round from the
current configuration, seven starts around it and eight uniform; up to ``sample_rounds`` rounds
of wider and uniform starts while none is valid; the joints the action does not use, such as
the other arm, back where the run started them with ``park_idle``, a manifest's,
:meth:`DecoupledPlanner.idle_joints`;
collision-free in the current mode; nearest first), and the motion to each is planned
(``motion_planner``, ``motion_checks`` of tmpc's checks) until one succeeds; the step's successor
mode is then derived at that configuration. A step none of whose samples can be reached sends
the search back to the previous step's next sample (with ``backjump``, a manifest's: of the
latest step that moved an object its failures depend on, :meth:`DecoupledPlanner.culprits`);
a plan whose first step is exhausted, or whose motions took ``plan_budget`` attempts (or
``plan_budget_per_step`` per step of a longer plan), is given up for the next task plan.
With ``lazy_motions`` (a manifest's) the motions wait until every step has a configuration
(:meth:`DecoupledPlanner.follow`); with ``lookahead`` a step that grasps or puts down an
object tries first the configurations after which the plan's next step on that object holds
(:meth:`DecoupledPlanner.looking_ahead`); with ``retreat_sideways`` a motion's ends retreat by
the hand that acts there, and with ``park_first`` the arm a step does not use goes back to its
place first, alone (:meth:`DecoupledPlanner.motion`); with ``spread_placements`` a release's
configurations go the roomiest first, with more aimed where the room grows unless
``aim_placements`` is false (:mod:`tmpc.runtime.planners.spread`). When no task plan is
left (the exclusions and blockers were learnt from a few samples per step, not proofs), task
planning starts afresh with new samples, until the time limit. A goal with geometric literals
is one more step (the goal's projection). The final plan's motions are shortcut by tmpc
(:func:`~tmpc.runtime.planners.decoupled.lazyprm.shortcut`, until the time limit) unless
``simplify`` is ``ompl`` (OMPL's simplifier then runs on them instead). Deterministic from
the seed: numpy's generator for the samples, OMPL's seeded per motion.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.planners.decoupled import DEFAULT_MOTION_PLANNER
from tmpc.runtime.planners.decoupled.lazyprm import shortcut
from tmpc.runtime.planners.decoupled.motion import (check_motion_planner, mode_segments,
                                                    ompl_space, plan_motion)
from tmpc.runtime.planners.decoupled.space import motion_seed, path_cost
from tmpc.runtime.planners.optimal import OptimalOptions, OptimalResult
from tmpc.runtime.planners.optimal.options import TASK_PLANNERS
from tmpc.runtime.planners.optimal.tasks import RULE_FAILURES, TaskPlans
from tmpc.runtime.planners.retreat import best_retreat, hand_frames, retreat_chains
from tmpc.runtime.planners.spread import Room
from tmpc.runtime.problem import PROJECTION_BATCH, Mode, PlanningProblem


#: collided configurations of a step's last sampling checked for what they hit
#: (:meth:`DecoupledPlanner.culprits`)
BLAME_CHECKS = 4
#: valid transition configurations kept per set of joints the actions move, the newest, as
#: projection starts (``seed_starts``)
SEED_POOL = 32
#: a seed start's noise, per joint, a share of the joint's range
SEED_NOISE = 0.02
#: seconds per motion of tmpc's own motion planner (``motion_planner = "tmpc"``) when no
#: ``motion_budget`` is given
LAZY_PRM_SECONDS = 2.0


@dataclass(frozen=True)
class DecoupledOptions:
    motion_planner: str = DEFAULT_MOTION_PLANNER
    #: an OMPL planner's budget per motion in tmpc's checks (its state and motion checks,
    #: :attr:`~tmpc.runtime.planners.decoupled.space.MotionSpace.checks`; a manifest's
    #: ``[planner]``): a count, not seconds, so the same seed gives the same plan on any
    #: machine under any load (docs/planning.md, "The motion budget"). 4,000 were about 2 s
    #: of Blocks World E's motions
    motion_checks: int = 4000
    #: seconds per motion: tmpc's lazy PRM's budget (None: :data:`LAZY_PRM_SECONDS`), and
    #: for OMPL's planners a wall-clock ceiling besides their checks (None: none but the
    #: run's time limit; given, a run depends on the machine's speed again)
    motion_budget: float | None = None
    samples: int = 4                   # transition configurations tried per step
    plan_budget: int = 40              # motions tried per task plan before the next one,
    plan_budget_per_step: int = 3      # ... or this many per step of a longer plan
    sample_rounds: int = 3             # rounds of projections before a step counts as failed
    projection_iterations: int = 30    # as the optimal planner's
    resolution: float = 0.05           # motion-check resolution (the validator's default)
    shortcut: bool = True              # tmpc's shortcuts on the plan (off: --simplify ompl)
    shortcut_rounds: int = 32          # ... rounds of 16 tries, each round one batched check
    #: each motion leaves its start and reaches its end by the hand's straight retreat (up,
    #: back or both; tmpc's), this many steps of ``retreat_step`` metres (0: off)
    retreat_steps: int = 4
    retreat_step: float = 0.025
    #: a plan's transition configurations first, its motions once every step has one
    #: (:meth:`DecoupledPlanner.follow`; tmpc's; a manifest's ``[planner]``): Blocks
    #: World E 10/10 with it; off by default, since Sort Clutter planned 7/10 with it, 10/10
    #: without (docs/benchmarks.md)
    lazy_motions: bool = False
    #: a step that grasps or releases an object takes, of its transition configurations,
    #: first those from which the plan's next step on that object holds
    #: (:meth:`DecoupledPlanner.looking_ahead`; tmpc's; a manifest's ``[planner]``): Blocks
    #: World F-J's; off by default, Blocks E planned 9/10 with it (docs/benchmarks.md)
    lookahead: bool = False
    #: a step none of whose configurations led on sends the search back to the latest step
    #: that moved an object its failures depend on, not to the step before it
    #: (:meth:`DecoupledPlanner.culprits`; tmpc's; a manifest's ``[planner]``): Blocks World
    #: E v0-v4 all planned with it (54-248 s); off by default until measured in full
    #: (docs/planning.md)
    backjump: bool = False
    #: the arm a step does not use starts where the run started it
    #: (:meth:`DecoupledPlanner.idle_joints`; tmpc's; a manifest's ``[planner]``): Blocks
    #: World E-J's (E 10/10, median 69.0 s against 83.3 s without; G 9/10 against 7/10); off
    #: by default: Sort Clutter's first four variations took 1.3-3.9x their table times with
    #: it, though side by side its v0-v4 took 0.69-1.21x (median 0.94x) the time without it
    #: (docs/benchmarks.md)
    park_idle: bool = False
    #: the longest edge (Euclidean over the configuration's coordinates) OMPL's planner
    #: grows its trees by (0: OMPL's own, a fifth of the space's extent: 3.5 on Sort
    #: Clutter's mobile PR2; a manifest's ``[planner]``)
    motion_range: float = 0.0
    #: of the 16 projection starts of each round after a step's first (which found no valid
    #: configuration), this many (in place of uniform ones) are valid transition
    #: configurations found before by actions that move the same joints (the same arm), a
    #: little perturbed (:meth:`DecoupledPlanner.seeded`; tmpc's; a manifest's
    #: ``[planner]``; 0: off)
    seed_starts: int = 0
    #: a motion's retreats move the hand its end's action grasps or releases with (the
    #: longest chain of any hand without one), and may slide it sideways too
    #: (:data:`~tmpc.runtime.planners.retreat.SIDEWAYS`; tmpc's; a manifest's ``[planner]``)
    retreat_sideways: bool = False
    #: with ``park_idle``, a motion whose end parks the arm its action does not use moves that
    #: arm first, alone, then the rest (:meth:`DecoupledPlanner.motion`; tmpc's; a manifest's
    #: ``[planner]``). With ``retreat_sideways`` and seeds, Blocks World E: max 45.9 s
    #: against 124.9 s with seeds alone, medians alike; Blocks H 10/10 both, max 237.1 s
    #: against 273.2 s; off by default: Blocks G with the three left v3 unplanned in 300 s
    #: (docs/planning.md)
    park_first: bool = False
    #: a release's configurations the roomiest first (:mod:`tmpc.runtime.planners.spread`);
    #: a manifest's
    spread_placements: bool = False
    #: with it, more configurations of a release projected from starts aimed the way the room
    #: grows (:meth:`~tmpc.runtime.planners.spread.Room.around`); a manifest's, on by default
    #: (Blocks F: median 38.9 s without them, 70.2 s with them on seven variations)
    aim_placements: bool = True
    #: with ``backjump``, a plan ends at a step whose configurations are exhausted with no
    #: culprit when its transition never held anywhere and came no closer than a real miss
    #: (:attr:`~tmpc.runtime.planners.optimal.tasks.Transition.missed`: out of the arm's
    #: reach), once it has failed enough for a rule (:meth:`DecoupledPlanner.follow`;
    #: tmpc's; a manifest's ``[planner]``)
    give_up_missed: bool = False
    #: a grasp out of reach has the same grasp of every object not moved yet probed where it
    #: stands (:attr:`~tmpc.runtime.planners.optimal.OptimalOptions.probe_reach`; tmpc's; a
    #: manifest's ``[planner]``)
    probe_reach: bool = False
    #: with ``lazy_motions``, a motion of a chain whose transitions all hold that fails is
    #: planned once more on this multiple of the motion budget before the search backtracks
    #: (:meth:`DecoupledPlanner.chain_motions`; tmpc's; a manifest's ``[planner]``; 1: off)
    chain_retry: float = 1.0
    min_steps: int = 0
    max_steps: int = 100
    task_planner: str = "auto"         # as the optimal planner's (OptimalOptions.task_planner)


class DecoupledPlanner:
    """Task plan first, then motions (see the module docstring); ``solve(time_limit,
    progress=None)``, stopping at the first solution."""

    def __init__(self, problem: PlanningProblem, seed: int = 0,
                 options: DecoupledOptions = DecoupledOptions()):
        self.p = problem
        self.opt = options
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        # the shortcuts' own stream: the transitions drawn do not depend on --simplify
        self.shortcut_rng = np.random.default_rng([seed, 1])
        # the lookahead's: the transitions drawn do not depend on it either
        self.ahead_rng = np.random.default_rng([seed, 2])
        self.counts = {"task_plans": 0, "evidence": 0, "transition_samples": 0,
                       "transition_failures": 0, "transitions": 0, "motions": 0,
                       "motion_failures": 0, "backtracks": 0, "task_restarts": 0, "deepest_step": 0}
        self.tasks = TaskPlans(problem, OptimalOptions(min_steps=options.min_steps,
                                                       max_steps=options.max_steps,
                                                       first_solution=True,
                                                       task_planner=options.task_planner,
                                                       probe_reach=options.probe_reach),
                               self.counts)
        self.space = None
        self.hands: list[int] | None = None
        self.mode_count = 1
        self.motion_seconds = 0.0
        self.plan_depth = 0              # the deepest step the last plan followed reached
        #: the configurations of the last :meth:`transition_samples` call where the
        #: precondition held but that collided (at most :data:`BLAME_CHECKS`; with
        #: ``backjump``)
        self.collided_now: list[np.ndarray] = []
        #: per ground action (None: the goal), the joints its starts put where the run
        #: started them (:meth:`idle_joints`; learnt from its first projection)
        self.idle: dict = {}
        #: per ground action (None: the goal), the joints its first projection moved; and
        #: per such set of joints, the newest valid transition configurations (``seed_starts``)
        self.moves: dict = {}
        self.pool: dict[bytes, list[np.ndarray]] = {}
        self._carried: list[frozenset] | None = None
        #: with ``spread_placements``, the room of a release's configurations
        self.room = Room(problem) if options.spread_placements else None

    @classmethod
    def from_options(cls, problem: PlanningProblem, seed: int = 0,
                     overrides: dict | None = None) -> "DecoupledPlanner":
        """The registry's factory: ``motion_planner``, ``motion_budget``, ``motion_checks``,
        ``samples`` and ``simplify`` from the command line (``motion_budget``,
        ``motion_checks``, ``samples``, ``min_steps``, ``max_steps`` also from the run
        configuration's [planner]). E850 for an unknown motion planner, E851 for a value out
        of range."""
        config = problem.world.config
        params = dict(config.params) if config is not None else {}
        over = {k: v for k, v in (overrides or {}).items() if v is not None}
        base = DecoupledOptions()
        budget = over.get("motion_budget", params.get("motion_budget", base.motion_budget))
        opts = DecoupledOptions(
            motion_planner=check_motion_planner(str(over.get("motion_planner",
                                                             base.motion_planner))),
            motion_budget=None if budget is None else float(budget),
            motion_checks=int(over.get("motion_checks",
                                       params.get("motion_checks", base.motion_checks))),
            samples=int(over.get("samples", params.get("samples", base.samples))),
            shortcut=over.get("simplify", "tmpc") != "ompl",
            min_steps=int(params.get("min_steps", base.min_steps)),
            max_steps=int(params.get("max_steps", base.max_steps)),
            task_planner=str(over.get("task_planner",
                                      params.get("task_planner", base.task_planner))),
            lazy_motions=params.get("lazy_motions", base.lazy_motions) is True,
            lookahead=params.get("lookahead", base.lookahead) is True,
            backjump=params.get("backjump", base.backjump) is True,
            park_idle=params.get("park_idle", base.park_idle) is True,
            motion_range=float(params.get("motion_range", base.motion_range)),
            seed_starts=int(params.get("seed_starts", base.seed_starts)),
            retreat_sideways=params.get("retreat_sideways", base.retreat_sideways) is True,
            park_first=params.get("park_first", base.park_first) is True,
            spread_placements=params.get("spread_placements",
                                         base.spread_placements) is True,
            aim_placements=params.get("aim_placements", base.aim_placements) is True,
            give_up_missed=params.get("give_up_missed", base.give_up_missed) is True,
            probe_reach=params.get("probe_reach", base.probe_reach) is True,
            chain_retry=float(params.get("chain_retry", base.chain_retry)),
            projection_iterations=int(params.get("projection_iterations",
                                                 base.projection_iterations)))
        if opts.task_planner not in TASK_PLANNERS:
            raise InputError(error("E851", f"task planner {opts.task_planner!r} is unknown",
                                   None, f"one of {', '.join(TASK_PLANNERS)}"))
        if not ((opts.motion_budget is None or opts.motion_budget > 0)
                and opts.motion_checks >= 1 and opts.samples >= 1 and opts.motion_range >= 0
                and opts.chain_retry >= 1
                and 0 <= opts.seed_starts <= PROJECTION_BATCH // 2):
            raise InputError(error("E851", f"decoupled: motion budget {opts.motion_budget}, "
                                   f"motion checks {opts.motion_checks}, samples "
                                   f"{opts.samples}, motion range {opts.motion_range}, "
                                   f"seed_starts {opts.seed_starts} or chain_retry "
                                   f"{opts.chain_retry} out of range", None,
                                   "the motion budget is > 0 seconds, motion checks >= 1, "
                                   "samples >= 1, the motion range >= 0, seed_starts "
                                   f"0..{PROJECTION_BATCH // 2}, chain_retry >= 1"))
        return cls(problem, seed, opts)

    def warm_up_calls(self) -> list:
        """The SAT task planner and the OMPL space, built beside the kernel loads."""
        return [self.tasks.task_planner, self.motion_space]

    # ---- what the run's progress line reads --------------------------------------------------
    @property
    def modes(self) -> range:
        return range(self.mode_count)

    @property
    def node_mode(self) -> range:
        return range(self.counts["motions"])

    def motion_space(self):
        if self.space is None and self.opt.motion_planner != "tmpc":
            self.space = ompl_space(self.p, self.opt.resolution)
            self.space.range = self.opt.motion_range
        return self.space

    # ---- the loop ----------------------------------------------------------------------------
    def solve(self, time_limit: float, progress=None) -> OptimalResult:
        t0 = time.perf_counter()
        deadline = t0 + time_limit
        p = self.p
        status, path = "partial", [(p.q0.copy(), p.initial, None)]
        try:
            self.motion_space()
            while time.perf_counter() < deadline:
                if not self.tasks.next_plan(deadline):
                    if self.tasks.exhausted and self.counts["task_plans"] == 0:
                        break                # not even one plan: the task is unsolvable
                    if self.tasks.exhausted:  # what was learnt ruled everything out: afresh
                        self.counts["task_restarts"] += 1
                        self.tasks = TaskPlans(self.p, self.tasks.opt, self.counts)
                    continue
                steps = [(tr.action, tr) for tr in self.tasks.plan_transitions]
                if p.goal_formula() is not None:
                    sym = p.ground.init
                    for a in self.tasks.plan:
                        sym = p.ground.apply(sym, a)
                    steps.append((None, self.tasks.transition(sym, None, sym)))
                found = self.follow(steps, deadline)
                self.counts["deepest_step"] = max(self.counts["deepest_step"], self.plan_depth)
                if progress is not None:
                    progress(self)
                if found is not None:
                    status, path = "solved", self.shortcut(found, deadline)
                    break
        except KeyboardInterrupt:
            status = "interrupted"
            self.counts["interrupted"] = True
        seconds = time.perf_counter() - t0
        cost = path_cost(p, np.array([q for q, _, _ in path])) if status == "solved" else math.inf
        stats = dict(self.counts, seconds=round(seconds, 4), modes=self.mode_count,
                     nodes=len(path), cost=round(cost, 6) if status == "solved" else None,
                     cost_trace=[[round(seconds, 4), round(cost, 6)]] if status == "solved"
                     else [], first_solution_seconds=round(seconds, 4)
                     if status == "solved" else None, motion_planner=self.opt.motion_planner,
                     motion_seconds=round(self.motion_seconds, 4), time=p.timers.as_dict())
        if self.space is not None:
            stats.update(self.space.counts)
        return OptimalResult(status, path, stats, cost)

    def follow(self, steps: list, deadline: float) -> list | None:
        """The plan ``steps`` (``(action, transition)``; action None: the goal) made geometric
        depth first; the path of ``(q, mode, action)`` states, or None. Each step's
        transition configurations are tried in turn, and a motion into each (*eager*: the
        default, on the plan's motion budget).

        With ``lazy_motions`` the motions come last: depth first over the steps'
        transition configurations alone (at most the plan's budget of them), and once every
        step has one, the motions between them in order. The first motion that fails sends
        the search back to its step's next configuration (the motions before it kept), and
        from then on the plan is followed eagerly, a motion with every
        configuration taken, on the plan's motion budget: a plan whose transitions all hold
        is worth its motions, and with motions last again every failed motion would cost
        the configurations of all the steps after it. Most task plans fail at a transition:
        Blocks World E's decoupled runs planned 1,050 motions in 300 s (250 s of them) for
        50 plans, most of them on plans that failed later at a step no motion could
        change.

        A step whose configurations are exhausted sends the search back to the latest step
        it and the failed steps after it depend on (:meth:`culprits`; with ``backjump``, else
        to the step before; a step with no culprit goes back to the step before too); a
        motion that fails depends on every step before it."""
        p = self.p
        budget = max(self.opt.plan_budget, self.opt.plan_budget_per_step * len(steps))
        targets = budget                     # configurations taken before the first chain
        eager = not self.opt.lazy_motions
        self.plan_depth = 0
        # per depth: the configuration, its mode, the action into it (None at the root and
        # the goal), the motion into it (None: not planned yet), the next step's samples left
        stack: list[list] = [[p.q0.copy(), p.initial, None, None, None]]
        # per depth (with backjump): the earlier steps the failures at and below it depend
        # on, and the objects the step into it moved
        jump = self.opt.backjump
        conflicts: list[set] = [set()]
        moved: list[frozenset] = [frozenset()]
        while stack and time.perf_counter() < deadline and budget > 0 and targets > 0:
            depth = len(stack) - 1
            self.plan_depth = max(self.plan_depth, depth)
            if depth == len(steps):
                failed = self.chain_motions(stack, deadline)
                if failed is None:
                    return self.chain_path(stack)
                budget -= 1
                del stack[failed:]           # that configuration's step: its next sample
                del conflicts[failed:], moved[failed:]
                conflicts[-1].update(range(failed - 1))
                eager = True
                continue
            q, mode, _, _, todo = stack[-1]
            action, tr = steps[depth]
            if todo is None:
                todo = stack[-1][4] = self.step_samples(steps, depth, mode, q)
                if jump:
                    conflicts[-1] |= self.culprits(steps, depth, mode, moved,
                                                   [] if todo else self.collided_now)
            if not todo:
                self.counts["backtracks"] += 1
                back = depth - 1
                if jump and depth > 0:
                    found = conflicts[-1] - {depth}
                    if not found and self.opt.give_up_missed and tr.action is not None \
                            and tr.missed:
                        # out of reach wherever the steps before put things: no other
                        # configuration of theirs helps. Sampled again until it failed
                        # enough for the task planner's rule, then the plan ends
                        if tr.failures < RULE_FAILURES:
                            stack[-1][4] = None
                            continue
                        self.counts["missed_ends"] = self.counts.get("missed_ends", 0) + 1
                        return None
                    if not found:            # no culprit: back to the step before
                        self.counts["no_culprit"] = self.counts.get("no_culprit", 0) + 1
                    else:
                        back = max(found)
                        if back < depth - 1:
                            self.counts["backjumps"] = self.counts.get("backjumps", 0) + 1
                        conflicts[back] |= found - {back}
                del stack[back + 1:], conflicts[back + 1:], moved[back + 1:]
                continue
            target = todo.pop(0)
            motion = None
            if eager:
                motion = self.motion(mode, q, target, deadline, stack[-1][2], action)
                budget -= 1
                if motion is None:           # a motion depends on everything before it
                    conflicts[-1].update(range(depth))
                    continue
            else:
                targets -= 1
            tr.count(mode.id)
            self.counts["transitions"] += 1
            succ = mode
            if action is not None:
                succ = p.successor_mode(mode, action, target, self.mode_count)
                self.mode_count += 1
            stack.append([target.copy(), succ, action, motion, None])
            conflicts.append(set())
            moved.append(self.moved_objects(mode, succ) if jump else frozenset())
        return None

    def culprits(self, steps: list, i: int, mode: Mode, moved: list,
                 collided: list) -> set[int]:
        """The earlier steps (indices) whose choices step ``i``'s configurations in ``mode``
        depend on: for each movable object its action names (the goal's: every movable
        object) or one of the ``collided`` configurations (where its precondition held: at
        most :data:`BLAME_CHECKS` of a sampling that found none valid) hits, the latest step
        that moved it (``moved[k + 1]``: the objects step ``k`` moved). An object no step
        moved yet stands where it stood at the start. A collision of the robot with itself
        (the other arm where an earlier step left it) depends on the step before.

        With ``backjump``, a step whose configurations are exhausted sends the search to the
        latest of its culprits and those of the steps after it that failed (conflict-directed
        backjumping; none: the step before): Blocks World F's task plans failed at step 11-15
        on a placement the right arm cannot reach where `b` stood, and the search had tried,
        before giving up, every other configuration of the ten steps between that never
        touched `b`."""
        movable = self.tasks.task_planner().movable
        action = steps[i][0]
        if action is None:
            objects = set(movable)
        else:
            objects = {x.lower() for lit in action.pre_geometric if lit.positive
                       for x in lit.args if x.lower() in movable}
        robot = False
        scene = {k.lower() for k in mode.poses}
        for q in collided:
            for a, b, _ in self.p.collision.check(q, poses=mode.poses, attached=mode.held).pairs:
                named = [x.lower() for x in (a, b) if x.lower() in movable]
                objects.update(named)
                robot |= a.lower() not in scene and b.lower() not in scene
        last = {x: k for k in range(i) for x in moved[k + 1]}     # the latest mover wins
        out = {last[x] for x in objects if x in last}
        if robot and i > 0:
            out.add(i - 1)
        return out

    @staticmethod
    def moved_objects(mode: Mode, succ: Mode) -> frozenset:
        """The objects (lower-case) a step from ``mode`` into ``succ`` took, released or
        moved."""
        held = set(mode.held or {}) ^ set(succ.held or {})
        out = {x.lower() for x in held}
        for name, T in succ.poses.items():
            before = mode.poses.get(name)
            if before is None or not np.array_equal(before, T):
                out.add(name.lower())
        return frozenset(out)

    def chain_motions(self, stack: list, deadline: float) -> int | None:
        """Plan the motions of the chain ``stack`` not planned yet, in order; the depth of
        the first that fails, or None when all are planned."""
        for i in range(1, len(stack)):
            if stack[i][3] is None:
                ends = (stack[i - 1][1], stack[i - 1][0], stack[i][0], deadline,
                        stack[i - 1][2], stack[i][2])
                motion = self.motion(*ends)
                if motion is None and self.opt.chain_retry > 1:
                    # a whole plan's transitions hang on it: once more, on a larger budget
                    self.counts["chain_retries"] = self.counts.get("chain_retries", 0) + 1
                    motion = self.motion(*ends, scale=self.opt.chain_retry)
                if motion is None:
                    return i
                stack[i][3] = motion
        return None

    @staticmethod
    def chain_path(stack: list) -> list:
        """The ``(q, mode, action)`` path of a chain whose motions are planned: each motion
        in the mode it starts in, then the transition (the goal's ends the path there)."""
        path: list = []
        for i in range(1, len(stack)):
            mode = stack[i - 1][1]
            q, _, action, motion, _ = stack[i]
            path += [(x.copy(), mode, None) for x in motion[:-1]]
            if action is None:               # the goal's literals hold here
                return path + [(q.copy(), mode, None)]
            path.append((q.copy(), mode, action))
        return path + [(stack[-1][0].copy(), stack[-1][1], None)]

    def shortcut(self, path: list, deadline: float = math.inf) -> list:
        """The final plan's OMPL motions shortcut by tmpc
        (:func:`~tmpc.runtime.planners.decoupled.lazyprm.shortcut`, each motion in its mode)
        unless ``shortcut`` is off (``--simplify ompl``) or tmpc planned them (its own
        planner shortcuts already). Segments left at ``deadline`` (the run's time limit)
        stay as planned."""
        if not self.opt.shortcut or self.opt.motion_planner == "tmpc":
            return path
        t = time.perf_counter()
        out = []
        for seg in mode_segments(path):
            mode = seg[0][1]
            if time.perf_counter() >= deadline:
                out.extend(seg)
                continue
            Q = shortcut(self.p, mode, np.array([q for q, _, _ in seg]), self.shortcut_rng,
                         rounds=self.opt.shortcut_rounds, resolution=self.opt.resolution)
            out.extend((q.copy(), mode, None) for q in Q[:-1])
            out.append((Q[-1].copy(), seg[-1][1], seg[-1][2]))
        self.counts["shortcut_seconds"] = round(time.perf_counter() - t, 4)
        return out

    def step_samples(self, steps: list, i: int, mode: Mode, q: np.ndarray) -> list[np.ndarray]:
        """Step ``i``'s transition configurations from ``q`` in ``mode``
        (:meth:`transition_samples`), those from which the plan's next step on the object it
        grasps or releases holds first, with ``lookahead`` (:meth:`looking_ahead`)."""
        action, tr = steps[i]
        if not self.opt.lookahead or action is None:
            return self.transition_samples(mode, action, q, tr)
        todo = self.transition_samples(mode, action, q, tr, keep=PROJECTION_BATCH)
        return self.looking_ahead(steps, i, mode, todo)[:self.opt.samples]

    def looking_ahead(self, steps: list, i: int, mode: Mode, todo: list) -> list:
        """``todo`` (step ``i``'s configurations in ``mode``) reordered by the plan's next step
        ``j`` on the object step ``i`` grasps or releases: first the configurations after
        which ``j``'s precondition holds collision-free (projected from each, one batch),
        then those where it holds only in collision, then the rest (each group nearest
        first). ``j`` is looked at when it comes next, or when step ``i`` puts the object
        down, the hands are empty after it and ``j`` only grasps it (a block put on the
        table for the other arm to take: the steps between cannot move it). A
        configuration is never dropped, only tried later."""
        p = self.p
        if len(todo) < 2:
            return todo
        action = steps[i][0]
        first = p.successor_mode(mode, action, todo[0], -1)
        before, after = set(mode.held or {}), set(first.held or {})
        moved = {x.lower() for x in before ^ after}
        if not moved:
            return todo
        j = next((k for k in range(i + 1, len(steps)) if steps[k][0] is not None and any(
            x.lower() in moved for lit in steps[k][0].pre_geometric if lit.positive
            for x in lit.args)), None)
        if j is None:
            return todo
        later = steps[j][0]
        if j > i + 1:
            movable = self.tasks.task_planner().movable
            named = {x.lower() for lit in later.pre_geometric if lit.positive
                     for x in lit.args if x.lower() in movable}
            if after or not named <= moved or not (before - after):
                return todo
        if not p.has_geometry(later):
            return todo
        score = []
        for k, c in enumerate(todo):
            succ = first if k == 0 else p.successor_mode(mode, action, c, -1)
            starts = self.starts_around(c, self.ahead_rng)
            Qp, holds, _ = p.project_raw(succ, later, starts,
                                         iterations=self.opt.projection_iterations)
            self.counts["lookahead_projections"] = \
                self.counts.get("lookahead_projections", 0) + len(starts)
            good = holds.any() and bool(p.valid_batch(succ, Qp[holds]).any())
            score.append(0 if good else 1 if holds.any() else 2)
        order = np.argsort(score, kind="stable")
        return [todo[k] for k in order]

    def starts_around(self, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """One batch of projection starts: ``q``, 7 around it (a tenth of each joint's range)
        and 8 uniform ones."""
        p = self.p
        near = q + rng.normal(0.0, 0.1, (PROJECTION_BATCH // 2 - 1, len(q))) * (p.upper - p.lower)
        return np.vstack([q[None], p.wrap(near), p.uniform(rng, PROJECTION_BATCH // 2)])

    def transition_samples(self, mode: Mode, action, q: np.ndarray, tr,
                           keep: int | None = None) -> list[np.ndarray]:
        """Up to ``samples`` (or ``keep``) collision-free configurations where ``action``'s
        geometric precondition (the goal's for None) holds in ``mode``, the nearest to ``q``
        first: projected from ``q`` and from uniform starts. An action without geometry
        happens at ``q``."""
        p = self.p
        self.collided_now = []
        if action is not None and not p.has_geometry(action):
            return [q.copy()]
        out = []
        key = None if action is None else action.id
        for r in range(self.opt.sample_rounds):
            if r == 0:                       # nearby transitions first, far ones if those fail
                starts = self.starts_around(q, self.rng)
            else:                            # none valid: wider, then uniform starts
                near = q + self.rng.normal(0.0, 0.3, (PROJECTION_BATCH // 2, len(q))) \
                    * (p.upper - p.lower)
                starts = np.vstack([p.wrap(near), p.uniform(self.rng, PROJECTION_BATCH // 2)])
            if r > 0:                        # none valid from the usual starts: seeds too
                self.seeded(key, starts)
            # the joints the action does not use go back to where the run started them; in
            # the wider rounds, where that collides, where they are and the start values
            idle = self.idle.get(key) if self.opt.park_idle else None
            others = []
            if idle is not None and idle.any():
                if r > 0:
                    others = [np.broadcast_to(q[idle], starts[:, idle].shape),
                              starts[:, idle].copy()]
                starts[:, idle] = p.q0[idle]
            self.counts["transition_samples"] += len(starts)
            Qp, holds, dist = p.project_raw(mode, action, starts,
                                            iterations=self.opt.projection_iterations)
            if key not in self.moves:
                self.moves[key] = (np.abs(Qp - starts) > 1e-9).any(axis=0)
            if idle is None and self.opt.park_idle:
                self.idle[key] = self.idle_joints(~self.moves[key])
            ok = holds.copy()
            if ok.any():
                ok[ok] = p.valid_batch(mode, Qp[ok])
            for other in others:
                retry = holds & ~ok
                if not retry.any():
                    break
                Qa = Qp[retry]
                Qa[:, idle] = other[retry]
                good = p.valid_batch(mode, Qa)
                rows = np.flatnonzero(retry)[good]
                Qp[rows], ok[rows] = Qa[good], True
            for qp, h, good, d in zip(Qp, holds, ok, dist):
                if good:
                    out.append(p.wrap(qp))
                else:
                    tr.record_failure(mode, qp, bool(h), float(d))
                    self.counts["transition_failures"] += 1
                    if h and self.opt.backjump and len(self.collided_now) < BLAME_CHECKS:
                        self.collided_now.append(np.array(qp))
            if out:
                break
        if self.room is not None and self.opt.aim_placements and action is not None:
            out += self.room.around(mode, action, Qp[holds])     # [] if it releases nothing
        if out and self.opt.seed_starts:
            pool = self.pool.setdefault(self.moves[key].tobytes(), [])
            pool += [x.copy() for x in out]
            del pool[:-SEED_POOL]
        if out:                              # the nearest first: shorter motions
            X = np.array(out)
            cost = p.cost(X, q)
            order = self.room.order(mode, action, X, cost) \
                if self.room is not None and action is not None else np.argsort(cost, kind="stable")
            out = [out[i] for i in order]
        return out[:keep or self.opt.samples]

    def seeded(self, key, starts: np.ndarray) -> None:
        """With ``seed_starts``, the last ``seed_starts`` of ``starts`` (uniform ones)
        replaced in place by valid transition configurations (drawn with replacement) found
        before by actions that move the same joints as action ``key`` (its first
        projection's), each perturbed by :data:`SEED_NOISE` of each joint's range. Measured
        on Blocks World E's start, 20 rounds of 16 projections of a left-arm grasp of `d`:
        16 valid configurations from the usual starts, 62 with 4 seeds from another block's
        grasps, 113 with 8: a top grasp holds about its axis at any angle, but the open
        gripper clears a block only face on, and a seed comes face on. Seeds may come from
        configurations motions reach only through narrow passages, and find more of those
        (docs/planning.md)."""
        moves = self.moves.get(key)
        pool = self.pool.get(moves.tobytes()) if moves is not None else None
        k = self.opt.seed_starts
        if not k or not pool:
            return
        p = self.p
        S = np.array([pool[i] for i in self.rng.integers(len(pool), size=k)])
        starts[-k:] = p.wrap(S + self.rng.normal(0.0, SEED_NOISE, S.shape) * (p.upper - p.lower))

    def idle_joints(self, unmoved: np.ndarray) -> np.ndarray:
        """Of the joints an action's projection never moved (``unmoved``, a mask), those no
        joint it moved carries, the joints all the robot hangs on (a base, a torso) apart:
        a PR2's other arm, not its own wrist roll, free about a top grasp's axis. An
        action's starts put those where the run started them (the other arm back out of
        the way: uniform values of it collided with the table, the ceiling or the arm at
        work in most of Blocks World G's attempts, and those collisions passed for evidence
        against the placement; left where it last worked, it stood in the way of the
        motions). The precondition does not depend on them, so the projection is the same;
        in the wider rounds a configuration that collides so is tried again with the other
        arm where it is, then with the start's values of it. A failed attempt is recorded
        with the other arm back where it started."""
        carried = self.carried()
        everything = frozenset().union(*carried)
        own = [carried[a] for a in np.flatnonzero(~unmoved) if carried[a] != everything]
        hold = unmoved.copy()
        for j in np.flatnonzero(unmoved):
            hold[j] = not any(carried[j] <= frames for frames in own)
        return hold

    def carried(self) -> list[frozenset]:
        """Per joint, the robot's frames that move with it (forward kinematics at the
        start configuration, each joint turned by 0.2 in turn)."""
        if self._carried is None:
            q = np.asarray(self.p.q0, float)
            Q = np.repeat(q[None], len(q) + 1, axis=0)
            Q[np.arange(1, len(q) + 1), np.arange(len(q))] += 0.2
            frames = self.p.frames_of(Q)
            base = frames[0]
            self._carried = [frozenset(np.flatnonzero(
                (np.abs(f.p - base.p) > 1e-9).any(axis=1)
                | (np.abs(f.R - base.R) > 1e-9).any(axis=(1, 2)))) for f in frames[1:]]
        return self._carried

    def motion(self, mode: Mode, q0: np.ndarray, q1: np.ndarray, deadline: float,
               before=None, after=None, scale: float = 1.0) -> np.ndarray | None:
        """The motion q0 -> q1 in ``mode`` as the motion planner returns it, or None.
        ``before``: the action that happened at ``q0``; ``after``: the one at ``q1`` (None:
        the start, the goal or unknown); ``scale``: the motion budget's multiple.

        With ``park_first`` (and ``park_idle``), a motion whose end puts the arm ``after``
        does not use back where the run started it moves that arm there first, alone, and
        then the rest, when the configuration between is free: two motion plans, each in
        its own joints (OMPL holds the others: ``fixed``), on the one motion budget; the
        whole at once on what is left of it when the first fails. Blocks World E v7's
        failed motions each moved both arms: the right one out from under the table's
        ceiling, the left one into a grasp under it (docs/planning.md)."""
        if np.abs(self.p.difference(q1, q0)).max() <= 1e-12:
            return q0[None].copy()          # an action without geometry: no motion
        t = time.perf_counter()
        seconds = self.opt.motion_budget if self.opt.motion_budget is not None else \
            (LAZY_PRM_SECONDS if self.space is None else math.inf)
        budget = Budget(min(seconds * scale, deadline - t), self.space,
                        round(self.opt.motion_checks * scale))
        if not budget.left():
            return None
        k = self.counts["motions"]
        self.counts["motions"] += 1
        out, back = self.retreats(mode, q0, q1, before, after)
        a = out[-1] if out else q0
        b = back[-1] if back else q1
        path = None
        mid = self.parked_between(mode, a, b, after)
        if mid is not None:
            idle = self.idle[after.id]
            first = self.plan(mode, a, mid, budget, motion_seed(self.seed, k), ~idle)
            if first is not None:
                rest = self.plan(mode, mid, b, budget, motion_seed(self.seed, k) + 1, idle) \
                    if budget.left() else None
                if rest is None:
                    self.counts["motion_failures"] += 1
                    return None
                path = np.vstack([first, rest[1:]])
                self.counts["parked_first"] = self.counts.get("parked_first", 0) + 1
        if path is None:
            path = self.plan(mode, a, b, budget, motion_seed(self.seed, k)) \
                if budget.left() else None
        if path is None:
            self.counts["motion_failures"] += 1
            return None
        return np.vstack([q0[None], *(x[None] for x in out), path,
                          *(x[None] for x in back[::-1]), q1[None]])

    def plan(self, mode: Mode, a: np.ndarray, b: np.ndarray, budget: Budget,
             seed: int, fixed: np.ndarray | None = None) -> np.ndarray | None:
        """One call of the motion planner, a -> b within what is left of ``budget``, the
        joints of the mask ``fixed`` held: the path or None."""
        res = plan_motion(self.p, mode, a, b, self.opt.motion_planner, budget.seconds_left(),
                          seed, self.space, self.opt.resolution, fixed, budget.checks_left())
        self.motion_seconds += res.seconds
        return res.path

    def parked_between(self, mode: Mode, a: np.ndarray, b: np.ndarray,
                       after) -> np.ndarray | None:
        """With ``park_first``: ``a`` with the joints ``after`` leaves idle at their values
        in ``b`` (the arm it does not use, back where it was parked), when those differ, the
        rest differs too, and that configuration is free in ``mode``; else None."""
        if not (self.opt.park_first and self.opt.park_idle) or after is None:
            return None
        idle = self.idle.get(after.id)
        if idle is None or not idle.any():
            return None
        step = np.abs(self.p.difference(b, a))
        if step[idle].max() <= 1e-9 or step[~idle].max() <= 1e-9:
            return None
        mid = a.copy()
        mid[idle] = b[idle]
        return mid if self.p.valid_batch(mode, mid[None])[0] else None

    def retreats(self, mode: Mode, q0: np.ndarray, q1: np.ndarray, before=None,
                 after=None) -> tuple[list, list]:
        """The hand's retreat out of ``q0`` and out of ``q1`` (the approach to it, reversed):
        the longest straight chain of each (:mod:`tmpc.runtime.planners.retreat`); none
        with ``retreat_steps`` 0 or no grasping frame. With ``retreat_sideways``, the chains
        of the hand the action at that end (``before``, ``after``) grasps or releases with
        (every hand's without one), sideways ones among them."""
        if self.opt.retreat_steps <= 0:
            return [], []
        if self.hands is None:
            self.hands = hand_frames(self.p)
        if not self.hands:
            return [], []
        hands: list = self.hands
        if self.opt.retreat_sideways:
            hands = [(hand_frames(self.p, x) if x is not None else []) or self.hands
                     for x in (before, after)]
        c0, c1 = retreat_chains(self.p, [(mode, q0), (mode, q1)], hands,
                                self.opt.retreat_steps, self.opt.retreat_step,
                                self.opt.resolution, self.opt.retreat_sideways)
        return best_retreat(c0), best_retreat(c1)


class Budget:
    """One motion's budget, shared by its motion plans: ``seconds`` of wall clock (``inf``:
    none) and, with an OMPL ``space``, ``checks`` of its checks
    (:attr:`~tmpc.runtime.planners.decoupled.space.MotionSpace.checks`), both counted from
    now."""

    def __init__(self, seconds: float, space, checks: int):
        self.end = time.perf_counter() + seconds
        self.space = space
        self.last = None if space is None else space.checks + int(checks)

    def seconds_left(self) -> float:
        return self.end - time.perf_counter()

    def checks_left(self) -> int | None:
        return None if self.space is None else self.last - self.space.checks

    def left(self) -> bool:
        checks = self.checks_left()
        return self.seconds_left() > 0 and (checks is None or checks > 0)
