"""The searches (AIT*-style): a reverse Dijkstra for the cost-to-go, then a forward lazy A*
whose edges are collision-checked only when the search needs them.

A reverse Dijkstra from the goal vertices over the graph with collisions ignored (edge
directions reversed; SciPy's csgraph) gives an admissible, consistent cost-to-go ``h``. The
forward search is A* on ``g + h`` that checks each edge for collision only when the entry that
uses it is popped (:func:`lazy_astar`): the first goal popped is the best path of the edges
that are valid. Edges are checked in batches at ``coarse`` times the resolution, a found path's
at the full resolution; a failed edge is blacklisted: it leaves the graph at the next rebuild,
and with it the reverse branch through it. The searches before a first solution are inflated
(``inflation``) and a search gives up after ``search_budget`` edge checks until the next batch.
"""

from __future__ import annotations

import heapq
import math
import time

import numpy as np

from tmpc.runtime.planners.optimal.escapes import Escapes
from tmpc.runtime.planners.optimal.graph import ModeGraph, PastDeadline, edge_key, load_graphs
from tmpc.runtime.planners.optimal.options import BestSolution, OptimalOptions
from tmpc.runtime.problem import PlanningProblem


class OutOfChecks(Exception):
    """A search spent its edge-check budget (``search_budget``) or passed its deadline."""


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
    raises :class:`OutOfChecks`."""
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
            raise OutOfChecks
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
            return gv, chain(closed, v), closed
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


def chain(parents: dict[int, int], v: int) -> list[int]:
    """The path from the search's root to v through the parents."""
    path = [v]
    while parents[path[-1]] >= 0:
        path.append(parents[path[-1]])
    return path[::-1]


class Searcher:
    """The searches over the graph and the edge checks they make. ``deadline``: the run's (a
    search stops checking edges after it); ``progress``: before a first solution, the path to
    the deepest vertex the last search closed (a partial result)."""

    def __init__(self, problem: PlanningProblem, options: OptimalOptions, graph: ModeGraph,
                 escapes: Escapes, best: BestSolution, counts: dict):
        self.p = problem
        self.opt = options
        self.graph = graph
        self.escapes = escapes
        self.best = best
        self.counts = counts
        self.deadline = math.inf
        self.progress: list[int] = [0]
        #: seconds per vertex of the last search's graph, heuristic and adjacency lists
        self._graph_seconds = 0.0
        self._search_t0 = 0.0
        self._checks_left = math.inf
        self._later = 0                  # searches since (and including) the first solution's
        self._graph_size = -1

    def fits(self, deadline: float) -> bool:
        """Is there time for a search before ``deadline``: its graph, heuristic and adjacency
        lists (which do not stop at the deadline) as long per vertex as the last one's?"""
        return time.perf_counter() + self._graph_seconds * len(self.graph.node_mode) < deadline

    def search(self) -> bool:
        """Reverse Dijkstra for h, then the forward lazy A*; True if the best cost improved.
        Nothing to do (False) without goals or when the graph did not grow."""
        G = self.graph
        if not G.goals or len(G.node_mode) == self._graph_size:
            return False
        t = self._search_t0 = time.perf_counter()
        self.counts["searches"] += 1
        try:
            g = G.search_graph(self.deadline)
        except PastDeadline:
            # the run's time is up before the graph was: no search (the first one's graph
            # has no measure to be foreseen by :meth:`fits`; a Hanoi run's first goal came
            # with 884,000 vertices)
            self.counts["searches_cut"] += 1
            self._graph_seconds = (time.perf_counter() - t) / len(G.node_mode)
            self.p.timers.search += time.perf_counter() - t
            return False
        _, dijkstra = load_graphs()
        h = dijkstra(g.T.tocsr(), directed=True, indices=sorted(G.goals), min_only=True)
        improved = self._forward(g, h)
        if self.best.path is not None:
            self._later += 1
        self._graph_size = len(G.node_mode)
        self.p.timers.search += time.perf_counter() - t
        return improved

    def _forward(self, g, h: np.ndarray) -> bool:
        """Lazy A* with edges checked at the coarse step; the edges of the path it finds are
        then checked at the full resolution (all at once) and, if one fails, it is blacklisted
        and the search goes on: every edge of a reported path is valid at the resolution."""
        G = self.graph
        depth = np.array([G.depth[m] for m in G.node_mode])
        self._checks_left = self.opt.search_budget or math.inf
        lists = adjacency(g, h)
        # what a search spends before it can stop at the deadline, per vertex
        self._graph_seconds = (time.perf_counter() - self._search_t0) / len(G.node_mode)
        while True:
            # weighted (ABIT*'s inflation): a path found with fewer edge checks, at most
            # ``weight`` times the graph's cheapest; after the first solution the weight goes
            # down to 1 (1 + (inflation - 1) deflation^k at the k-th later search), so the
            # anytime costs reach the optimum while each search still ends within its budget
            weight = 1.0 + (self.opt.inflation - 1.0) * self.opt.deflation ** self._later
            try:
                cost, path, closed = lazy_astar(lists, h, 0, G.goals, G.valid,
                                                self.best.cost, self.check_coarse, weight=weight,
                                                deadline=self.deadline)
            except OutOfChecks:
                self.counts["searches_cut"] += 1
                return False
            if path is None:
                if self.best.path is None and closed:
                    reached = np.fromiter(closed, np.int64, len(closed))
                    self.progress = chain(closed, int(reached[np.argmax(depth[reached])]))
                return False
            if self.confirm(path):
                break
        self.best.record_solution(cost, path)
        return True

    def confirm(self, path: list[int]) -> bool:
        """Check the edges of ``path`` at the full resolution, and at ``confirm_resolution``
        too if it is finer (those not confirmed yet, a batched call per mode and resolution);
        False if one fails (it is then invalid)."""
        G = self.graph
        todo: dict[int, list[tuple[int, int]]] = {}
        for u, v in zip(path, path[1:]):
            key = edge_key(u, v)
            if not G.is_bridge(u, v) and key not in G.fine:
                todo.setdefault(G.node_mode[u], []).append(key)
        good = True
        groups = [(mid, keys, np.array(keys).T) for mid, keys in todo.items()]
        items = [(G.modes[mid], G.Q[a], G.Q[b]) for mid, _, (a, b) in groups]
        oks = self.p.motions_valid_many(items, self.opt.resolution)
        if self.opt.confirm_resolution < self.opt.resolution:
            # the finer steps do not fall on the coarser ones: both, or a plan valid at 0.01
            # may graze at 0.05 (by 0.3 mm at most, in 3 of 27 Non-Monotonic and kitchen runs)
            oks = [a & b for a, b in zip(oks, self.p.motions_valid_many(
                items, self.opt.confirm_resolution))]
        for (_, keys, _), ok in zip(groups, oks):
            self.counts["edges_confirmed"] += len(keys)
            for key, fine in zip(keys, ok.tolist()):
                G.fine[key] = fine
                if not fine:
                    self.record_edge(key, False)
                    good = False
        return good

    def record_edge(self, key: tuple[int, int], ok: bool) -> None:
        """What a check found of the edge ``key``; an invalid one is blacklisted, and a
        waiting portal at either end becomes due for escape stubs."""
        self.graph.edge_ok[key] = ok
        if not ok:
            self.counts["edges_invalid"] += 1
            self.graph.invalid.add(key)
            self.escapes.edge_failed(key)

    def check_coarse(self, pairs) -> None:
        """Collision-check the unchecked edges among ``pairs`` (the popped one and those near
        the top of the search's queue), a batched call per mode, at ``coarse`` times the
        resolution: most edges that fail show it at a coarse step already (a state of the
        segment collides), and only the edges of a path found are checked at every step
        (:meth:`Searcher.confirm`). Raises :class:`OutOfChecks` once the budget or the run's time is
        spent."""
        G = self.graph
        todo: dict[int, dict[tuple[int, int], None]] = {}      # per mode, keys in order
        for u, v in pairs:
            if G.valid(u, v) is None:
                todo.setdefault(G.node_mode[u], {})[edge_key(u, v)] = None
        groups, spent = [], time.perf_counter() >= self.deadline     # the run's time is up
        for mid, keys in todo.items():
            if spent or self._checks_left <= 0:
                spent = True               # the modes before this one are still checked
                break
            self._checks_left -= len(keys)
            groups.append((mid, list(keys)))
        items = [(G.modes[mid], G.Q[a], G.Q[b])
                 for mid, keys in groups for a, b in [np.array(keys).T]]
        oks = self.p.motions_valid_many(items, self.opt.coarse * self.opt.resolution)
        for (_, keys), ok in zip(groups, oks):
            self.counts["edges_checked"] += len(keys)
            for key, good in zip(keys, ok.tolist()):
                self.record_edge(key, good)
        if spent:
            raise OutOfChecks
