"""Improvement of solutions (tmpc's additions, anytime runs): shortcuts inside each mode,
transition refinement along the manifolds that keep the transitions' effects, and the seed
from the unified planner's plan; every result is a path of the graph.

Each improved solution is shortcut inside its modes (:meth:`Improver.shortcut`), then its
transitions are moved along their constraints (:meth:`Improver.refine_transitions`, with
:func:`tmpc.runtime.planners.optimal.refine.refine_path`); :meth:`Improver.improve_solution` is
that pass. An anytime run starts from the unified planner's plan
(:meth:`Improver.seed_from_unified`). The free motions each step finds become graph edges known
valid, so later searches start from the new cost (their bound) and can reuse them.
"""

from __future__ import annotations

import math
import time

import numpy as np

from tmpc.runtime.planners.optimal.graph import ModeGraph, edge_key, same_poses
from tmpc.runtime.planners.optimal.options import BestSolution, OptimalOptions
from tmpc.runtime.planners.optimal.refine import refine_path
from tmpc.runtime.planners.optimal.tasks import TaskPlans
from tmpc.runtime.planners.unified import UnifiedPlanner
from tmpc.runtime.problem import PlanningProblem


class Improver:
    """Shortcuts, transition refinement and the unified seed of the best solution."""

    def __init__(self, problem: PlanningProblem, options: OptimalOptions, graph: ModeGraph,
                 tasks: TaskPlans, best: BestSolution, rng: np.random.Generator, counts: dict,
                 seed: int):
        self.p = problem
        self.opt = options
        self.graph = graph
        self.tasks = tasks
        self.best = best
        self.rng = rng
        self.counts = counts
        self.seed = seed

    def improve_solution(self, deadline: float, report) -> None:
        """A new solution shortcut, then its transitions refined; ``report()`` after each
        step that lowered the cost."""
        if self.shortcut(deadline):
            report()
        if self.refine_transitions(deadline):
            report()

    # ---- the seed ----------------------------------------------------------------------------
    def seed_from_unified(self, deadline: float) -> bool:
        """Start from the unified planner's plan (anytime runs only): run it (same seed) and
        make its path a path of the graph: its states become vertices of the modes this planner
        derives for them (its actions' transitions, with their bridges, and its last state a
        goal vertex), its motions edges, checked here at the full resolution, ends included.
        The graph then grows and searches as without it, bounded by this cost from the start:
        a search only returns a cheaper plan. The objective is the composite length alone, so
        the seed may have more actions than the task optimum. True if the plan was taken."""
        if not self.opt.seed_unified or self.opt.first_solution:
            return False
        p, G = self.p, self.graph
        unified = UnifiedPlanner.from_options(p, self.seed)    # the configuration's options
        # a third of the time left at most: a problem unified is slow on keeps the rest
        res = unified.solve(max(0.0, deadline - time.perf_counter()) / 3)
        self.counts["seed"] = res.status
        if res.status == "interrupted":
            raise KeyboardInterrupt
        if res.status != "solved" or np.abs(p.difference(res.path[0][0], p.q0)).max() > 1e-9:
            return False
        mode, ids = G.modes[0], [0]
        for (q, _, action), (q2, _, _) in zip(res.path, res.path[1:]):
            u = ids[-1]
            if action is None:
                ids.append(G.add_vertex(q2, mode))
                continue
            if np.abs(p.difference(q2, q)).max() > 1e-9:
                return False                 # an action that moves: not a transition vertex
            new = p.successor_mode(mode, action, q, len(G.modes))
            succ, _ = G.find_or_add_mode(new.sym, new.poses, new.held, mode, action)
            self.tasks.transition(mode.sym, action, succ.sym).count(mode.id)
            ids.append(G.add_vertex(q, succ))
            G.bridge[u] = (ids[-1], action)
            mode = succ
        last = ids[-1]
        if not G.is_goal_mode(mode) or (p.goal_formula() is not None
                                        and not p.holds(mode, None, G.Q[last])):
            return False
        segs = G.segments(ids)
        self._check_fine(segs, [[(i, i + 1) for i in range(len(s) - 1)] for s in segs])
        if not all(G.fine[edge_key(u, v)] for s in segs for u, v in zip(s, s[1:])):
            self.counts["seed"] = "rejected at the resolution"
            return False
        G.goals.add(last)
        self.best.record_solution(G.path_cost(ids), ids)
        return True

    # ---- shortcuts ---------------------------------------------------------------------------
    def shortcut(self, deadline: float) -> bool:
        """Shortcuts of the best path (the unified planner's smoothing, done as graph edges).
        Per mode segment (the vertices between two transitions), its edges are cut into
        ``shortcut_points`` pieces in all (new vertices, outside the nearest-neighbour lists),
        and straight motions between ``shortcut_tries`` pairs of those points at least two
        apart (longer jumps likelier) are checked at the full resolution, ends included, every
        segment's in one batched call. Each segment is then replaced by its cheapest route over
        the free shortcuts and the pieces; the pieces that route uses are checked the same way
        (a piece of a valid edge is not valid by itself at the validator's resolution: its
        states are other states), and a failed one is removed and the route found again.
        ``shortcut_rounds`` rounds, until ``deadline``. True if the cost went down."""
        opt, G = self.opt, self.graph
        if opt.shortcut_tries <= 0 or self.best.path is None:
            return False
        path = list(self.best.path)
        for _ in range(opt.shortcut_rounds):
            if time.perf_counter() >= deadline:
                break
            dense = [self._dense(seg) for seg in G.segments(path)]
            tries = []
            for seg, _ in dense:
                far = [(i, j) for i in range(len(seg)) for j in range(i + 2, len(seg))
                       if edge_key(seg[i], seg[j]) not in G.fine]
                if len(far) > opt.shortcut_tries:
                    gap = np.array([j - i for i, j in far], float)
                    pick = self.rng.choice(len(far), opt.shortcut_tries, replace=False,
                                           p=gap / gap.sum())
                    far = [far[k] for k in sorted(pick)]
                tries.append(far)
            self._check_fine([seg for seg, _ in dense], tries)
            costs = [self.p.cost(G.Q[seg][None], G.Q[seg][:, None]).tolist()
                     for seg, _ in dense]
            routes = [None] * len(dense)
            while True:               # route over the pieces, check the pieces used, again
                pieces = []
                for k, (seg, _) in enumerate(dense):
                    routes[k] = self._route(seg, costs[k])
                    r = routes[k] or []
                    pieces.append([(i, j) for i, j in zip(r, r[1:])
                                   if edge_key(seg[i], seg[j]) not in G.fine])
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
        cost = G.path_cost(path)
        if cost >= self.best.cost - 1e-6:
            return False
        self.best.record_solution(cost, path)
        return True

    def _check_fine(self, segs: list[list[int]], pairs: list[list[tuple[int, int]]]) -> None:
        """Check the motions seg[i] -> seg[j] of each segment's pairs at the full resolution,
        ends included, in one batched call; the free ones become edges known valid."""
        p, G = self.p, self.graph
        items = [(G.mode_of(seg[0]), G.Q[[seg[i] for i, _ in prs]],
                  G.Q[[seg[j] for _, j in prs]]) for seg, prs in zip(segs, pairs) if prs]
        if not items:
            return
        oks = iter(p.motions_valid_many(items, self.opt.resolution, ends=True))
        for seg, prs in zip(segs, pairs):
            if not prs:
                continue
            for (i, j), good in zip(prs, next(oks).tolist()):
                key = edge_key(seg[i], seg[j])
                G.edge_ok[key] = G.fine[key] = good
                if good:
                    G.shortcuts.append((seg[i], seg[j], float(
                        p.cost(G.Q[seg[j]], G.Q[seg[i]]))))
                    self.counts["shortcuts"] += int(j > i + 1)
                else:
                    G.invalid.add(key)

    def _dense(self, seg: list[int]) -> tuple[list[int], set[int]]:
        """The segment with its edges cut into about ``shortcut_points`` pieces in all, and
        the new points (vertices of the segment's mode, not in its nearest-neighbour lists)."""
        if len(seg) < 2:
            return seg, set()
        p, G = self.p, self.graph
        Q = G.Q[seg]
        step = p.cost(Q[1:], Q[:-1])
        piece = max(float(step.sum()) / self.opt.shortcut_points, 1e-9)
        mode = G.mode_of(seg[0])
        out, points = [seg[0]], set()
        for k, (u, v) in enumerate(zip(seg, seg[1:])):
            n = int(min(math.ceil(step[k] / piece), 64))
            d = p.difference(G.Q[v], G.Q[u])
            for t in range(1, n):
                w = G.add_vertex(p.wrap(G.Q[u] + d * (t / n)), mode, listed=False)
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
                ok = self.graph.fine.get(edge_key(seg[i], seg[j]))
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

    # ---- transition refinement ---------------------------------------------------------------
    def refine_transitions(self, deadline: float) -> bool:
        """The best path's transitions moved along their constraints and its corners cut
        (:func:`tmpc.runtime.planners.optimal.refine.refine_path`). The vertices that moved
        become new vertices (outside the nearest-neighbour lists) with their bridges, the
        motions between them edges known valid: the refined path is a path of the graph. True
        if the cost went down."""
        G = self.graph
        path = self.best.path
        if self.opt.refine_sweeps <= 0 or path is None or len(path) < 2:
            return False
        actions = [G.bridge[u][1] if G.is_bridge(u, v) else None
                   for u, v in zip(path, path[1:])] + [None]
        out = refine_path(self.p, G.Q[path], [G.mode_of(v) for v in path],
                          actions, lambda m, new: m.sym == new.sym and
                          same_poses(m, new.poses, new.held),
                          self.opt.resolution, deadline, max_sweeps=self.opt.refine_sweeps)
        self.counts["refine_sweeps"] = self.counts.get("refine_sweeps", 0) + out.sweeps
        if out.cost >= self.best.cost - 1e-6:
            return False
        ids = [G.add_vertex(q, G.mode_of(path[k]), listed=False)
               if k in out.moved else path[k] for q, k in zip(out.Q, out.keep)]
        for (a, b), k in zip(zip(ids, ids[1:]), out.keep):
            if actions[k] is not None:
                G.bridge[a] = (b, actions[k])
            elif not G.fine.get(edge_key(a, b)):
                G.edge_ok[edge_key(a, b)] = G.fine[edge_key(a, b)] = True
                G.shortcuts.append((a, b, float(self.p.cost(G.Q[b], G.Q[a]))))
        if path[-1] in G.goals:
            G.goals.add(ids[-1])
        self.best.record_solution(G.path_cost(ids), ids)
        return True
