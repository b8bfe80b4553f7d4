"""The ``optimal`` planner (thesis ch. 4, tmit-star's TMIT*): task plans from incremental SAT,
a multimodal random geometric graph grown in batches, lazy transitions, and an asymmetric
(reverse heuristic, forward lazy) search; anytime.

**Task plans.** :class:`~tmpc.runtime.planners.taskplan.TaskPlanner` (geometric literals get
blockers) gives the shortest plan consistent with what was learnt. Each of its steps becomes a
*transition* of the step's symbolic state: ``(action, successor state)`` with success/failure
counts. A new task plan is asked for when no transition has budget left, or when a batch tried a
transition and the batch budget (5) is spent. Before asking, the last plan's prefix up to and
including its first transition without a success is excluded, and **blockers** are pinned
(thesis §4.3.5): a transition that succeeded shows its geometric literals hold after its prefix;
one that never succeeded, with a literal false at its best attempt (the projection closest to
the precondition), shows that literal false there. Pinned literals remove every plan that needs
them at that point without first running an action that may change them, not only the excluded
prefix.

**The graph.** Vertices are ``(q, mode)``. Per batch, each reachable mode (modes reached in this
batch first, as tmit-star's frontier) gets ``batch_size`` uniform collision-free samples. For
every new sample and every transition of the mode's symbolic state with budget left (fewer than
5 successes, a cap that grows by 5 every ``cap_growth`` batches while there is no solution,
and fewer than the batch's cap, which starts at 1 and grows by 1 per batch), the
precondition's distance is evaluated (the projector at 0 iterations: batched). Only samples
closer than the mode's PRM* connection radius are projected (from the sample itself). A success
adds a *transition vertex* in the mode and a *bridge vertex* at the same configuration in the
successor mode (deduplicated by symbolic state, held frames and poses to 1e-3), joined by a
zero-cost directed edge. A goal with geometric literals is one more transition of the goal
states, whose successes are goal vertices; otherwise every bridge into a goal mode is one.
Inside a mode, vertices are joined to their k nearest neighbours (k = ceil(rewire (e + e/d) log
n)), symmetrised; there are no other edges, so across modes the distance is infinite without a
known transition.

**The search** (AIT*-style). A reverse Dijkstra from the goal vertices over the graph with
collisions ignored (edge directions reversed; SciPy's csgraph) gives an admissible, consistent
cost-to-go ``h``. The forward search is A* on ``g + h`` that checks each edge for collision only
when the entry that uses it is popped (lazy A*): the first goal popped is the best path of the
edges that are valid. A failed edge is blacklisted: it leaves the graph at the next rebuild, and
with it the reverse branch through it. Costs are tmit-star's composite path length
(:meth:`PlanningProblem.cost`), so plan costs compare across the two planners.

**Anytime.** After the first solution, batches go on until the time limit; each improved
solution is reported (``on_solution``: the CLI writes it atomically) and recorded in the
cost-over-time trace. ``first_solution`` stops at the first one (tmit-star without ``-o``);
``until_converged`` stops once the last ``converged_solutions`` searches' best costs lie within
``converged_ratio`` of each other. Ctrl-C keeps the best plan. Each improved solution is then
shortcut inside its modes (:meth:`OptimalPlanner._shortcut`), its transitions moved along the
manifolds that keep their effects (:meth:`OptimalPlanner._refine`), and an anytime run starts
from the unified planner's plan (:meth:`OptimalPlanner._seed`); all become graph edges, so every
reported plan is a path of the graph.

Differences from tmit-star (docs/planning.md "Where it differs"): the reverse search is
recomputed per batch rather than repaired incrementally (LPA*); blockers are used (tmit-star
declares ``blocked_steps`` and never reads it); each mode's entries are joined to its exits and
half of its samples are drawn around them (``portals``, ``corridor``; a mode entered but not
yet left: a tenth around its entries, ``entry_share``); a portal vertex one of whose edges
failed gets short free motions out of it (escape stubs, :meth:`OptimalPlanner._escape`; every
portal, when a search finds no path); edges are
checked in batches, coarse first, a found path's at the full resolution (``coarse``); the
search before a first solution is inflated (``inflation``) and a search gives up after
``search_budget`` edge checks until the next batch; the absolute cap grows while there is no
solution (``cap_growth``: tmit-star's never does); anytime runs shortcut and refine their
solutions and start from the unified planner's plan (``shortcut_*``, ``refine_sweeps``,
``seed_unified``).
"""

from __future__ import annotations

import heapq
import math
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.planners.refine import refine_path
from tmpc.runtime.planners.taskplan import SOLVED, TaskPlanner
from tmpc.runtime.planners.unified import UnifiedPlanner
from tmpc.runtime.problem import Mode, PlanningProblem


def _graphs():
    """scipy's ``csr_matrix`` and ``dijkstra``: imported on first use, 0.10-0.15 s that a run
    spends on its warm-up thread beside the kernel loads (:meth:`OptimalPlanner.warm_up_calls`)
    rather than in setup on the main thread."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra
    return csr_matrix, dijkstra


#: cost of a transition edge (same configuration): positive so sparse graphs keep it
_BRIDGE = 1e-12


@dataclass(frozen=True)
class OptimalOptions:
    batch_size: int = 50               # uniform samples per mode per batch (tmit-star: 50)
    batch_budget: int = 5              # batches per task plan (tmit-star: 5)
    rewire: float = 1.0                # k-nearest rewire factor
    resolution: float = 0.05           # motion-check resolution (the validator's default)
    coarse: float = 8.0                # the search checks edges at coarse x resolution first
    inflation: float = 2.0             # heuristic weight of the searches before a first solution
    deflation: float = 0.5             # ... its excess over 1 shrinks by this per later search
    mode_caps: int = 0                 # > 0: caps per source mode, this many times the absolute
    portals: bool = True               # join each mode's entries to its exits (tmpc's addition)
    corridor: float = 0.5              # share of samples around entry-exit segments (tmpc's)
    corridor_sigma: float = 0.05       # their noise, as a fraction of each coordinate's range
    #: a mode with entries but no exit yet: this share of samples around its entries (tmpc's)
    entry_share: float = 0.1
    search_budget: int = 3000          # edges one search may check before it waits for a batch
    escape_tries: int = 16             # short motions tried out of each new portal (tmpc's; 0: off)
    escape_rounds: int = 2             # ... and again out of the free ends kept
    escape_keep: int = 2               # free ends kept per vertex and round
    #: escape only out of portals one of whose edges failed (at the next sampling, or at once
    #: when a search before the first solution found no path)
    escape_lazy: bool = True
    #: their lengths: the largest coordinate step, as fractions of each coordinate's range
    escape_steps: tuple = (0.005, 0.02, 0.06)
    #: anytime runs start from the unified planner's plan (tmpc's; not with first_solution)
    seed_unified: bool = True
    shortcut_tries: int = 32           # shortcuts tried per mode segment of a new solution (tmpc's)
    shortcut_points: int = 16          # ... between points cutting its edges into this many pieces
    shortcut_rounds: int = 3           # ... and again on the shortened segment
    #: sweeps of transition refinement per new solution (tmpc's; 0: off; refine.py)
    refine_sweeps: int = 200
    absolute_cap: int = 5              # successes per transition, ever (tmit-star: 5)
    #: projector steps per transition attempt (the unified planner takes the problem's 15):
    #: tmit-star's putdowns need more, and fewer batches pay for them (docs/planning.md)
    projection_iterations: int = 30
    #: > 0: with no solution yet, the absolute cap grows by its first value every this many
    #: batches (tmpc's; tmit-star's caps never grow)
    cap_growth: int = 10
    cap_increment: int = 1             # the per-batch success cap grows by this much
    first_solution: bool = False       # stop at the first solution (tmit-star without -o)
    until_converged: bool = False
    converged_solutions: int = 10
    converged_ratio: float = 0.10
    min_steps: int = 0
    max_steps: int = 100               # tmit-star's default


@dataclass
class OptimalResult:
    status: str                        # solved | partial | interrupted
    path: list[tuple[np.ndarray, Mode, object | None]]
    stats: dict = field(default_factory=dict)
    cost: float = math.inf


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

    def count(self, mode_id: int) -> None:
        """One more success, from mode ``mode_id``."""
        self.successes += 1
        self.by_mode[mode_id] = self.by_mode.get(mode_id, 0) + 1


class OptimalPlanner:
    def __init__(self, problem: PlanningProblem, seed: int = 0,
                 options: OptimalOptions = OptimalOptions()):
        self.p = problem
        self.opt = options
        self.rng = np.random.default_rng(seed)
        self.seed = seed
        self.tp: TaskPlanner | None = None
        self.dim = len(problem.lower)
        span = np.where(problem.wraps, 2 * np.pi, problem.upper - problem.lower)
        #: log of the space's measure over the unit ball's (PRM* radius)
        d = self.dim
        self._log_ratio = float(np.log(np.maximum(span, 1e-9)).sum()
                                - (d / 2 * math.log(math.pi) - math.lgamma(d / 2 + 1)))
        # vertices
        self.Q = np.zeros((1024, self.dim))
        self.node_mode: list[int] = []
        self.mode_vertices: dict[int, list[int]] = {}
        self.bridge: dict[int, tuple[int, object]] = {}     # transition vertex -> (bridge, action)
        self.stubs: list[tuple[int, int, float]] = []       # escape edges (valid) and costs
        #: seconds per vertex of the last search's graph, heuristic and adjacency lists
        self._graph_seconds = 0.0
        self._search_t0 = 0.0
        self.shortcuts: list[tuple[int, int, float]] = []   # shortcut edges (valid) and costs
        self._stub_count: dict[int, int] = {}               # stub vertices per mode
        self._to_escape: list[int] = []                     # portals made since the last escape
        self._portal_set: set[int] = set()                 # portals not escaped from yet
        self.goals: set[int] = set()
        # modes
        self.modes: list[Mode] = []
        self.depth: dict[int, int] = {}
        self.reachable: list[int] = []
        self.transitions: dict[int, list[Transition]] = {}
        self.plan: list | None = None
        self.plan_transitions: list[Transition] = []
        self.plans_exhausted = False
        # batches
        self.batch = 0
        self.batch_budget = options.batch_budget
        self.cap = 0
        self.absolute_cap = options.absolute_cap
        self.queue: deque[int] = deque()
        self.frontier: list[int] = []
        self.sampled: set[int] = set()
        self.no_budget = True
        self.tried = False
        # search
        self.edge_ok: dict[tuple[int, int], bool] = {}
        self._invalid: set[tuple[int, int]] = set()         # blacklisted edges
        self._nn: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._fine: dict[tuple[int, int], bool] = {}        # edges checked at the resolution
        self._checks_left = math.inf
        self._deadline = math.inf          # the run's: a search stops checking edges after it
        self.best_cost = math.inf
        self.best_path: list[int] | None = None
        self.trace: list[tuple[float, float]] = []
        self._search_costs: list[float] = []
        self._later = 0                  # searches since (and including) the first solution's
        self._graph_size = -1
        self._progress: list[int] = [0]
        self.on_solution = None          # callback(result) at every improved solution
        self.counts = {"batches": 0, "task_plans": 0, "samples": 0, "projections": 0,
                       "transitions": 0, "transition_failures": 0, "edges_checked": 0,
                       "edges_confirmed": 0, "edges_invalid": 0, "searches": 0,
                       "searches_cut": 0, "evidence": 0, "escapes": 0, "shortcuts": 0}
        self._t0 = time.perf_counter()

    @classmethod
    def from_options(cls, problem: PlanningProblem, seed: int = 0,
                     overrides: dict | None = None) -> "OptimalPlanner":
        """The registry's factory: ``batch_size``, ``batch_budget``, ``min_steps``,
        ``max_steps``, ``projection_iterations`` from the run configuration (a tmit-star spec
        or a manifest's [planner]); the command line's ``batch_size``, ``rewire``,
        ``first_solution`` and ``until_converged`` win. E825 for a value out of range."""
        config = problem.world.config
        params = dict(config.params) if config is not None else {}
        over = {k: v for k, v in (overrides or {}).items() if v is not None}
        base = OptimalOptions()
        opts = OptimalOptions(
            batch_size=int(over.get("batch_size", params.get("batch_size", base.batch_size))),
            batch_budget=int(params.get("batch_budget", base.batch_budget)),
            rewire=float(over.get("rewire", base.rewire)),
            first_solution=bool(over.get("first_solution", False)),
            until_converged=bool(over.get("until_converged", False)),
            min_steps=int(params.get("min_steps", base.min_steps)),
            max_steps=int(params.get("max_steps", base.max_steps)),
            projection_iterations=int(params.get("projection_iterations",
                                                 base.projection_iterations)))
        for name, value, ok in (("batch size", opts.batch_size, opts.batch_size >= 1),
                                ("batch budget", opts.batch_budget, opts.batch_budget >= 1),
                                ("rewire factor", opts.rewire, opts.rewire > 0),
                                ("projection iterations", opts.projection_iterations,
                                 opts.projection_iterations >= 1)):
            if not ok:
                raise InputError(error("E825", f"{name} {value} is out of range", None,
                                       "batch size, budget and projection iterations >= 1, "
                                       "rewire factor > 0"))
        return cls(problem, seed=seed, options=opts)

    # ---- vertices and modes ----------------------------------------------------------------
    def _add_vertex(self, q: np.ndarray, mode: Mode, listed: bool = True) -> int:
        """A new vertex; ``listed``: among its mode's vertices (nearest-neighbour edges)."""
        i = len(self.node_mode)
        if i == len(self.Q):
            self.Q = np.concatenate([self.Q, np.zeros_like(self.Q)])
        self.Q[i] = q
        self.node_mode.append(mode.id)
        if listed:
            self.mode_vertices[mode.id].append(i)
        return i

    def _mode(self, sym: int, poses, held, parent: Mode, action) -> tuple[Mode, bool]:
        """The known mode with this symbolic state and pose set (1e-3), or a new one."""
        for m in self.modes:
            if m.sym == sym and _same_poses(m, poses, held):
                return m, False
        m = self.p.make_mode(len(self.modes), sym, poses, held, parent.id, action)
        self._add_mode(m, self.depth[parent.id] + 1)
        return m, True

    def _add_mode(self, mode: Mode, depth: int) -> None:
        self.modes.append(mode)
        self.mode_vertices[mode.id] = []
        self.depth[mode.id] = depth
        self.reachable.append(mode.id)

    def _goal_mode(self, mode: Mode) -> bool:
        return self.p.ground.goal.holds(mode.sym)

    # ---- task plans --------------------------------------------------------------------------
    def warm_up_calls(self) -> list:
        """Set-up a run makes beside its kernel loads (:meth:`PlanningProblem.start_warm_up`):
        the SAT task planner (Z3's import and context, the encoding's first layers), which
        the first task plan would otherwise build inside planning time, and scipy's graphs."""
        return [self._task_planner, _graphs]

    def _task_planner(self) -> TaskPlanner:
        if self.tp is None:
            self.tp = TaskPlanner(self.p.ground, geometric=True)
        return self.tp

    def _new_task_plan(self, deadline: float) -> bool:
        """Learn from the last plan (exclusion, blockers) and ask for the next one; False when
        there is none (the graph keeps growing with the transitions known)."""
        t = time.perf_counter()
        try:
            if self.tp is None:
                self._task_planner()
            elif self.plan is not None:
                self._learn()
            if self.plans_exhausted:
                return False
            left = None if math.isinf(deadline) else max(0.0, deadline - time.perf_counter())
            res = self.tp.next_plan(self.opt.max_steps, left, min_steps=self.opt.min_steps)
        finally:
            self.p.timers.task_planning += time.perf_counter() - t
        if res.status != SOLVED:
            self.plans_exhausted = res.status != "timeout"
            self.plan = None
            return False
        self.counts["task_plans"] += 1
        self.plan = list(res.actions)
        self.plan_transitions = []
        sym = self.p.ground.init
        for action in self.plan:
            to = self.p.ground.apply(sym, action)
            self.plan_transitions.append(self._transition(sym, action, to))
            sym = to
        if self.p.goal_formula() is not None:
            self._transition(sym, None, sym)
        self.batch_budget = self.opt.batch_budget
        return True

    def _transition(self, sym: int, action, to: int) -> Transition:
        known = self.transitions.setdefault(sym, [])
        for tr in known:
            if tr.action is action and tr.to_sym == to:
                return tr
        tr = Transition(sym, action, to)
        known.append(tr)
        return tr

    def _learn(self) -> None:
        """Exclude the last plan's prefix through its first transition without a success (all
        of it if every one succeeded) and pin the blockers its transitions showed."""
        plan, trs = self.plan, self.plan_transitions
        k = next((i for i, tr in enumerate(trs) if tr.successes == 0), len(trs))
        for i, tr in enumerate(trs[:k + 1]):
            lits = ([(lit, True) for lit in tr.action.pre_geometric] if tr.successes else
                    [(lit, False) for lit in self._false_literals(tr)])
            for lit, value in lits:
                if self.tp.add_evidence(plan[:i], lit, value):
                    self.counts["evidence"] += 1
        self.tp.exclude_prefix(plan[:min(len(plan), k + 1)])
        self.plan = None

    # ---- batches -----------------------------------------------------------------------------
    def _new_batch(self) -> None:
        self.batch += 1
        self.counts["batches"] += 1
        self.batch_budget -= 1
        self.cap += self.opt.cap_increment
        if self.opt.cap_growth and self.best_path is None and \
                self.batch % self.opt.cap_growth == 0:
            self.absolute_cap += self.opt.absolute_cap
        self.sampled = set()
        self.queue = deque(self.reachable)
        self.frontier = []
        self.no_budget = True
        self.tried = False

    def _radius(self, n: int) -> float:
        """PRM*'s connection radius for n samples of a mode (tmit-star's transition test)."""
        n = max(n, 2)
        d = self.dim
        return float(self.opt.rewire * 2.0 * math.exp(
            (math.log1p(1.0 / d) + self._log_ratio + math.log(math.log(n) / n)) / d))

    def _sample_modes(self, deadline: float) -> bool:
        """Sample the modes of the current batch until the batch is done (True) or a goal mode
        was reached (False: the batch resumes next time)."""
        while (self.frontier or self.queue) and time.perf_counter() < deadline:
            mid = self.frontier.pop() if self.frontier else self.queue.popleft()
            if mid in self.sampled:
                continue
            self.sampled.add(mid)
            reached = self._sample_mode(self.modes[mid])
            self._escape()
            if reached:
                return False
        return not (self.frontier or self.queue)

    def _uniform_valid(self, mode: Mode, n: int) -> np.ndarray:
        """``n`` collision-free samples of ``mode``: uniform ones, and with ``corridor`` > 0
        that share drawn around the straight segments between the mode's entries and exits
        (a point of a random segment plus Gaussian noise of ``corridor_sigma`` times each
        coordinate's range), where a first path through the mode has to go; the uniform
        share keeps the graph dense everywhere (asymptotic optimality)."""
        p = self.p
        got, tries = [], 0
        portals = self._portals_of(mode.id) if self.opt.corridor > 0 else None
        share = self.opt.corridor
        if portals is not None and portals[0] is portals[1]:
            share = self.opt.entry_share              # entries only: no exit yet
        while sum(len(g) for g in got) < n and tries < 50:
            tries += 1
            t = time.perf_counter()
            Q = p.uniform(self.rng, 2 * n)
            if portals is not None:
                k = int(round(len(Q) * share))
                a = portals[0][self.rng.integers(len(portals[0]), size=k)]
                b = portals[1][self.rng.integers(len(portals[1]), size=k)]
                # a third at the entry, a third at the exit, a third along the segment; noise
                # at three scales (the first steps out of a grasp are short)
                u = self.rng.random((k, 1))
                u = np.where(u < 1 / 3, 0.0, np.where(u < 2 / 3, 1.0, self.rng.random((k, 1))))
                along = a + u * p.difference(b, a)
                scale = self.opt.corridor_sigma * self.rng.choice([0.2, 1.0, 3.0], (k, 1))
                noise = self.rng.normal(0.0, 1.0, along.shape) * scale
                Q[:k] = p.wrap(along + noise * (p.upper - p.lower))
            p.timers.sampling += time.perf_counter() - t
            got.append(Q[p.valid_batch(mode, Q)])
            self.counts["samples"] += len(Q)
        return np.concatenate(got)[:n] if got else np.zeros((0, self.dim))

    def _portals_of(self, mid: int):
        """(entry configurations, exit configurations) of a mode; a mode with no exit yet has
        its entries for both (its samples near them: the way out of a grasp), the start mode
        with none: None."""
        got = self._portals().get(mid)
        if got is not None:
            return self.Q[got[0]], self.Q[got[1]]
        entries = [b for b, _ in self.bridge.values() if self.node_mode[b] == mid]
        if not entries:
            return None
        at = self.Q[entries]
        return at, at

    def _sample_mode(self, mode: Mode) -> bool:
        """A batch of samples in ``mode`` and the transitions they reach; True if a goal mode
        (or goal vertex) was reached."""
        p = self.p
        Q = self._uniform_valid(mode, self.opt.batch_size)
        ids = [self._add_vertex(q, mode) for q in Q]
        # stubs are no uniform samples: the PRM* radius counts the others
        radius = self._radius(len(self.mode_vertices[mode.id]) - self._stub_count.get(mode.id, 0))
        reached = False
        for tr in self.transitions.get(mode.sym, ()):
            if not self._budget(tr, mode):
                continue
            self.no_budget = False
            dist = p.distances(mode, tr.action, Q)
            near = np.nonzero(dist < radius)[0]
            if not len(near):
                continue
            self.tried = True
            if tr.action is not None and not p.has_geometry(tr.action):
                # a purely discrete action happens wherever the robot is
                for i in near:
                    if not self._budget(tr, mode):
                        break
                    reached |= self._succeed(tr, mode, ids[i], Q[i])
                continue
            reached |= self._project(tr, mode, Q[near])
        return reached

    def _project(self, tr: Transition, mode: Mode, starts: np.ndarray) -> bool:
        """Project ``starts`` onto ``tr``'s precondition (16 a call) while it has budget; a
        collision-free result succeeds. True if a goal was reached."""
        p = self.p
        reached = False
        for lo in range(0, len(starts), 16):
            if not self._budget(tr, mode):
                break
            part = starts[lo:lo + 16]
            self.counts["projections"] += len(part)
            Qp, holds, dist_p = p.project_raw(mode, tr.action, part,
                                              iterations=self.opt.projection_iterations)
            ok = holds.copy()
            if ok.any():
                ok[ok] = p.valid_batch(mode, Qp[ok])
            for q, h, good, d in zip(Qp, holds, ok, dist_p):
                if not self._budget(tr, mode):
                    break
                if good:
                    reached |= self._succeed(tr, mode, None, p.wrap(q))
                else:
                    self._fail(tr, mode, q, bool(h), float(d))
        return reached

    def _budget(self, tr: Transition, mode: Mode | None = None) -> bool:
        """Successes left for ``tr`` in this batch: fewer than the batch's cap and the
        absolute cap. With ``mode_caps`` the caps count the successes from ``mode`` (and all
        of them stay under ``mode_caps`` times the absolute cap), so the budget a transition
        spent in modes that lead nowhere does not starve it in the others."""
        cap = min(self.absolute_cap, self.cap)
        if not self.opt.mode_caps or mode is None:
            return tr.successes < cap
        return tr.by_mode.get(mode.id, 0) < cap and \
            tr.successes < self.opt.mode_caps * self.absolute_cap

    def _succeed(self, tr: Transition, mode: Mode, vertex: int | None, q: np.ndarray) -> bool:
        tr.count(mode.id)
        self.counts["transitions"] += 1
        v = self._add_vertex(q, mode) if vertex is None else vertex
        self._new_portal(v)
        if tr.action is None:
            self.goals.add(v)
            return True
        new = self.p.successor_mode(mode, tr.action, q, len(self.modes))
        succ, fresh = self._mode(new.sym, new.poses, new.held, mode, tr.action)
        b = self._add_vertex(q, succ)
        self._new_portal(b)
        self.bridge[v] = (b, tr.action)
        if fresh:
            self.frontier.append(succ.id)
        if self._goal_mode(succ) and self.p.goal_formula() is None:
            self.goals.add(b)
            return True
        return False

    def _escape(self) -> None:
        """Escape stubs (tmpc's addition): short free motions out of the portal vertices made
        since the last call (transition, bridge and goal vertices), kept as vertices whose
        edges are known valid.

        A portal is often nearly trapped: a grasped object still rests on its support, or an
        open gripper still surrounds the object it released, so the first step of almost every
        nearest-neighbour edge (1-3 rad long) collides (clutter-8, seed 2: a bridge whose 24
        edges all failed kept four searches from a solution) while steps of a few hundredths
        of a radian are free. Per vertex, ``escape_tries`` random directions, each scaled to
        one of ``escape_steps`` (the largest coordinate step over that coordinate's range), are
        checked at the full resolution, ends included, in one batched call per round; the
        ``escape_keep`` longest free ones are kept, and tried from again, ``escape_rounds``
        times. Only the last stubs of each chain get nearest-neighbour edges (the ones before
        them join it to the portal alone), so a portal adds a few vertices to the searches,
        not a cluster. With ``escape_lazy`` a portal is escaped from only once one of its edges
        failed, or when a search before the first solution found no path (all portals not
        escaped from yet)."""
        todo, self._to_escape = self._to_escape, []
        opt, p = self.opt, self.p
        if not todo or opt.escape_tries <= 0:
            return
        span = np.where(p.wraps, 2 * np.pi, np.maximum(p.upper - p.lower, 1e-9))
        steps = np.asarray(opt.escape_steps, float)
        made, parents = [], set()
        for _ in range(opt.escape_rounds):
            items = []
            for v in todo:
                d = self.rng.normal(size=(opt.escape_tries, self.dim))
                d /= np.maximum(np.abs(d / span).max(1, keepdims=True), 1e-12)
                length = steps[self.rng.integers(len(steps), size=opt.escape_tries)]
                items.append((v, self.modes[self.node_mode[v]],
                              p.wrap(self.Q[v] + d * length[:, None]), length))
            oks = p.motions_valid_many([(mode, np.broadcast_to(self.Q[v], Q1.shape), Q1)
                                        for v, mode, Q1, _ in items], opt.resolution, ends=True)
            todo = []
            for (v, mode, Q1, length), ok in zip(items, oks):
                free = np.nonzero(ok)[0]
                for i in free[np.argsort(-length[free], kind="stable")][:opt.escape_keep]:
                    w = self._add_vertex(Q1[i], mode, listed=False)
                    self.stubs.append((v, w, float(p.cost(Q1[i], self.Q[v]))))
                    self.edge_ok[_key(v, w)] = self._fine[_key(v, w)] = True
                    parents.add(v)
                    todo.append(w)
            made += todo
        for w in made:
            if w not in parents:
                mid = self.node_mode[w]
                self.mode_vertices[mid].append(w)
                self._stub_count[mid] = self._stub_count.get(mid, 0) + 1
        self.counts["escapes"] += len(made)

    def _fail(self, tr: Transition, mode: Mode, q: np.ndarray, held: bool,
              distance: float) -> None:
        """A failed attempt; the best one (smallest distance, the precondition false) is kept
        for the blocker evidence :meth:`_learn` derives."""
        tr.failures += 1
        self.counts["transition_failures"] += 1
        if tr.action is not None and not held and (tr.best_fail is None
                                                   or distance < tr.best_fail[0]):
            tr.best_fail = (distance, mode, q)

    def _false_literals(self, tr: Transition) -> list:
        """The geometric literals of ``tr``'s action that are false at its best failed
        attempt (none if its precondition never failed there: only collisions did)."""
        if tr.best_fail is None:
            return []
        _, mode, q = tr.best_fail
        geo = self.p.geo_oracle(mode, q)
        return [lit for lit in tr.action.pre_geometric
                if geo(lit.predicate, lit.args) != lit.positive]

    # ---- the graph and the search ------------------------------------------------------------
    def _graph(self):
        """The sparse graph (CSR of costs) of the current vertices: symmetrised k-nearest
        neighbours inside each mode, blacklisted edges removed, transition edges directed.

        Built with sparse-matrix unions (``maximum``: an edge that two sets share has the same
        cost in both), not by sorting every edge's key: at ~100k vertices the sort was most of
        a search (clutter-14 with red sticks, 1-2 s a search, measured 2026-12-03)."""
        n = len(self.node_mode)
        k = int(math.ceil(self.opt.rewire * (math.e + math.e / self.dim) * math.log(max(n, 2))))
        rows, cols, vals = [], [], []
        for mid, ids in self.mode_vertices.items():
            if len(ids) < 2:
                continue
            nn, nc = self._neighbours(mid, k)
            kk = min(k, len(ids) - 1)
            ids = np.asarray(ids)
            rows.append(np.repeat(ids, kk))
            cols.append(ids[nn[:, :kk].ravel()])
            vals.append(nc[:, :kk].ravel())

        csr_matrix = _graphs()[0]

        def sparse(r, c, w):
            return csr_matrix((np.maximum(w, _BRIDGE), (r, c)), shape=(n, n))

        # one direction of the neighbour lists has no duplicate: union it with its transpose
        g = sparse(*(np.concatenate(x) if x else np.zeros(0, t)
                     for x, t in ((rows, np.int64), (cols, np.int64), (vals, float))))
        g = g.maximum(g.T)
        extra = []
        if self.stubs or self.shortcuts:
            a, b, w = (np.array(x) for x in zip(*self.stubs, *self.shortcuts))
            extra.append((a.astype(np.int64), b.astype(np.int64), w))
        if self.opt.portals:
            for a, b in self._portals().values():
                ra, rb = np.meshgrid(a, b, indexing="ij")
                w = np.stack([self.p.cost(self.Q[b], self.Q[x]) for x in a])
                extra.append((ra.ravel(), rb.ravel(), w.ravel()))
        if extra:
            r, c, w = (np.concatenate(x) for x in zip(*extra))
            r, c = np.concatenate([r, c]), np.concatenate([c, r])
            _, first = np.unique(r * n + c, return_index=True)       # a few thousand edges
            g = g.maximum(sparse(r[first], c[first], np.concatenate([w, w])[first]))
        if self.bridge:
            src = np.fromiter(self.bridge, np.int64, len(self.bridge))
            dst = np.array([self.bridge[v][0] for v in src], np.int64)
            g = g.maximum(sparse(src, dst, np.zeros(len(src))))
        if self._invalid:
            g = g.tocoo()
            bad = np.array(sorted(self._invalid), np.int64)
            bad = np.sort(bad[:, 0] * (1 << 32) + bad[:, 1])
            key = np.minimum(g.row, g.col).astype(np.int64) * (1 << 32) + \
                np.maximum(g.row, g.col)
            at = np.minimum(np.searchsorted(bad, key), len(bad) - 1)
            keep = bad[at] != key
            g = csr_matrix((g.data[keep], (g.row[keep], g.col[keep])), shape=(n, n))
        return g.tocsr()

    def _portals(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Per mode, (entries, exits): the vertices where the robot arrives in the mode (the
        start, bridges) and those where it leaves it (transition and goal vertices). Every
        entry is joined to every exit: the straight motion between them is often free and is
        what a first solution needs (the unified planner's connect step); k-nearest edges
        rarely span that far in a high-dimensional space with 50 samples per batch."""
        entries: dict[int, list[int]] = {0: [0]}
        exits: dict[int, list[int]] = {}
        for t, (b, _) in self.bridge.items():
            entries.setdefault(self.node_mode[b], []).append(b)
            exits.setdefault(self.node_mode[t], []).append(t)
        for g in self.goals:
            if g not in entries.get(self.node_mode[g], ()):
                exits.setdefault(self.node_mode[g], []).append(g)
        return {mid: (np.asarray(ins, np.int64), np.asarray(exits[mid], np.int64))
                for mid, ins in entries.items() if exits.get(mid)}

    def _neighbours(self, mid: int, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The nearest neighbours of a mode's vertices (positions in the mode's list) and their
        costs, sorted, at least ``k`` per vertex (fewer when the mode has fewer): kept between
        searches and updated with the new vertices only (their costs to all, the old lists
        merged with the new columns); rebuilt when k outgrows what is kept."""
        ids = self.mode_vertices[mid]
        X = self.Q[ids]
        keep = min(k + 4, len(ids) - 1)
        nn, nc = self._nn.get(mid, (np.zeros((0, 0), np.int64), np.zeros((0, 0))))
        old = len(nn)
        if old and nn.shape[1] < min(k, len(ids) - 1):
            old = 0                                     # k grew past the lists: start over
        new = np.arange(old, len(ids))
        if len(new):
            C = np.empty((len(new), len(ids)))
            step = max(1, int(2e6 // (len(ids) * self.dim)))   # bounds the (r, N, n) block
            for lo in range(0, len(new), step):
                C[lo:lo + step] = self.p.cost(X[None], X[new[lo:lo + step], None])
            C[np.arange(len(new)), new] = np.inf
            top = _smallest(C, keep)
            rows_new = (top, np.take_along_axis(C, top, 1))
            if old:
                cand = np.concatenate([nn, np.broadcast_to(new, (old, len(new)))], 1)
                cost = np.concatenate([nc, C[:, :old].T], 1)
                order = _smallest(cost, keep)
                nn = np.concatenate([np.take_along_axis(cand, order, 1), _pad(rows_new[0], keep)])
                nc = np.concatenate([np.take_along_axis(cost, order, 1),
                                     _pad(rows_new[1], keep, np.inf)])
            else:
                nn, nc = rows_new
            self._nn[mid] = (nn, nc)
        return nn, nc

    def _search(self) -> bool:
        """Reverse Dijkstra for h, then the forward lazy A*; True if the best cost improved."""
        if not self.goals or len(self.node_mode) == self._graph_size:
            return False
        t = self._search_t0 = time.perf_counter()
        self.counts["searches"] += 1
        g = self._graph()
        _, dijkstra = _graphs()
        h = dijkstra(g.T.tocsr(), directed=True, indices=sorted(self.goals), min_only=True)
        improved = self._forward(g, h)
        if self.best_path is not None:
            self._later += 1
        self._graph_size = len(self.node_mode)
        self.p.timers.search += time.perf_counter() - t
        return improved

    def _forward(self, g, h: np.ndarray) -> bool:
        """Lazy A* with edges checked at the coarse step; the edges of the path it finds are
        then checked at the full resolution (all at once) and, if one fails, it is blacklisted
        and the search goes on: every edge of a reported path is valid at the resolution."""
        depth = np.array([self.depth[m] for m in self.node_mode])
        self._checks_left = self.opt.search_budget or math.inf
        lists = adjacency(g, h)
        # what a search spends before it can stop at the deadline, per vertex
        self._graph_seconds = (time.perf_counter() - self._search_t0) / len(self.node_mode)
        while True:
            # weighted (ABIT*'s inflation): a path found with fewer edge checks, at most
            # ``weight`` times the graph's cheapest; after the first solution the weight goes
            # down to 1 (1 + (inflation - 1) deflation^k at the k-th later search), so the
            # anytime costs reach the optimum while each search still ends within its budget
            weight = 1.0 + (self.opt.inflation - 1.0) * self.opt.deflation ** self._later
            try:
                cost, path, closed = lazy_astar(lists, h, 0, self.goals, self._valid,
                                                self.best_cost, self._check, weight=weight,
                                                deadline=self._deadline)
            except _OutOfChecks:
                self.counts["searches_cut"] += 1
                return False
            if path is None:
                if self.best_path is None and closed:
                    reached = np.fromiter(closed, np.int64, len(closed))
                    self._progress = _chain(closed, int(reached[np.argmax(depth[reached])]))
                return False
            if self._confirm(path):
                break
        self._improve(cost, path)
        return True

    def _confirm(self, path: list[int]) -> bool:
        """Check the edges of ``path`` at the full resolution (those not confirmed yet, a
        batched call per mode); False if one fails (it is then invalid)."""
        todo: dict[int, list[tuple[int, int]]] = {}
        for u, v in zip(path, path[1:]):
            key = _key(u, v)
            if not self._is_bridge(u, v) and key not in self._fine:
                todo.setdefault(self.node_mode[u], []).append(key)
        good = True
        groups = [(mid, keys, np.array(keys).T) for mid, keys in todo.items()]
        oks = self.p.motions_valid_many([(self.modes[mid], self.Q[a], self.Q[b])
                                         for mid, _, (a, b) in groups], self.opt.resolution)
        for (_, keys, _), ok in zip(groups, oks):
            self.counts["edges_confirmed"] += len(keys)
            for key, fine in zip(keys, ok.tolist()):
                self._fine[key] = fine
                if not fine:
                    self._mark(key, False)
                    good = False
        return good

    def _new_portal(self, v: int) -> None:
        if self.opt.escape_lazy:
            self._portal_set.add(v)
        else:
            self._to_escape.append(v)

    def _mark(self, key: tuple[int, int], ok: bool) -> None:
        self.edge_ok[key] = ok
        if not ok:
            self.counts["edges_invalid"] += 1
            self._invalid.add(key)
            for v in key:
                if v in self._portal_set:
                    self._portal_set.discard(v)
                    self._to_escape.append(v)

    def _valid(self, u: int, v: int) -> bool | None:
        """Is the edge u -> v collision-free (None: not checked yet; transition edges always
        are)?"""
        if self._is_bridge(u, v):
            return True
        return self.edge_ok.get(_key(u, v))

    def _is_bridge(self, u: int, v: int) -> bool:
        """Is u -> v a transition edge (u's action taking it to v in the next mode)?"""
        return self.bridge.get(u, (None,))[0] == v

    def _check(self, pairs) -> None:
        """Collision-check the unchecked edges among ``pairs`` (the popped one and those near
        the top of the search's queue), a batched call per mode, at ``coarse`` times the
        resolution: most edges that fail show it at a coarse step already (a state of the
        segment collides), and only the edges of a path found are checked at every step
        (:meth:`_confirm`)."""
        todo: dict[int, dict[tuple[int, int], None]] = {}      # per mode, keys in order
        for u, v in pairs:
            if self._valid(u, v) is None:
                todo.setdefault(self.node_mode[u], {})[_key(u, v)] = None
        groups, spent = [], time.perf_counter() >= self._deadline     # the run's time is up
        for mid, keys in todo.items():
            if spent or self._checks_left <= 0:
                spent = True               # the modes before this one are still checked
                break
            self._checks_left -= len(keys)
            groups.append((mid, list(keys)))
        items = [(self.modes[mid], self.Q[a], self.Q[b])
                 for mid, keys in groups for a, b in [np.array(keys).T]]
        oks = self.p.motions_valid_many(items, self.opt.coarse * self.opt.resolution)
        for (_, keys), ok in zip(groups, oks):
            self.counts["edges_checked"] += len(keys)
            for key, good in zip(keys, ok.tolist()):
                self._mark(key, good)
        if spent:
            raise _OutOfChecks

    def _seed(self, deadline: float) -> bool:
        """Start from the unified planner's plan (tmpc's addition, anytime runs only): run it
        (same seed) and make its path a path of the graph: its states become vertices of the
        modes this planner derives for them (its actions' transitions, with their bridges, and
        its last state a goal vertex), its motions edges, checked here at the full resolution,
        ends included. The graph then grows and searches as without it, bounded by this cost
        from the start: a search only returns a cheaper plan. The objective is the composite
        length alone, so the seed may have more actions than the task optimum (clutter-14 with
        14 red sticks: unified's plans have 32-34 actions, the optimum is 28, and cost 0.5-0.65x
        the optimal planner's own plans at 30 s). True if the plan was taken."""
        if not self.opt.seed_unified or self.opt.first_solution:
            return False
        p = self.p
        unified = UnifiedPlanner.from_options(p, self.seed)    # the configuration's options
        # a third of the time left at most: a problem unified is slow on keeps the rest
        res = unified.solve(max(0.0, deadline - time.perf_counter()) / 3)
        self.counts["seed"] = res.status
        if res.status == "interrupted":
            raise KeyboardInterrupt
        if res.status != "solved" or np.abs(p.difference(res.path[0][0], p.q0)).max() > 1e-9:
            return False
        mode, ids = self.modes[0], [0]
        for (q, _, action), (q2, _, _) in zip(res.path, res.path[1:]):
            u = ids[-1]
            if action is None:
                ids.append(self._add_vertex(q2, mode))
                continue
            if np.abs(p.difference(q2, q)).max() > 1e-9:
                return False                 # an action that moves: not a transition vertex
            new = p.successor_mode(mode, action, q, len(self.modes))
            succ, _ = self._mode(new.sym, new.poses, new.held, mode, action)
            self._transition(mode.sym, action, succ.sym).count(mode.id)
            ids.append(self._add_vertex(q, succ))
            self.bridge[u] = (ids[-1], action)
            mode = succ
        last = ids[-1]
        if not self._goal_mode(mode) or (p.goal_formula() is not None
                                         and not p.holds(mode, None, self.Q[last])):
            return False
        segs = self._segments(ids)
        self._check_fine(segs, [[(i, i + 1) for i in range(len(s) - 1)] for s in segs])
        if not all(self._fine[_key(u, v)] for s in segs for u, v in zip(s, s[1:])):
            self.counts["seed"] = "rejected at the resolution"
            return False
        self.goals.add(last)
        self._improve(self._path_cost(ids), ids)
        return True

    def _shortcut(self, deadline: float) -> bool:
        """Shortcuts of the best path (tmpc's addition: the unified planner's smoothing, done
        as graph edges). Per mode segment (the vertices between two transitions), its edges
        are cut into ``shortcut_points`` pieces in all (new vertices, outside the nearest-
        neighbour lists), and straight motions between ``shortcut_tries`` pairs of those
        points at least two apart (longer jumps likelier) are checked at the full resolution,
        ends included, every segment's in one batched call. Each segment is then replaced by
        its cheapest route over the free shortcuts and the pieces; the pieces that route uses
        are checked the same way (a piece of a valid edge is not valid by itself at the
        validator's resolution: its states are other states), and a failed one is removed and
        the route found again. ``shortcut_rounds`` rounds, until ``deadline``. The free
        motions become graph edges known valid, so later searches start from the new cost
        (their bound) and can reuse them. True if the cost went down."""
        opt = self.opt
        if opt.shortcut_tries <= 0 or self.best_path is None:
            return False
        path = list(self.best_path)
        for _ in range(opt.shortcut_rounds):
            if time.perf_counter() >= deadline:
                break
            dense = [self._dense(seg) for seg in self._segments(path)]
            tries = []
            for seg, _ in dense:
                far = [(i, j) for i in range(len(seg)) for j in range(i + 2, len(seg))
                       if _key(seg[i], seg[j]) not in self._fine]
                if len(far) > opt.shortcut_tries:
                    gap = np.array([j - i for i, j in far], float)
                    pick = self.rng.choice(len(far), opt.shortcut_tries, replace=False,
                                           p=gap / gap.sum())
                    far = [far[k] for k in sorted(pick)]
                tries.append(far)
            self._check_fine([seg for seg, _ in dense], tries)
            costs = [self.p.cost(self.Q[seg][None], self.Q[seg][:, None]).tolist()
                     for seg, _ in dense]
            routes = [None] * len(dense)
            while True:               # route over the pieces, check the pieces used, again
                pieces = []
                for k, (seg, _) in enumerate(dense):
                    routes[k] = self._route(seg, costs[k])
                    r = routes[k] or []
                    pieces.append([(i, j) for i, j in zip(r, r[1:])
                                   if _key(seg[i], seg[j]) not in self._fine])
                if not any(pieces):
                    break
                self._check_fine([seg for seg, _ in dense], pieces)
            out = []
            for (seg, points), r in zip(dense, routes):
                out += [seg[i] for i in r] if r is not None else \
                    [v for v in seg if v not in points]
            if out == path:
                break
            path = out
        cost = self._path_cost(path)
        if cost >= self.best_cost - 1e-6:
            return False
        self._improve(cost, path)
        return True

    def _polish(self, deadline: float) -> None:
        """A new solution shortcut, then its transitions refined, each improvement
        reported."""
        if self._shortcut(deadline):
            self._report()
        if self._refine(deadline):
            self._report()

    def _refine(self, deadline: float) -> bool:
        """The best path's transitions moved along their constraints and its corners cut
        (:func:`~tmpc.runtime.planners.refine.refine_path`, tmpc's addition). The vertices
        that moved become new vertices (outside the nearest-neighbour lists) with their
        bridges, the motions between them edges known valid: the refined path is a path of
        the graph. True if the cost went down."""
        if self.opt.refine_sweeps <= 0 or self.best_path is None or len(self.best_path) < 2:
            return False
        path = self.best_path
        actions = [self.bridge[u][1] if self._is_bridge(u, v) else None
                   for u, v in zip(path, path[1:])] + [None]
        out = refine_path(self.p, self.Q[path], [self.modes[self.node_mode[v]] for v in path],
                          actions, lambda m, new: m.sym == new.sym and
                          _same_poses(m, new.poses, new.held),
                          self.opt.resolution, deadline, max_sweeps=self.opt.refine_sweeps)
        self.counts["refine_sweeps"] = self.counts.get("refine_sweeps", 0) + out.sweeps
        if out.cost >= self.best_cost - 1e-6:
            return False
        ids = [self._add_vertex(q, self.modes[self.node_mode[path[k]]], listed=False)
               if k in out.moved else path[k] for q, k in zip(out.Q, out.keep)]
        for (a, b), k in zip(zip(ids, ids[1:]), out.keep):
            if actions[k] is not None:
                self.bridge[a] = (b, actions[k])
            elif not self._fine.get(_key(a, b)):
                self.edge_ok[_key(a, b)] = self._fine[_key(a, b)] = True
                self.shortcuts.append((a, b, float(self.p.cost(self.Q[b], self.Q[a]))))
        if path[-1] in self.goals:
            self.goals.add(ids[-1])
        self._improve(self._path_cost(ids), ids)
        return True

    def _segments(self, path: list[int]) -> list[list[int]]:
        """``path`` cut at its transitions (a change of mode, or a bridge): the mode segments."""
        segs, cut = [], 0
        for k in range(len(path) - 1):
            if self.node_mode[path[k]] != self.node_mode[path[k + 1]] \
                    or self._is_bridge(path[k], path[k + 1]):
                segs.append(path[cut:k + 1])
                cut = k + 1
        segs.append(path[cut:])
        return segs

    def _improve(self, cost: float, path: list[int]) -> None:
        """A new best solution, recorded in the cost-over-time trace."""
        self.best_cost, self.best_path = cost, path
        self.trace.append((round(time.perf_counter() - self._t0, 4), round(cost, 6)))

    def _check_fine(self, segs: list[list[int]], pairs: list[list[tuple[int, int]]]) -> None:
        """Check the motions seg[i] -> seg[j] of each segment's pairs at the full resolution,
        ends included, in one batched call; the free ones become edges known valid."""
        p = self.p
        items = [(self.modes[self.node_mode[seg[0]]], self.Q[[seg[i] for i, _ in prs]],
                  self.Q[[seg[j] for _, j in prs]]) for seg, prs in zip(segs, pairs) if prs]
        if not items:
            return
        oks = iter(p.motions_valid_many(items, self.opt.resolution, ends=True))
        for seg, prs in zip(segs, pairs):
            if not prs:
                continue
            for (i, j), good in zip(prs, next(oks).tolist()):
                key = _key(seg[i], seg[j])
                self.edge_ok[key] = self._fine[key] = good
                if good:
                    self.shortcuts.append((seg[i], seg[j], float(
                        p.cost(self.Q[seg[j]], self.Q[seg[i]]))))
                    self.counts["shortcuts"] += int(j > i + 1)
                else:
                    self._invalid.add(key)

    def _dense(self, seg: list[int]) -> tuple[list[int], set[int]]:
        """The segment with its edges cut into about ``shortcut_points`` pieces in all, and
        the new points (vertices of the segment's mode, not in its nearest-neighbour lists)."""
        if len(seg) < 2:
            return seg, set()
        p = self.p
        Q = self.Q[seg]
        step = p.cost(Q[1:], Q[:-1])
        piece = max(float(step.sum()) / self.opt.shortcut_points, 1e-9)
        mode = self.modes[self.node_mode[seg[0]]]
        out, points = [seg[0]], set()
        for k, (u, v) in enumerate(zip(seg, seg[1:])):
            n = int(min(math.ceil(step[k] / piece), 64))
            d = p.difference(self.Q[v], self.Q[u])
            for t in range(1, n):
                w = self._add_vertex(p.wrap(self.Q[u] + d * (t / n)), mode, listed=False)
                points.add(w)
                out.append(w)
            out.append(v)
        return out, points

    def _route(self, seg: list[int], C: list) -> list[int] | None:
        """Positions of the cheapest route from seg[0] to seg[-1] (a DAG: i -> j for i < j)
        over the pieces (i -> i + 1) not known invalid and the motions known valid (costs
        C[i, j]), or None if there is none."""
        best, back = [0.0], [-1]
        for j in range(1, len(seg)):
            b, arg = math.inf, -1
            for i in range(j):
                ok = self._fine.get(_key(seg[i], seg[j]))
                if ok or (ok is None and i == j - 1):
                    c = best[i] + C[i][j]
                    if c < b:
                        b, arg = c, i
            best.append(b)
            back.append(arg)
        if not math.isfinite(best[-1]):
            return None
        out, j = [], len(seg) - 1
        while j >= 0:
            out.append(j)
            j = back[j]
        return out[::-1]

    def _path_cost(self, path: list[int]) -> float:
        """Composite length of a path of vertices (transition edges cost nothing)."""
        return float(sum(0.0 if self._is_bridge(u, v) else self.p.cost(self.Q[v], self.Q[u])
                         for u, v in zip(path, path[1:])))

    # ---- the loop ----------------------------------------------------------------------------
    def solve(self, time_limit: float, progress=None) -> OptimalResult:
        p = self.p
        self._t0 = start = time.perf_counter()
        deadline = self._deadline = start + time_limit
        self._add_mode(p.initial, 0)
        root = self._add_vertex(p.q0, p.initial)
        status = "partial"
        try:
            if self._goal_mode(p.initial) and (p.goal_formula() is None
                                               or p.holds(p.initial, None, p.q0)):
                self.goals.add(root)
                self.best_cost, self.best_path = 0.0, [root]
                self.trace.append((0.0, 0.0))
            else:
                if self._seed(deadline):
                    self._report()
                    self._polish(deadline)
                self._new_task_plan(deadline)
                self._new_batch()
            while self.best_path != [root] and time.perf_counter() < deadline:
                done = self._sample_modes(deadline)
                if not self._search_fits(deadline):
                    break         # no time for a search (its graph first: ~2 s at 140k vertices)
                found = self._search()
                if not found and self.best_path is None and (self._to_escape
                                                             or self._portal_set):
                    # no path: stubs out of every portal not escaped from yet, then again
                    self._to_escape += sorted(self._portal_set)
                    self._portal_set.clear()
                    self._escape()
                    if self._search_fits(deadline):
                        found = self._search()
                if found:
                    self._report()
                    if self.opt.first_solution:
                        break
                    self._polish(deadline)
                if self.best_path is not None:
                    self._search_costs.append(self.best_cost)
                    if self._converged():
                        break
                if done:
                    if self.no_budget or (self.tried and self.batch_budget <= 0):
                        self._new_task_plan(deadline)
                    self._new_batch()
                if progress is not None:
                    progress(self)
        except KeyboardInterrupt:
            status = "interrupted"
            self.counts["interrupted"] = True
        return self._result(status, time.perf_counter() - start)

    def _search_fits(self, deadline: float) -> bool:
        """Is there time for a search before ``deadline``: its graph, heuristic and adjacency
        lists (which do not stop at the deadline) as long per vertex as the last one's?"""
        return time.perf_counter() + self._graph_seconds * len(self.node_mode) < deadline

    def _converged(self) -> bool:
        n = self.opt.converged_solutions
        if not self.opt.until_converged or len(self._search_costs) < n:
            return False
        last = self._search_costs[-n:]
        return max(last) - min(last) <= self.opt.converged_ratio * min(last)

    def _report(self) -> None:
        if self.on_solution is not None:
            self.on_solution(self._result("solved", time.perf_counter() - self._t0))

    def _result(self, status: str, seconds: float) -> OptimalResult:
        solved = self.best_path is not None
        ids = self.best_path if solved else self._progress
        path = []
        for k, v in enumerate(ids):
            nxt = ids[k + 1] if k + 1 < len(ids) else None
            b = self.bridge.get(v)
            action = b[1] if b is not None and b[0] == nxt else None
            path.append((self.Q[v].copy(), self.modes[self.node_mode[v]], action))
        stats = dict(self.counts, seconds=round(seconds, 4), nodes=len(self.node_mode),
                     modes=len(self.modes), cost=round(self.best_cost, 6) if solved else None,
                     cost_trace=[list(x) for x in self.trace],
                     first_solution_seconds=self.trace[0][0] if self.trace else None,
                     time=self.p.timers.as_dict())
        if solved:
            status = "solved"
        return OptimalResult(status, path, stats, self.best_cost)

class _OutOfChecks(Exception):
    """A search spent its edge-check budget (``search_budget``)."""


def lazy_astar(g, h: np.ndarray, start: int, goals, valid, bound: float = math.inf,
               check=None, lookahead: int = 64, weight: float = 1.0,
               deadline: float = math.inf):
    """A* over the CSR graph ``g`` (edge costs) from ``start`` to any of ``goals`` with a
    consistent heuristic ``h`` (inf: no goal reachable), evaluating an edge only when the entry
    that uses it is popped (lazy A*), and only for paths cheaper than ``bound``.

    ``valid(u, v)``: True/False, or None while the edge is unknown; then ``check(pairs)`` is
    called with that edge and the edges of the entries at the top of the queue (the first
    ``lookahead`` of its heap: those popped soon), to evaluate them in one batch, and ``valid``
    is asked again. ``weight`` > 1 orders the queue by g + weight h (weighted A*: a path at most
    ``weight`` times the cheapest, found after fewer edge checks). Returns (cost, path,
    parents): the cheapest path whose edges are all valid (with ``weight`` 1), or (inf, None,
    parents) when none beats ``bound``; ``parents`` maps every closed vertex to its parent (-1
    for the start). Past ``deadline`` (``time.perf_counter()``, read every 1024 entries) it
    raises :class:`_OutOfChecks`."""
    # Python lists: the loop reads them element by element (numpy scalars cost several times
    # more per read); ``g`` may be the (indptr, indices, data, h) lists of :func:`adjacency`
    indptr, ind, data, h = g if isinstance(g, tuple) else adjacency(g, h)
    closed: dict[int, int] = {}
    inf = math.inf
    if h[start] == inf:
        return inf, None, closed
    heap = [(weight * float(h[start]), 0.0, 0, start, -1)]
    count = pops = 0
    while heap:
        f, gv, _, v, u = heapq.heappop(heap)
        pops += 1
        if not pops & 1023 and time.perf_counter() > deadline:
            raise _OutOfChecks
        if gv + h[v] >= bound - 1e-12:
            if weight == 1.0:
                break                   # ordered by g + h: nothing left can beat the bound
            continue
        if v in closed:
            continue
        if u >= 0:
            ok = valid(u, v)
            if ok is None:
                check([(u, v)] + [(e[4], e[3]) for e in heap[:lookahead]
                                  if e[3] not in closed and e[4] >= 0])
                ok = valid(u, v)
            if not ok:
                continue
        closed[v] = u
        if v in goals:
            return gv, _chain(closed, v), closed
        for a in range(indptr[v], indptr[v + 1]):
            w = ind[a]
            hw = h[w]
            if hw == inf or w in closed:
                continue
            ng = gv + data[a]
            if ng + hw < bound:
                count += 1
                heapq.heappush(heap, (ng + weight * hw, ng, count, w, v))
    return inf, None, closed


def adjacency(g, h: np.ndarray) -> tuple[list, list, list, list]:
    """The CSR graph ``g`` and the heuristic ``h`` as Python lists, for :func:`lazy_astar`
    (made once for the searches over one graph)."""
    return g.indptr.tolist(), g.indices.tolist(), g.data.tolist(), \
        np.asarray(h, float).tolist()


def _smallest(C: np.ndarray, k: int) -> np.ndarray:
    """Column indices of each row's ``k`` smallest entries, in order: what a stable argsort's
    first ``k`` columns are (ties by column), after a partial sort when the rows are long.
    A full sort of every row was most of a graph's construction at ~100k vertices."""
    if k <= 0:
        return np.zeros((len(C), 0), np.int64)
    if C.shape[1] <= 4 * k:
        return np.argsort(C, axis=1, kind="stable")[:, :k]
    part = np.argpartition(C, k - 1, axis=1)[:, :k]
    # the k-th value's ties may be cut arbitrarily by the partition: take every column up to it
    kth = np.take_along_axis(C, part, 1).max(1, keepdims=True)
    within = C <= kth
    if (within.sum(1) == k).all():
        sub = np.sort(part, axis=1)            # column order, then by value (stable: ties by col)
        vals = np.take_along_axis(C, sub, 1)
        return np.take_along_axis(sub, np.argsort(vals, axis=1, kind="stable"), 1)
    return np.argsort(C, axis=1, kind="stable")[:, :k]     # ties at the k-th value: exact


def _pad(a: np.ndarray, width: int, value=0) -> np.ndarray:
    """``a`` (r, w <= width) padded on the right to ``width`` columns."""
    if a.shape[1] >= width:
        return a[:, :width]
    return np.concatenate([a, np.full((len(a), width - a.shape[1]), value, a.dtype)], 1)


def _chain(parents: dict[int, int], v: int) -> list[int]:
    """The path from the search's root to v through the parents."""
    path = [v]
    while parents[path[-1]] >= 0:
        path.append(parents[path[-1]])
    return path[::-1]


def _key(u: int, v: int) -> tuple[int, int]:
    return (u, v) if u < v else (v, u)


def _same_poses(m: Mode, poses, held) -> bool:
    if set(m.held) != set(held) or set(m.poses) != set(poses):
        return False
    for name, (frame, T) in held.items():
        f2, T2 = m.held[name]
        if f2 != frame or not np.allclose(T, T2, atol=1e-3):
            return False
    return all(np.allclose(poses[name], m.poses[name], atol=1e-3) for name in poses)


__all__ = ["OptimalPlanner", "OptimalOptions", "OptimalResult", "Transition", "lazy_astar"]
