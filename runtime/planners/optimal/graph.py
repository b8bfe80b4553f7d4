"""The multimodal graph: vertices ``(q, mode)``, the modes, the edges known valid or invalid, and
the sparse graph (CSR of costs) the searches run on.

Inside a mode, vertices are joined to their k nearest neighbours (k = ceil(rewire (e + e/d) log
n), PRM*'s), symmetrised; a transition is a zero-cost directed edge from its transition vertex
to its bridge vertex (same configuration, successor mode); escape stubs, shortcuts and each
mode's entry-exit pairs (``portals``) are edges both ways; blacklisted edges are removed. The
nearest-neighbour lists are kept per mode between searches and merged with the new vertices'
columns (:meth:`ModeGraph.neighbours`); the graph is built with sparse-matrix unions
(``maximum``: an edge two sets share has the same cost in both) rather than by sorting every
edge's key.
"""

from __future__ import annotations

import math
import time

import numpy as np

from tmpc.runtime.planners.optimal.options import OptimalOptions
from tmpc.runtime.problem import Mode, PlanningProblem

#: cost of a transition edge (same configuration): positive so sparse graphs keep it
BRIDGE_COST = 1e-12


#: a mode with more vertices than this gets its neighbour lists afresh from a k-d tree (where
#: the cost allows it: :meth:`ModeGraph._torus`)
TREE_SIZE = 2000


class PastDeadline(Exception):
    """The search graph was not finished by the run's deadline."""


def load_graphs():
    """scipy's ``csr_matrix`` and ``dijkstra``: imported on first use, which a run does on its
    warm-up thread beside the kernel loads
    (:meth:`tmpc.runtime.planners.optimal.planner.OptimalPlanner.warm_up_calls`) rather than in
    setup on the main thread."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra
    return csr_matrix, dijkstra


def edge_key(u: int, v: int) -> tuple[int, int]:
    """The undirected key of the edge u - v: (smaller, larger)."""
    return (u, v) if u < v else (v, u)


def same_poses(m: Mode, poses, held) -> bool:
    """Does mode ``m`` have these object poses and held objects (frames equal, poses to
    1e-3)?"""
    if set(m.held) != set(held) or set(m.poses) != set(poses):
        return False
    for name, (frame, T) in held.items():
        f2, T2 = m.held[name]
        if f2 != frame or not np.allclose(T, T2, atol=1e-3):
            return False
    return all(np.allclose(poses[name], m.poses[name], atol=1e-3) for name in poses)


def smallest_k(C: np.ndarray, k: int) -> np.ndarray:
    """Column indices of each row's ``k`` smallest entries, in order: what a stable argsort's
    first ``k`` columns are (ties by column), after a partial sort when the rows are long
    (a full sort of every row would dominate a large graph's construction)."""
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


class ModeGraph:
    """Vertices, modes and edges of the planner's graph.

    Vertex ``i`` is configuration ``Q[i]`` in mode ``modes[node_mode[i]]``; ``mode_vertices``
    lists a mode's vertices that get nearest-neighbour edges (stubs before the last of their
    chain, shortcut points and refined vertices are left out); ``bridge`` maps a transition
    vertex to ``(bridge vertex, action)``; ``goals`` are the goal vertices. ``edge_ok`` holds
    what is known of an edge (keys of :func:`edge_key`), ``fine`` what was checked at the full
    resolution, ``invalid`` the blacklisted edges; ``stubs`` and ``shortcuts`` are extra edges
    known valid, ``(u, v, cost)``."""

    def __init__(self, problem: PlanningProblem, options: OptimalOptions):
        self.p = problem
        self.opt = options
        self.dim = len(problem.lower)
        span = np.where(problem.wraps, 2 * np.pi, problem.upper - problem.lower)
        #: log of the space's measure over the unit ball's (PRM* radius)
        d = self.dim
        self.log_ratio = float(np.log(np.maximum(span, 1e-9)).sum()
                               - (d / 2 * math.log(math.pi) - math.lgamma(d / 2 + 1)))
        # vertices
        self.Q = np.zeros((1024, self.dim))
        self.node_mode: list[int] = []
        self.mode_vertices: dict[int, list[int]] = {}
        self.bridge: dict[int, tuple[int, object]] = {}     # transition vertex -> (bridge, action)
        self.stubs: list[tuple[int, int, float]] = []       # escape edges (valid) and costs
        self.shortcuts: list[tuple[int, int, float]] = []   # shortcut edges (valid) and costs
        self.stub_count: dict[int, int] = {}                # stub vertices per mode
        self.goals: set[int] = set()
        # modes
        self.modes: list[Mode] = []
        self.depth: dict[int, int] = {}
        self.reachable: list[int] = []
        # edges
        self.edge_ok: dict[tuple[int, int], bool] = {}
        self.invalid: set[tuple[int, int]] = set()          # blacklisted edges
        self.fine: dict[tuple[int, int], bool] = {}         # edges checked at the resolution
        self._nn: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    # ---- vertices and modes ----------------------------------------------------------------
    def add_vertex(self, q: np.ndarray, mode: Mode, listed: bool = True) -> int:
        """A new vertex; ``listed``: among its mode's vertices (nearest-neighbour edges)."""
        i = len(self.node_mode)
        if i == len(self.Q):
            self.Q = np.concatenate([self.Q, np.zeros_like(self.Q)])
        self.Q[i] = q
        self.node_mode.append(mode.id)
        if listed:
            self.mode_vertices[mode.id].append(i)
        return i

    def find_or_add_mode(self, sym: int, poses, held, parent: Mode, action) -> tuple[Mode, bool]:
        """The known mode with this symbolic state and pose set (1e-3), or a new one (True)."""
        for m in self.modes:
            if m.sym == sym and same_poses(m, poses, held):
                return m, False
        m = self.p.make_mode(len(self.modes), sym, poses, held, parent.id, action)
        self.add_mode(m, self.depth[parent.id] + 1)
        return m, True

    def add_mode(self, mode: Mode, depth: int) -> None:
        self.modes.append(mode)
        self.mode_vertices[mode.id] = []
        self.depth[mode.id] = depth
        self.reachable.append(mode.id)

    def is_goal_mode(self, mode: Mode) -> bool:
        return self.p.ground.goal.holds(mode.sym)

    def mode_of(self, v: int) -> Mode:
        """The mode of vertex ``v``."""
        return self.modes[self.node_mode[v]]

    def radius(self, n: int) -> float:
        """PRM*'s connection radius for n samples of a mode (tmit-star's transition test)."""
        n = max(n, 2)
        d = self.dim
        return float(self.opt.rewire * 2.0 * math.exp(
            (math.log1p(1.0 / d) + self.log_ratio + math.log(math.log(n) / n)) / d))

    # ---- edges and paths ---------------------------------------------------------------------
    def is_bridge(self, u: int, v: int) -> bool:
        """Is u -> v a transition edge (u's action taking it to v in the next mode)?"""
        return self.bridge.get(u, (None,))[0] == v

    def valid(self, u: int, v: int) -> bool | None:
        """Is the edge u -> v collision-free (None: not checked yet; transition edges always
        are)?"""
        if self.is_bridge(u, v):
            return True
        return self.edge_ok.get(edge_key(u, v))

    def path_cost(self, path: list[int]) -> float:
        """Composite length of a path of vertices (transition edges cost nothing)."""
        return float(sum(0.0 if self.is_bridge(u, v) else self.p.cost(self.Q[v], self.Q[u])
                         for u, v in zip(path, path[1:])))

    def segments(self, path: list[int]) -> list[list[int]]:
        """``path`` cut at its transitions (a change of mode, or a bridge): the mode segments."""
        segs, cut = [], 0
        for k in range(len(path) - 1):
            if self.node_mode[path[k]] != self.node_mode[path[k + 1]] \
                    or self.is_bridge(path[k], path[k + 1]):
                segs.append(path[cut:k + 1])
                cut = k + 1
        segs.append(path[cut:])
        return segs

    # ---- portals -----------------------------------------------------------------------------
    def portals(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
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

    def portal_configurations(self, mid: int):
        """(entry configurations, exit configurations) of a mode; a mode with no exit yet has
        its entries for both (its samples near them: the way out of a grasp), the start mode
        with none: None."""
        got = self.portals().get(mid)
        if got is not None:
            return self.Q[got[0]], self.Q[got[1]]
        entries = [b for b, _ in self.bridge.values() if self.node_mode[b] == mid]
        if not entries:
            return None
        at = self.Q[entries]
        return at, at

    # ---- the search graph --------------------------------------------------------------------
    def search_graph(self, deadline: float = math.inf):
        """The sparse graph (CSR of costs) of the current vertices: symmetrised k-nearest
        neighbours inside each mode, blacklisted edges removed, transition edges directed.
        :class:`PastDeadline` past ``deadline`` while the neighbour lists are made (the lists
        of the modes done by then are kept for the next search)."""
        n = len(self.node_mode)
        k = int(math.ceil(self.opt.rewire * (math.e + math.e / self.dim) * math.log(max(n, 2))))
        rows, cols, vals = [], [], []
        for mid, ids in self.mode_vertices.items():
            if len(ids) < 2:
                continue
            nn, nc = self.neighbours(mid, k, deadline)
            kk = min(k, len(ids) - 1)
            ids = np.asarray(ids)
            rows.append(np.repeat(ids, kk))
            cols.append(ids[nn[:, :kk].ravel()])
            vals.append(nc[:, :kk].ravel())

        csr_matrix = load_graphs()[0]

        def sparse(r, c, w):
            return csr_matrix((np.maximum(w, BRIDGE_COST), (r, c)), shape=(n, n))

        # one direction of the neighbour lists has no duplicate: union it with its transpose
        g = sparse(*(np.concatenate(x) if x else np.zeros(0, t)
                     for x, t in ((rows, np.int64), (cols, np.int64), (vals, float))))
        g = g.maximum(g.T)
        extra = []
        if self.stubs or self.shortcuts:
            a, b, w = (np.array(x) for x in zip(*self.stubs, *self.shortcuts))
            extra.append((a.astype(np.int64), b.astype(np.int64), w))
        if self.opt.portals:
            for a, b in self.portals().values():
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
        if self.invalid:
            g = g.tocoo()
            bad = np.array(sorted(self.invalid), np.int64)
            bad = np.sort(bad[:, 0] * (1 << 32) + bad[:, 1])
            key = np.minimum(g.row, g.col).astype(np.int64) * (1 << 32) + \
                np.maximum(g.row, g.col)
            at = np.minimum(np.searchsorted(bad, key), len(bad) - 1)
            keep = bad[at] != key
            g = csr_matrix((g.data[keep], (g.row[keep], g.col[keep])), shape=(n, n))
        return g.tocsr()

    def _torus(self) -> np.ndarray | None:
        """The periods of the coordinates (0: none) if the cost is Euclidean on them, a torus
        in the coordinates that wrap (a fixed base: :meth:`PlanningProblem.cost`); None if it is
        not (a mobile base's cost adds its planar distance and its turn to the joints')."""
        p = self.p
        if getattr(getattr(p, "model", None), "mobile_base", True):
            return None
        return np.where(p.wraps, p.upper - p.lower, 0.0)

    def _tree_neighbours(self, X: np.ndarray, keep: int,
                         box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every vertex's ``keep`` nearest others (positions in ``X``) and their costs, sorted,
        from a k-d tree (scipy's, periodic where coordinates wrap): a mode's lists made afresh
        in O(N log N) rather than the N x N costs (20,000 vertices: 0.9 s against 19 s). The
        costs are :meth:`PlanningProblem.cost`'s; ties fall as the tree returns them. ``box``:
        :meth:`_torus`."""
        from scipy.spatial import cKDTree
        Y = np.where(box > 0, np.mod(X - self.p.lower, np.where(box > 0, box, 1.0)), X)
        _, idx = cKDTree(Y, boxsize=box).query(Y, keep + 1)
        # a vertex is its own nearest, unless another stands on it: drop it wherever it is
        rows = np.arange(len(X))[:, None]
        cost = self.p.cost(X[idx], X[:, None])
        cost[idx == rows] = np.inf
        order = np.argsort(cost, axis=1, kind="stable")[:, :keep]
        return np.take_along_axis(idx, order, 1), np.take_along_axis(cost, order, 1)

    def neighbours(self, mid: int, k: int,
                   deadline: float = math.inf) -> tuple[np.ndarray, np.ndarray]:
        """The nearest neighbours of a mode's vertices (positions in the mode's list) and their
        costs, sorted, at least ``k`` per vertex (fewer when the mode has fewer): kept between
        searches and updated with the new vertices only (their costs to all, the old lists
        merged with the new columns); rebuilt when k outgrows the entries they hold exactly,
        or the merged lists could not hold the ``k + 4`` entries kept. Past ``deadline``
        (``time.perf_counter()``, read per block of rows) it raises :class:`PastDeadline`, the
        mode's lists as they were."""
        ids = self.mode_vertices[mid]
        X = self.Q[ids]
        keep = min(k + 4, len(ids) - 1)
        nn, nc, exact = self._nn.get(mid, (np.zeros((0, 0), np.int64), np.zeros((0, 0)), 0))
        old = len(nn)
        if old and (exact < min(k, len(ids) - 1) or nn.shape[1] + len(ids) - old < keep):
            # k grew past the lists' exact entries, or by more than the new vertices can fill
            # (k counts every mode's vertices): start over
            old = 0
        new = np.arange(old, len(ids))
        box = self._torus() if not old and len(ids) > TREE_SIZE else None
        if box is not None:
            nn, nc = self._tree_neighbours(X, keep, box)
        elif len(new):
            # row blocks of the new vertices' costs to all: each block's k smallest kept, and
            # (for the merge) the old vertices' costs to the new ones; never the whole N x N
            # matrix (8 N^2 bytes: a Hanoi 3 run whose first goal came with 884,000 vertices
            # peaked at 6.5 GB)
            top = np.empty((len(new), keep), np.int64)
            top_cost = np.empty((len(new), keep))
            back = np.empty((old, len(new)))
            step = max(1, int(2e6 // (len(ids) * self.dim)))   # bounds the (r, N, n) block
            for lo in range(0, len(new), step):
                if time.perf_counter() > deadline:
                    raise PastDeadline
                rows = new[lo:lo + step]
                C = self.p.cost(X[None], X[rows, None])
                C[np.arange(len(rows)), rows] = np.inf
                t = smallest_k(C, keep)
                top[lo:lo + len(rows)] = t
                top_cost[lo:lo + len(rows)] = np.take_along_axis(C, t, 1)
                back[:, lo:lo + len(rows)] = C[:, :old].T
            if old:
                cand = np.concatenate([nn, np.broadcast_to(new, (old, len(new)))], 1)
                cost = np.concatenate([nc, back], 1)
                order = smallest_k(cost, keep)
                nn = np.concatenate([np.take_along_axis(cand, order, 1), _pad(top, keep)])
                nc = np.concatenate([np.take_along_axis(cost, order, 1),
                                     _pad(top_cost, keep, np.inf)])
            else:
                nn, nc = top, top_cost
        if len(new):
            # how many leading entries of every list are exact: all of them while a list holds
            # every other vertex; once cut to ``keep``, the entries a merge appends past an old
            # list's cut may miss old vertices that were cut, so its count stays
            complete = keep >= len(ids) - 1
            exact = math.inf if complete else min(keep, exact if old else keep)
            self._nn[mid] = (nn, nc, exact)
        return nn, nc
