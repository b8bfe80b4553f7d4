"""The sound first pass of batched collision checks: the candidate geometry pairs of a batch of states.

Every geometry's bounding volumes (:mod:`tmpc.runtime.collision.spheres`) are placed once per
batch plan (the object placements and held objects of a mode: :class:`Plan`); then one compiled
call (:func:`tmpc.runtime.collision.pass_kernel.candidates`, loaded by
:mod:`tmpc.runtime.collision.kernel`) visits the states one by one and each pair through the
stages, stopping at the first that clears it: bounding balls and boxes, the pair tables
(:mod:`tmpc.runtime.collision.pair_table`), the covers, then the convex hulls (GJK with a
checked separating plane). A pair is dropped only when it cannot touch, so a state the pass
leaves no pair is free, and every remaining pair is decided by exact fcl
(:mod:`tmpc.runtime.collision.motion`). Soundness and the stages' sources: docs/collision.md,
"The first pass".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from tmpc.runtime.collision.geometry import PassGeometry, geom_frames
from tmpc.runtime.collision.kernel import fall_back, load_kernel, pass_kernel
from tmpc.runtime.collision.pair_table import GJK_MARGIN, PairTable, PairTables
from tmpc.runtime.collision.spheres import (
    K_MAX,
    NEVER,
    R_TARGET,
    ball,
    box,
    cover,
    hull_points,
    inflate,
    mesh_parts,
    ragged,
)
from tmpc.runtime.collision.store import TABLE_FIELDS, FirstPassStore, robot_key

if TYPE_CHECKING:
    from tmpc.runtime.collision.geometry import Placement

#: a mesh's hull vertex this much deeper than the tolerance inside a box primitive collides for
#: sure (m; :meth:`tmpc.runtime.collision.motion.BatchChecker.confirm`): fcl's EPA finds the
#: depth to ~1e-6
SURE_DEPTH = 1e-3
#: batch plans kept (least recently used out)
PLANS_KEPT = 256


@dataclass
class Plan:
    """Index arrays of one batch call (object placements and held objects fixed).

    ``mv``: the moving geometries (global ids; robot links and held objects), hanging on frames
    ``used[fpos]``; ``mm``: pairs of moving geometries (positions in ``mv``); ``bb_m``: per
    (moving, obstacle box) pair, the moving position, grouped by box (``bb_start``); ``ff``:
    pairs of geometries that do not move in the batch (global ids, checked once). The layout is
    :func:`~tmpc.runtime.collision.pass_kernel.candidates`'s.
    """

    used: np.ndarray
    mv: np.ndarray
    fpos: np.ndarray
    local: np.ndarray            # (M, 4, 4) T_frame_geom
    ball_c: np.ndarray           # (M, 3) in frame coordinates
    ball_r: np.ndarray           # (M,)
    obb_c: np.ndarray            # (M, 3) box (the local AABB) center, frame coordinates
    obb_R: np.ndarray            # (M, 3, 3) box axes in frame coordinates
    obb_h: np.ndarray            # (M, 3) half-extents
    cov: np.ndarray              # (M, K, 3) cover centers in frame coordinates
    cov_r: np.ndarray            # (M, K) their radii (the first ncov[m] of row m)
    ncov: np.ndarray             # (M,) balls in each cover
    mm: np.ndarray               # (P, 2)
    table_of: np.ndarray         # (P,) row of each mm pair in the tables' answers, or -1
    bb_m: np.ndarray             # (K,) moving position of each (moving, obstacle box) pair
    bb_start: np.ndarray         # (W + 1,) the pairs of box w: bb_m[bb_start[w]:bb_start[w + 1]]
    box_geom: np.ndarray         # (W,) global id of each obstacle
    box_R: np.ndarray            # (W, 3, 3) world rotation
    box_t: np.ndarray            # (W, 3) world center
    box_h: np.ndarray            # (W, 3) half-extents
    box_r: np.ndarray            # (W,) rounding radius
    box_half: np.ndarray         # (W, 3) half-extents of each obstacle's world AABB
    ff: np.ndarray               # (F, 2)
    tables: list[tuple[int, "PairTable"]]   # (index into mm, table)
    table_set: PairTables        # the same tables, read at once
    # the convex stage (hull_points), geometry i = the moving ones (frame coordinates), then
    # the obstacles (world): its hull points hull_p[hull_s[i]:hull_s[i + 1]], every point of it
    # all_p[all_s[i]:all_s[i + 1]] (none: the hull points), its radius hull_r[i]
    hull_p: np.ndarray           # (P, 3)
    hull_s: np.ndarray           # (M + W + 1,)
    all_p: np.ndarray            # (V, 3)
    all_s: np.ndarray            # (M + W + 1,)
    hull_r: np.ndarray           # (M + W,)
    # pairs sure to collide (BatchChecker.confirm): moving geometry m a mesh whose hull points
    # are its hull's vertices, obstacle w a box primitive of half-extents box_x[w] (else -1)
    sure_ok: np.ndarray          # (M,) bool
    box_x: np.ndarray            # (W, 3)
    #: an obstacle is more than one row (a hollow mesh's parts): a pair may come out twice
    split: bool = False


@dataclass
class Candidates:
    """Geometry pairs (global ids) the pass could not rule out, sorted by state; forward
    kinematics of the plan's frames, batch-last: R (U, 3, 3, B), p (U, 3, B)."""

    states: np.ndarray
    ga: np.ndarray
    gb: np.ndarray
    R: np.ndarray
    p: np.ndarray
    coarse: int                  # pairs left after the bounding-ball stage
    covers: int = 0              # pairs left after the covers (then the convex stage)
    sure: np.ndarray | None = None   # per pair: certain to collide (None: none is)

    def take(self, rows: np.ndarray) -> "Candidates":
        """These candidates, only (and in the order of) ``rows``."""
        return Candidates(self.states[rows], self.ga[rows], self.gb[rows], self.R, self.p,
                          self.coarse, self.covers,
                          None if self.sure is None else self.sure[rows])


class FirstPass:
    """Bounding volumes of a collision world's geometry and the batched candidate search.

    ``geometry``: what the pass reads of the world; ``kinematics``: the world's batched forward
    kinematics, ``Q (B, n) -> (R (F, 3, 3, B), p (F, 3, B))``
    (:meth:`tmpc.runtime.collision.CollisionWorld.kinematics`)."""

    def __init__(self, geometry: PassGeometry, kinematics: Callable, k_max: int = K_MAX,
                 r_target: float = R_TARGET):
        self.geometry = world = geometry
        self.kinematics = kinematics
        self.store = (FirstPassStore(robot_key(world.model, k_max, r_target, GJK_MARGIN))
                      if world.model is not None else None)
        self.covers = [cover(g.shape, g.mesh, k_max, r_target, self.store) for g in world.geoms]
        seen: dict[int, int] = {}
        #: a name of each geometry that is the same in every run: its body and its index there
        self._gname = []
        for g in world.geoms:
            k = seen[g.body] = seen.get(g.body, -1) + 1
            self._gname.append(f"{world.bodies[g.body].name}#{k}")
        self.balls = [ball(g.shape, g.mesh, self.store) for g in world.geoms]
        self.hulls = [hull_points(g.shape, g.mesh, self.store) for g in world.geoms]
        self.K = max([len(c[1]) for c in self.covers] + [1])
        self._plans: dict = {}
        self._tables: dict = {}
        self._table_sets: dict = {}
        self._link_parts: dict = {}
        self._parts: dict = {}

    def plan(self, place: "dict[int, Placement]", allowed: np.ndarray, key=None) -> Plan:
        """The plan of a batch (cached: motions reuse it). ``key``: the world's key of this
        state (:meth:`tmpc.runtime.collision.CollisionWorld.placed`), else one is made from the
        placements."""
        key = ("state", key) if key is not None else \
            (tuple((b, pl.frame, pl.T.tobytes(), pl.held) for b, pl in sorted(place.items())),
             allowed.tobytes())
        got = self._plans.pop(key, None)
        if got is None:
            # least recently used out: an optimal search's frontier spans ~100 modes, and a plan
            # rebuilt on every mode switch costs more than the ~40 KB it takes
            if len(self._plans) >= PLANS_KEPT:
                self._plans.pop(next(iter(self._plans)))
            got = self._plan(place, allowed)
            if self.store is not None:
                self.store.save()            # covers and tables built for it, for the next run
        self._plans[key] = got
        return got

    def _plan(self, place: "dict[int, Placement]", allowed: np.ndarray) -> Plan:
        w = self.geometry
        gframe, local = geom_frames(w, place)
        body = w.geom_body
        moving = gframe >= 0                                   # per dynamic position
        mv = w.dynamic[moving]
        # the frames the pass reads from the batched FK: those carrying robot geometry or held
        # objects (one kernel serves every set: the selection is numpy's)
        used = np.unique(gframe[moving]).astype(np.int64)
        mpos = np.full(len(w.geoms), -1, np.int64)
        mpos[mv] = np.arange(len(mv))
        world_T = {int(g): local[k] for k, g in enumerate(w.dynamic) if not moving[k]}
        for g in w.static:
            world_T[int(g)] = place[w.geoms[g].body].T @ w.geoms[g].T_body_geom
        pairs = np.concatenate([w.dd, w.ds]).reshape(-1, 2)
        pairs = pairs[~allowed[body[pairs[:, 0]], body[pairs[:, 1]]]]
        ma, mb = mpos[pairs[:, 0]] >= 0, mpos[pairs[:, 1]] >= 0
        mm = np.stack([mpos[pairs[ma & mb, 0]], mpos[pairs[ma & mb, 1]]], 1).reshape(-1, 2)
        one = pairs[ma ^ mb]
        one = np.where(ma[ma ^ mb][:, None], one, one[:, ::-1])   # moving geometry first
        # the obstacles: one each, a hollow mesh one per part (:func:`mesh_parts`), its pairs
        # once per part
        obstacles = np.unique(one[:, 1])
        parts = [self._obstacle_parts(int(g)) for g in obstacles]
        rows = np.array([1 if x is None else len(x[0]) for x in parts], np.int64)
        first = np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int64)
        box_geom = np.repeat(obstacles, rows)
        boxes, placed = [], []
        for g, x in zip(obstacles.tolist(), parts):
            T = world_T[g]
            if x is None:
                boxes.append(self._world_box(g, T))
                placed.append(self._placed_hull(g, T))
                continue
            c, h, pts, start, r = x
            R, t = T[:3, :3], T[:3, 3]
            for i in range(len(c)):
                boxes.append((R, R @ c[i] + t, h[i], 0.0))
                placed.append((pts[start[i]:start[i + 1]] @ R.T + t, np.zeros((0, 3)),
                               float(r[i])))
        at = np.searchsorted(obstacles, one[:, 1])
        per = rows[at]
        bb_w = (np.repeat(first[at], per) + np.arange(per.sum())
                - np.repeat(np.cumsum(per) - per, per)).astype(np.int64)
        bb_m = np.repeat(mpos[one[:, 0]], per).astype(np.int64)
        M = len(mv)
        lm = local[moving]
        cov_c, cov_r = np.zeros((M, self.K, 3)), np.full((M, self.K), NEVER)
        ball_c, ball_r = np.zeros((M, 3)), np.zeros(M)
        moving_parts = [self._moving_part(int(g), L) for g, L in zip(mv, lm)]
        for i, g in enumerate(mv):
            r = self.covers[g][1]
            cov_c[i, :len(r)] = moving_parts[i][0]
            cov_r[i, :len(r)] = r
            ball_c[i] = moving_parts[i][1]
            ball_r[i] = self.balls[g][1]
        arr = [np.array([b[j] for b in boxes]).reshape((-1,) + shp)
               for j, shp in enumerate(((3, 3), (3,), (3,), ()))]
        gm = [w.geoms[g] for g in mv]
        obb_c = np.array([part[2] for part in moving_parts])
        obb_h = np.array([inflate(g.aabb_half) for g in gm])
        tables, table_of, table_set = self._tables_of(mv[mm])
        order = np.argsort(bb_w, kind="stable")             # the pass visits pairs box by box
        bb_m, bb_w = bb_m[order], bb_w[order]
        bb_start = np.searchsorted(bb_w, np.arange(len(box_geom) + 1)).astype(np.int64)
        box_R, box_t, box_h, box_r = arr
        box_half = (np.abs(box_R) @ box_h[..., None])[..., 0] + box_r[:, None]
        ncov = np.array([len(self.covers[g][1]) for g in mv], np.int64)
        convex = [part[3] for part in moving_parts] + placed
        hull_p, hull_s = ragged([h[0] for h in convex])
        all_p, all_s = ragged([h[1] for h in convex])
        sure_ok = np.array([w.geoms[g].hull is not None and w.geoms[g].mesh is not None
                            and len(self.hulls[g][0]) > 0 for g in mv], bool)
        box_x = np.array([np.asarray(w.geoms[g].shape.size, float)
                          if w.geoms[g].shape.kind == "box" else np.full(3, -1.0)
                          for g in box_geom]).reshape(-1, 3)
        return Plan(used=used, mv=mv.astype(np.int64),
                    fpos=np.searchsorted(used, gframe[moving]), local=lm, ball_c=ball_c,
                    ball_r=ball_r, obb_c=obb_c.reshape(-1, 3),
                    obb_R=np.ascontiguousarray(lm[:, :3, :3]), obb_h=obb_h.reshape(-1, 3),
                    cov=cov_c, cov_r=cov_r, ncov=ncov, mm=mm.astype(np.int64),
                    table_of=table_of, bb_m=bb_m, bb_start=bb_start,
                    box_geom=box_geom.astype(np.int64), box_R=box_R, box_t=box_t, box_h=box_h,
                    box_r=box_r, box_half=box_half.reshape(-1, 3), ff=pairs[~ma & ~mb],
                    tables=tables, table_set=table_set,
                    hull_p=hull_p, hull_s=hull_s, all_p=all_p, all_s=all_s,
                    hull_r=np.array([h[2] for h in convex], float), sure_ok=sure_ok,
                    box_x=box_x, split=bool((rows > 1).any()))

    def _moving_part(self, g: int, L: np.ndarray) -> tuple:
        """Moving geometry g's cover centres, ball centre, box centre and placed hull
        (:meth:`_placed_hull`) in its frame's coordinates, ``L`` being T_frame_geom. A robot
        link's ``L`` never changes, so its part is computed once (a plan is made for every new
        placement of the objects, and Blocks World I spent 14% of its search making them)."""
        link = self.geometry.is_link(g)
        if link and g in self._link_parts:
            return self._link_parts[g]
        R, t = L[:3, :3], L[:3, 3]
        part = (self.covers[g][0] @ R.T + t, R @ self.balls[g][0] + t,
                R @ self.geometry.geoms[g].aabb_center + t, self._placed_hull(g, L))
        if link:
            self._link_parts[g] = part
        return part

    def _obstacle_parts(self, g: int):
        """Geometry g's parts as an obstacle (:func:`mesh_parts`: a hollow mesh's; None for
        a robot link and any other geometry), made once."""
        if g not in self._parts:
            geom = self.geometry.geoms[g]
            self._parts[g] = None if self.geometry.is_link(g) else \
                mesh_parts(geom.shape, geom.mesh, self.store)
        return self._parts[g]

    def _tables_of(self, pairs: np.ndarray) -> tuple:
        """The pair tables of the moving pairs ``pairs`` (P, 2) (global ids): ``(row in
        pairs, table)`` of those with one, each pair's row among them (-1: none), and them read
        at once (:class:`PairTables`). Cached by the pairs: they change only with what the
        robot holds."""
        key = pairs.tobytes()
        got = self._table_sets.get(key)
        if got is None:
            tables = [(k, t) for k, t in
                      ((k, self._table(int(a), int(b))) for k, (a, b) in enumerate(pairs))
                      if t is not None]
            table_of = np.full(len(pairs), -1, np.int64)
            table_of[[k for k, _ in tables]] = np.arange(len(tables))
            got = (tables, table_of, PairTables.of([t for _, t in tables]))
            if len(self._table_sets) >= PLANS_KEPT:
                self._table_sets.pop(next(iter(self._table_sets)))
            self._table_sets[key] = got
        return got

    def _placed_hull(self, g: int, T: np.ndarray):
        """Geometry g's :func:`hull_points` placed by T (its frame's or the world's)."""
        fast, every, r = self.hulls[g]
        R, t = T[:3, :3], T[:3, 3]
        return fast @ R.T + t, np.zeros((0, 3)) if every is None else every @ R.T + t, r

    def _table(self, ga: int, gb: int) -> "PairTable | None":
        """The pair table of two robot link geometries (None for held objects, whose placement
        changes from call to call, and for pairs with no table)."""
        if not (self.geometry.is_link(ga) and self.geometry.is_link(gb)):
            return None
        key = (min(ga, gb), max(ga, gb))
        if key not in self._tables:
            self._tables[key] = self._stored_table(*key)
        return self._tables[key]

    def _stored_table(self, ga: int, gb: int) -> "PairTable | None":
        if self.store is None:
            return PairTable.build(self.geometry, self.kinematics, ga, gb)
        name = f"table/{self._gname[ga]}|{self._gname[gb]}"
        got = self.store.get(name)
        if got is not None:
            return None if "none" in got else PairTable(ga, gb, *(got[f] for f in TABLE_FIELDS))
        table = PairTable.build(self.geometry, self.kinematics, ga, gb)
        self.store.put(name, {"none": np.zeros(0)} if table is None else
                       {f: getattr(table, f) for f in TABLE_FIELDS})
        return table

    def _world_box(self, g: int, T: np.ndarray):
        geom = self.geometry.geoms[g]
        c, h, r = box(geom.shape, geom.aabb_center, geom.aabb_half)
        return T[:3, :3], T[:3, :3] @ c + T[:3, 3], h, r

    @staticmethod
    def load_kernel() -> str | None:
        """:func:`tmpc.runtime.collision.kernel.load_kernel`: load the compiled pass; why it is
        numba's JIT (None: the module built ahead of time)."""
        return load_kernel()

    def candidates(self, Q: np.ndarray, plan: Plan, frames=None) -> Candidates:
        """The pass over states Q (B, n); ``frames``: their kinematics when known (batch-last,
        :meth:`tmpc.runtime.collision.CollisionWorld.check_batches`), else computed here. One compiled call
        (:func:`~tmpc.runtime.collision.pass_kernel.candidates`) after the pair tables."""
        kernel = pass_kernel()
        n = len(Q)
        R, p = self.kinematics(Q) if frames is None else frames
        R = np.ascontiguousarray(np.asarray(R)[plan.used][..., :n])
        p = np.ascontiguousarray(np.asarray(p)[plan.used][..., :n])
        free = np.ascontiguousarray(plan.table_set.free(Q))
        cap = max(64, 4 * n)
        M, K = plan.cov.shape[:2]
        scratch = (np.empty((M, 3)), np.empty((K, 3)), np.empty((K, 3)), np.empty((4, 3)),
                   np.empty(3), np.empty(K, np.int64), np.empty(K, np.int64),
                   np.empty(K, np.int64))
        while True:
            out = [np.empty(cap, np.int64) for _ in range(3)] + [np.empty(cap, bool)]
            args = (R, p, plan.fpos, plan.ball_c, plan.ball_r, plan.obb_c, plan.obb_R,
                    plan.obb_h, plan.cov, plan.cov_r, plan.ncov, plan.mm, plan.table_of, free,
                    plan.bb_start, plan.bb_m, plan.box_R, plan.box_t, plan.box_h, plan.box_r,
                    plan.box_half, plan.mv, plan.box_geom, plan.hull_p, plan.hull_s,
                    plan.all_p, plan.all_s, plan.hull_r, plan.sure_ok, plan.box_x,
                    self.geometry.tolerance + SURE_DEPTH, *out, *scratch)
            try:
                got, coarse, covers = kernel(*args)
            except TypeError as exc:
                # the module built ahead of time takes its one signature only: arguments of
                # another type or layout (none known; a test pins the pass's) go to the JIT
                kernel = fall_back(exc, "candidates")
                got, coarse, covers = kernel(*args)
            if got >= 0:
                break
            cap *= 4
        s, a, b, f = (o[:got] for o in out)
        if plan.split and got > 1:      # a pair two parts of a hollow mesh left: once
            G = len(self.geometry.geoms)
            _, keep = np.unique((s * G + a) * G + b, return_index=True)
            if len(keep) < got:
                keep.sort()
                s, a, b, f = s[keep], a[keep], b[keep], f[keep]
        return Candidates(s, a, b, R, p, coarse, covers, f)
