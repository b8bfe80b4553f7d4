"""Escape stubs (tmpc's addition): short free motions out of portal vertices (transition,
bridge and goal vertices), kept as vertices whose edges are known valid.

A portal is often nearly trapped: a grasped object still rests on its support, or an open
gripper still surrounds the object it released, so the first step of almost every
nearest-neighbour edge (1-3 rad long) collides while steps of a few hundredths of a radian are
free (clutter-8, seed 2: a bridge whose 24 edges all failed kept four searches from a
solution). Per vertex, ``escape_tries`` random directions, each scaled to one of
``escape_steps`` (the largest coordinate step over that coordinate's range), are checked at the
full resolution, ends included, in one batched call per round; the ``escape_keep`` longest free
ones are kept, and tried from again, ``escape_rounds`` times. Only the last stubs of each chain
get nearest-neighbour edges (the ones before them join it to the portal alone), so a portal
adds a few vertices to the searches, not a cluster. With ``escape_lazy`` a portal is escaped
from only once one of its edges failed, or when a search before the first solution found no
path (all portals not escaped from yet). A portal escaped from also gets its retreat chains
(``cartesian_steps``, :mod:`tmpc.runtime.planners.retreat`): the hand straight up, back, or
both, in steps of ``cartesian_step`` metres, the way out of a grasp that random stubs rarely
find (a disc lifted off its rod); their vertices are in ``retreat_vertices``.
"""

from __future__ import annotations

import numpy as np

from tmpc.runtime.planners.optimal.graph import ModeGraph, edge_key
from tmpc.runtime.planners.optimal.options import OptimalOptions
from tmpc.runtime.planners.retreat import hand_frames, retreat_chains
from tmpc.runtime.problem import PlanningProblem


class Escapes:
    """The portals waiting for escape stubs and the stubs' making. ``due``: portals to escape
    from at the next :meth:`Escapes.escape`; ``waiting`` (``escape_lazy``): portals not escaped from
    yet, until one of their edges fails."""

    def __init__(self, problem: PlanningProblem, options: OptimalOptions, graph: ModeGraph,
                 rng: np.random.Generator, counts: dict):
        self.p = problem
        self.opt = options
        self.graph = graph
        self.rng = rng
        self.counts = counts
        self.due: list[int] = []
        self.waiting: set[int] = set()
        self._hands: list[int] | None = None
        #: the vertices of retreat chains (the others are random stubs)
        self.retreat_vertices: set[int] = set()

    def new_portal(self, v: int) -> None:
        """Vertex ``v`` is a new portal: due at once, or (``escape_lazy``) waiting."""
        if self.opt.escape_lazy:
            self.waiting.add(v)
        else:
            self.due.append(v)

    def edge_failed(self, key: tuple[int, int]) -> None:
        """The edge ``key`` is invalid: a waiting portal at either end becomes due."""
        for v in key:
            if v in self.waiting:
                self.waiting.discard(v)
                self.due.append(v)

    def release_all(self) -> bool:
        """Every waiting portal becomes due (a search found no path); False if none was due
        or waiting."""
        if not (self.due or self.waiting):
            return False
        self.due += sorted(self.waiting)
        self.waiting.clear()
        return True

    def escape(self) -> None:
        """Escape stubs out of the portals due (see the module's docstring)."""
        todo, self.due = self.due, []
        opt, p, G = self.opt, self.p, self.graph
        made, parents = [], set()
        if opt.cartesian_steps:
            made += self.cartesian(todo, parents)
        if not todo or opt.escape_tries <= 0:
            self._list(made, parents)
            return
        span = np.where(p.wraps, 2 * np.pi, np.maximum(p.upper - p.lower, 1e-9))
        steps = np.asarray(opt.escape_steps, float)
        for _ in range(opt.escape_rounds):
            items = []
            for v in todo:
                d = self.rng.normal(size=(opt.escape_tries, G.dim))
                d /= np.maximum(np.abs(d / span).max(1, keepdims=True), 1e-12)
                length = steps[self.rng.integers(len(steps), size=opt.escape_tries)]
                items.append((v, G.mode_of(v), p.wrap(G.Q[v] + d * length[:, None]), length))
            oks = p.motions_valid_many([(mode, np.broadcast_to(G.Q[v], Q1.shape), Q1)
                                        for v, mode, Q1, _ in items], opt.resolution, ends=True)
            todo = []
            for (v, mode, Q1, length), ok in zip(items, oks):
                free = np.nonzero(ok)[0]
                for i in free[np.argsort(-length[free], kind="stable")][:opt.escape_keep]:
                    w = G.add_vertex(Q1[i], mode, listed=False)
                    G.stubs.append((v, w, float(p.cost(Q1[i], G.Q[v]))))
                    G.edge_ok[edge_key(v, w)] = G.fine[edge_key(v, w)] = True
                    parents.add(v)
                    todo.append(w)
            made += todo
        self._list(made, parents)

    def _list(self, made: list[int], parents: set[int]) -> None:
        """The last stub of each chain among ``made`` joins its mode's nearest-neighbour
        vertices; all are counted."""
        G = self.graph
        for w in made:
            if w not in parents:
                mid = G.node_mode[w]
                G.mode_vertices[mid].append(w)
                G.stub_count[mid] = G.stub_count.get(mid, 0) + 1
        self.counts["escapes"] += len(made)

    def cartesian(self, todo: list[int], parents: set[int]) -> list[int]:
        """Retreat chains out of each portal in ``todo``
        (:func:`~tmpc.runtime.planners.retreat.retreat_chains`: the hand straight up, back,
        or both), kept as stubs; returns the new vertices."""
        p, G, opt = self.p, self.graph, self.opt
        if self._hands is None:
            self._hands = hand_frames(p)
        if not self._hands or not todo:
            return []
        chains = retreat_chains(p, [(G.mode_of(v), G.Q[v]) for v in todo], self._hands,
                                opt.cartesian_steps, opt.cartesian_step, opt.resolution)
        made = []
        for v, per in zip(todo, chains):
            mode = G.mode_of(v)
            for chain in per:
                last = v
                for q in chain:
                    w = G.add_vertex(q, mode, listed=False)
                    G.stubs.append((last, w, float(p.cost(q[None], G.Q[last])[0])))
                    G.edge_ok[edge_key(last, w)] = G.fine[edge_key(last, w)] = True
                    parents.add(last)
                    made.append(w)
                    last = w
        self.retreat_vertices.update(made)
        return made
