"""Pair tables: a sound "free" test for two robot link geometries whose relative pose depends on one or two coordinates.

On a grid of the coordinates a table stores a lower bound of the two geometries' distance (fcl's
GJK distance between their convex hulls, which contain them, minus :data:`GJK_MARGIN`); moving
the coordinates moves no point of one relative to the other by more than a rate times the move,
so the pair is free wherever the bound at the nearest grid point exceeds that bound on the
approach (docs/collision.md, "Pair tables"). The first pass
(:mod:`tmpc.runtime.collision.first_pass`) reads the tables before its compiled call.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from tmpc.runtime.collision.geometry import PassGeometry
from tmpc.runtime.collision.kernel import fall_back, pass_kernel
from tmpc.runtime.collision.spheres import SLACK


@dataclass
class PairTable:
    """A sound "free" test for two link geometries whose relative pose depends on one or two
    configuration coordinates (the PR2's two shoulder pan links: a candidate in every random
    state, their covers being ~12 cm apart).

    ``dist`` holds, on a grid of the coordinates, a lower bound of the distance between the two
    (fcl GJK distance between their convex hulls, which contain them, minus :data:`GJK_MARGIN`).
    Moving coordinate i by Δ moves no point of one geometry relative to the other by more than
    ``rate[i] * |Δ|`` (a revolute joint: |Δ| times the largest distance of the moved geometry
    from the joint origin; a prismatic joint: |Δ|), so the pair is free at x when
    ``dist[g] > sum_i rate[i] * |x_i - g_i|`` for the nearest grid point g.
    """

    ga: int
    gb: int
    cols: np.ndarray             # (k,) columns of q
    lo: np.ndarray
    step: np.ndarray
    n: np.ndarray
    wrap: np.ndarray
    rate: np.ndarray
    dist: np.ndarray             # (prod n,)

    def free(self, Q: np.ndarray) -> np.ndarray:
        """(B,) bool: the pair certainly does not touch in states Q (B, n)
        (:meth:`PairTables.free` of this table alone)."""
        return PairTables.of([self]).free(Q)[0]

    @staticmethod
    def build(world: PassGeometry, kinematics: Callable, ga: int,
              gb: int) -> "PairTable | None":
        """The table of a pair of robot link geometries, or None when their relative pose depends
        on no or more than two coordinates (or on a joint more than once, or on a prismatic
        joint below another moving joint). ``kinematics``: the world's batched forward
        kinematics (:meth:`tmpc.runtime.collision.CollisionWorld.kinematics`)."""
        import fcl

        model = world.model
        if not (world.is_link(ga) and world.is_link(gb)):
            return None
        sides = [_path_joints(model, world.bodies[world.geoms[g].body].name) for g in (ga, gb)]
        common = {j.name for j in sides[0]} & {j.name for j in sides[1]}
        qidx = {n: i for i, n in enumerate(model.q_names)}
        coords: dict[int, list] = {}
        for side, chain in enumerate(sides):
            for depth, j in enumerate(chain):
                if j.name in common or not j.movable:
                    continue
                src, mult = (j.mimic.joint, j.mimic.multiplier) if j.mimic else (j.name, 1.0)
                if src in qidx:
                    coords.setdefault(qidx[src], []).append((side, depth, j, abs(mult)))
        if not 1 <= len(coords) <= 2 or any(len(v) > 1 for v in coords.values()):
            return None
        cols = np.array(sorted(coords))
        entries = [coords[c][0] for c in cols]
        R, p = kinematics(model.default_q[None])
        Tg = _geom_world(world, R, p, 0, ga), _geom_world(world, R, p, 0, gb)
        Tj = {e[2].name: _frame_world(model, kinematics, model.default_q, e[2].child)
              for e in entries}
        rate = []
        for side, depth, j, mult in entries:
            if j.type == "prismatic":
                rate.append(mult)
                continue
            o = Tj[j.name][:3, 3]
            below = [e for e in entries if e[0] == side and e[1] < depth]
            if below and below[0][2].type == "prismatic":
                return None
            if below:
                ob = Tj[below[0][2].name][:3, 3]
                rho = np.linalg.norm(ob - o) + _reach(world.geoms[(ga, gb)[side]],
                                                      Tg[side], ob)
            else:
                rho = _reach(world.geoms[(ga, gb)[side]], Tg[side], o)
            rate.append(mult * rho)
        rate = np.array(rate) * (1 + SLACK)
        lo = np.where(model.wraps[cols], -np.pi, model.lower[cols])
        hi = np.where(model.wraps[cols], np.pi, model.upper[cols])
        n = np.maximum(2, np.ceil((hi - lo) * rate / (2 * TABLE_SLACK))).astype(np.int64)
        while np.prod(n) > TABLE_CELLS:
            n = np.maximum(2, (n * 0.9).astype(np.int64))
        wrap = model.wraps[cols]
        step = np.where(wrap, (hi - lo) / n, (hi - lo) / (n - 1))
        grid = np.stack(np.meshgrid(*[lo[i] + np.arange(n[i]) * step[i] for i in range(len(n))],
                                    indexing="ij"), -1).reshape(-1, len(n))
        Q = np.repeat(model.default_q[None], len(grid), 0)
        Q[:, cols] = grid
        R, p = kinematics(Q)
        objs = [world.geoms[g].narrow for g in (ga, gb)]
        dist = np.empty(len(grid))
        for i in range(len(grid)):
            for o, g in zip(objs, (ga, gb)):
                Tw = _geom_world(world, R, p, i, g)
                o.setTransform(fcl.Transform(Tw[:3, :3], Tw[:3, 3]))
            dist[i] = fcl.distance(objs[0], objs[1], fcl.DistanceRequest(), fcl.DistanceResult())
        return PairTable(ga, gb, cols, lo, step, n, wrap, rate, np.maximum(dist, 0.0) - GJK_MARGIN)


@dataclass
class PairTables:
    """Several :class:`PairTable` read at once: :meth:`free` is every table's
    :meth:`PairTable.free`, row by row, in one compiled call whatever their number (the
    PR2's first pass reads 18 tables per call, and a call of one state, OMPL's, spent more
    time in their loop than in the compiled pass, then in a dozen numpy calls). A
    one-coordinate table is padded to two with a coordinate of one cell and rate 0, so its
    index and bound are unchanged."""

    cols: np.ndarray             # (T, 2)
    lo: np.ndarray               # (T, 2)
    step: np.ndarray             # (T, 2)
    n: np.ndarray                # (T, 2)
    wrap: np.ndarray             # (T, 2)
    rate: np.ndarray             # (T, 2)
    start: np.ndarray            # (T,) where table t's cells begin in ``dist``
    dist: np.ndarray             # (sum of cells,)
    _args: tuple | None = field(default=None, repr=False, compare=False)

    @staticmethod
    def of(tables: list[PairTable]) -> "PairTables":
        def padded(t: PairTable, field: str, pad):
            v = np.asarray(getattr(t, field))
            return np.concatenate([v, np.full(2 - len(v), pad, v.dtype)])
        cells = np.array([t.dist.size for t in tables], np.int64)
        fields = {"cols": np.int64(0), "lo": 0.0, "step": 1.0, "n": np.int64(1), "wrap": False,
                  "rate": 0.0}
        stacked = {f: np.array([padded(t, f, pad) for t in tables],
                               np.asarray(pad).dtype).reshape(-1, 2)
                   for f, pad in fields.items()}
        return PairTables(**stacked, start=np.cumsum(cells) - cells,
                          dist=np.concatenate([t.dist for t in tables] + [np.zeros(0)]))

    def free(self, Q: np.ndarray) -> np.ndarray:
        """(T, B) bool: table t's pair certainly does not touch in state b of Q (B, n): one
        compiled call (:func:`~tmpc.runtime.collision.pass_kernel.table_free`; the same formula
        in numpy took a dozen array calls, most of a one-state check)."""
        Q = np.ascontiguousarray(np.asarray(Q, float).reshape(len(Q), -1))
        out = np.empty((len(self.start), len(Q)), bool)
        if not len(self.start) or not len(Q):
            return out
        if self._args is None:
            self._args = tuple(np.ascontiguousarray(a) for a in (
                self.cols, self.lo, self.step, self.n, self.wrap, self.rate, self.start,
                self.dist))
        try:
            pass_kernel("table_free")(Q, *self._args, out)
        except TypeError as exc:        # the built module refused (kernel.fall_back)
            fall_back(exc, "table_free")(Q, *self._args, out)
        return out


#: grid spacing aims at this much slack per coordinate (m); tables have at most TABLE_CELLS cells
TABLE_SLACK = 0.004
TABLE_CELLS = 4096
#: GJK's distance may exceed the true one by its tolerance: subtract this (m)
GJK_MARGIN = 1e-4


def _path_joints(model, link: str) -> list:
    """Joints from ``link`` up to the root (nearest first)."""
    parent = {j.child: j for j in model.tree.joints}
    out = []
    while link in parent:
        out.append(parent[link])
        link = parent[link].parent
    return out


def _frame_world(model, kinematics: Callable, q, link: str) -> np.ndarray:
    R, p = kinematics(np.asarray(q, float)[None])
    f = model.frame(link)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R[f, :, :, 0], p[f, :, 0]
    return T


def _geom_world(world: PassGeometry, R: np.ndarray, p: np.ndarray, i: int,
                g: int) -> np.ndarray:
    """World pose of link geometry g in state i of the batch-last kinematics R, p."""
    geom = world.geoms[g]
    f = world.bodies[geom.body].frame
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R[f, :, :, i], p[f, :, i]
    return T @ geom.T_body_geom


def _reach(geom, T: np.ndarray, o: np.ndarray) -> float:
    """Largest distance from point o of the geometry placed at T (world)."""
    if geom.mesh is not None:
        pts = geom.mesh.hull_vertices
    else:
        c, h = geom.aabb_center, geom.aabb_half
        pts = c + h * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    world_pts = pts @ T[:3, :3].T + T[:3, 3]
    return float(np.linalg.norm(world_pts - o, axis=1).max())
