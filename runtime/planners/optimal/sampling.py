"""Batches of samples and the transitions they reach: each reachable mode's samples, the
transition attempts from them, and the success caps.

Per batch, each reachable mode (modes reached in this batch first, as tmit-star's frontier)
gets ``batch_size`` collision-free samples (uniform, and a share around the mode's entry-exit
segments: ``corridor``, ``entry_share``). For every new sample and every transition of the
mode's symbolic state with budget left (fewer than 5 successes, a cap that grows by 5 every
``cap_growth`` batches while there is no solution, and fewer than the batch's cap, which starts
at 1 and grows by 1 per batch), the precondition's distance is evaluated (the projector at 0
iterations: batched). Only samples closer than the mode's PRM* connection radius are projected
(from the sample itself). A success adds a *transition vertex* in the mode and a *bridge
vertex* at the same configuration in the successor mode (deduplicated by symbolic state, held
frames and poses to 1e-3), joined by a zero-cost directed edge. A goal with geometric literals
is one more transition of the goal states, whose successes are goal vertices; otherwise every
bridge into a goal mode is one.
"""

from __future__ import annotations

import time
from collections import deque

import numpy as np

from tmpc.runtime.planners.optimal.escapes import Escapes
from tmpc.runtime.planners.optimal.graph import ModeGraph
from tmpc.runtime.planners.optimal.options import BestSolution, OptimalOptions
from tmpc.runtime.planners.optimal.tasks import TaskPlans, Transition
from tmpc.runtime.problem import Mode, PlanningProblem


class TransitionSampler:
    """The batches: which modes are left to sample in this one (``queue``, ``frontier``), the
    caps (``cap`` this batch's, ``absolute_cap``), and whether a transition had budget
    (``no_budget``) or was tried (``tried``) in it."""

    def __init__(self, problem: PlanningProblem, options: OptimalOptions, graph: ModeGraph,
                 tasks: TaskPlans, escapes: Escapes, best: BestSolution,
                 rng: np.random.Generator, counts: dict):
        self.p = problem
        self.opt = options
        self.graph = graph
        self.tasks = tasks
        self.escapes = escapes
        self.best = best
        self.rng = rng
        self.counts = counts
        self.batch = 0
        self.batch_budget = options.batch_budget
        self.cap = 0
        self.absolute_cap = options.absolute_cap
        self.queue: deque[int] = deque()
        self.frontier: list[int] = []
        self.sampled: set[int] = set()
        self.no_budget = True
        self.tried = False

    def new_batch(self) -> None:
        """Start a batch: every reachable mode to sample, the caps one batch up."""
        self.batch += 1
        self.counts["batches"] += 1
        self.batch_budget -= 1
        self.cap += self.opt.cap_increment
        if self.opt.cap_growth and self.best.path is None and \
                self.batch % self.opt.cap_growth == 0:
            self.absolute_cap += self.opt.absolute_cap
        self.sampled = set()
        self.queue = deque(self.graph.reachable)
        self.frontier = []
        self.no_budget = True
        self.tried = False

    def needs_task_plan(self) -> bool:
        """Is a new task plan due: no transition had budget left, or one was tried and the
        batch budget is spent?"""
        return self.no_budget or (self.tried and self.batch_budget <= 0)

    def sample_modes(self, deadline: float) -> bool:
        """Sample the modes of the current batch until the batch is done (True) or a goal mode
        was reached (False: the batch resumes next time). A batch whose task plan turns out
        hopeless (:meth:`TaskPlans.hopeless`) ends there, done: one batch of Blocks World E
        with a few hundred modes made 1,500 attempts at a grasp its arm cannot reach (65 s)."""
        while (self.frontier or self.queue) and time.perf_counter() < deadline:
            mid = self.frontier.pop() if self.frontier else self.queue.popleft()
            if mid in self.sampled:
                continue
            self.sampled.add(mid)
            reached = self.sample_mode(self.graph.modes[mid])
            self.escapes.escape()
            if reached:
                return False
            if self.tasks.hopeless():
                return True
        return not (self.frontier or self.queue)

    def uniform_valid(self, mode: Mode, n: int) -> np.ndarray:
        """``n`` collision-free samples of ``mode``: uniform ones, and with ``corridor`` > 0
        that share drawn around the straight segments between the mode's entries and exits
        (a point of a random segment plus Gaussian noise of ``corridor_sigma`` times each
        coordinate's range), where a first path through the mode has to go; the uniform
        share keeps the graph dense everywhere (asymptotic optimality)."""
        p = self.p
        got, tries = [], 0
        portals = self.graph.portal_configurations(mode.id) if self.opt.corridor > 0 else None
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
        return np.concatenate(got)[:n] if got else np.zeros((0, self.graph.dim))

    def sample_mode(self, mode: Mode) -> bool:
        """A batch of samples in ``mode`` and the transitions they reach; True if a goal mode
        (or goal vertex) was reached."""
        p, G = self.p, self.graph
        Q = self.uniform_valid(mode, self.opt.batch_size)
        ids = [G.add_vertex(q, mode) for q in Q]
        # stubs are no uniform samples: the PRM* radius counts the others
        radius = G.radius(len(G.mode_vertices[mode.id]) - G.stub_count.get(mode.id, 0))
        reached = False
        for tr in self.tasks.transitions.get(mode.sym, ()):
            if not self.has_budget(tr, mode):
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
                    if not self.has_budget(tr, mode):
                        break
                    reached |= self.succeed(tr, mode, ids[i], Q[i])
                continue
            reached |= self.project(tr, mode, Q[near])
        return reached

    def project(self, tr: Transition, mode: Mode, starts: np.ndarray) -> bool:
        """Project ``starts`` onto ``tr``'s precondition (16 a call) while it has budget; a
        collision-free result succeeds. True if a goal was reached."""
        p = self.p
        reached = False
        for lo in range(0, len(starts), 16):
            if not self.has_budget(tr, mode):
                break
            part = starts[lo:lo + 16]
            self.counts["projections"] += len(part)
            Qp, holds, dist_p = p.project_raw(mode, tr.action, part,
                                              iterations=self.opt.projection_iterations)
            ok = holds.copy()
            if ok.any():
                ok[ok] = p.valid_batch(mode, Qp[ok])
            for q, h, good, d in zip(Qp, holds, ok, dist_p):
                if not self.has_budget(tr, mode):
                    break
                if good:
                    reached |= self.succeed(tr, mode, None, p.wrap(q))
                else:
                    tr.record_failure(mode, q, bool(h), float(d))
                    self.counts["transition_failures"] += 1
        return reached

    def has_budget(self, tr: Transition, mode: Mode | None = None) -> bool:
        """Successes left for ``tr`` in this batch: fewer than the batch's cap and the
        absolute cap. With ``mode_caps`` the caps count the successes from ``mode`` (and all
        of them stay under ``mode_caps`` times the absolute cap), so the budget a transition
        spent in modes that lead nowhere does not starve it in the others."""
        cap = min(self.absolute_cap, self.cap)
        if not self.opt.mode_caps or mode is None:
            return tr.successes < cap
        return tr.by_mode.get(mode.id, 0) < cap and \
            tr.successes < self.opt.mode_caps * self.absolute_cap

    def succeed(self, tr: Transition, mode: Mode, vertex: int | None, q: np.ndarray) -> bool:
        """A successful attempt of ``tr`` at ``q`` (at ``vertex``, or a new vertex): its
        transition vertex, and the bridge vertex in the successor mode; True if it reached a
        goal."""
        G = self.graph
        tr.count(mode.id)
        self.counts["transitions"] += 1
        v = G.add_vertex(q, mode) if vertex is None else vertex
        self.escapes.new_portal(v)
        if tr.action is None:
            G.goals.add(v)
            return True
        new = self.p.successor_mode(mode, tr.action, q, len(G.modes))
        succ, fresh = G.find_or_add_mode(new.sym, new.poses, new.held, mode, tr.action)
        b = G.add_vertex(q, succ)
        self.escapes.new_portal(b)
        G.bridge[v] = (b, tr.action)
        if fresh:
            self.frontier.append(succ.id)
        if G.is_goal_mode(succ) and self.p.goal_formula() is None:
            G.goals.add(b)
            return True
        return False
