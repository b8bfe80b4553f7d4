"""Bounding spheres of collision geometry and the sound first pass of batched collision checks.

Every geometry gets (a) one bounding ball and (b) a cover of up to ``max_spheres`` balls whose
union contains it: a box or cylinder is cut into cells, each inside its circumscribed ball; a
mesh's triangles are clustered, each ball containing all three vertices of every triangle of its
cluster, hence (a ball is convex) the whole triangle. Obstacles that stay put during a batch
(static objects, movable objects not held) are oriented boxes with a rounding radius (a sphere is
a box of size 0 rounded by its radius) that contain them.

Soundness: if two geometries touch, some point lies in both, hence in a ball (or box) of each;
so a geometry pair whose bounding balls, or whose covers, are disjoint cannot collide, and fcl is
asked only about the remaining candidate pairs. A state is declared free only when every
candidate pair is confirmed free by fcl: the pass never turns a colliding state into a free one
(radii carry a relative and absolute slack of 1e-9 against rounding). tests/runtime/test_collision.py
checks this against exact fcl on thousands of random states.

A pair the covers leave then meets the convex stage (:func:`hull_points`): a geometry lies in
the convex hull of its points (a mesh's hull vertices, a box's corners, a prism around a
cylinder, a sphere's center grown by its radius), so two geometries whose hulls a plane
separates cannot touch.

The pass runs in two steps: the compiled kinematics of a whole batch, then one compiled call
(:mod:`~tmpc.runtime.collision.pass_kernel`, numba) runs the tests of every pair state by state:
bounding balls and boxes (``coarse``), the covers of the pairs that survive, then their hulls.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from tmpc.compiler import aot
from tmpc.compiler.aot import Kernel
from tmpc.lang.world import Shape
from tmpc.runtime.collision.store import TABLE_FIELDS, FirstPassStore, mesh_key, robot_key

if TYPE_CHECKING:
    from tmpc.runtime.collision.geometry import MeshData
    from tmpc.runtime.collision.world import CollisionWorld, Placement

SLACK = 1e-9
#: radius of padding balls (never overlap anything)
_NEVER = -1e30


def _inflate(r):
    return np.asarray(r) * (1 + SLACK) + SLACK


def bounding_ball(points: np.ndarray, iters: int = 64) -> tuple[np.ndarray, float]:
    """A ball containing ``points`` (N, 3): Badoiu-Clarkson steps from the box center, then
    the radius that covers every point (so the ball contains them whatever the center)."""
    pts = np.asarray(points, float)
    c = (pts.min(0) + pts.max(0)) / 2
    for i in range(iters):
        far = pts[np.argmax(((pts - c) ** 2).sum(1))]
        c = c + (far - c) / (i + 2)
    r = float(np.sqrt(((pts - c) ** 2).sum(1).max()))
    best_c = (pts.min(0) + pts.max(0)) / 2
    best_r = float(np.sqrt(((pts - best_c) ** 2).sum(1).max()))
    return (c, r) if r < best_r else (best_c, best_r)


def _grid(h: np.ndarray, k: int) -> tuple[int, int, int]:
    """Cells per axis (product <= k) that make cells of a box with half-extents h most cubic."""
    n = [1, 1, 1]
    while True:
        i = int(np.argmax(np.asarray(h) / n))
        if np.prod(n) // n[i] * (n[i] + 1) > k:
            return tuple(n)
        n[i] += 1


def _box_cells(h: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    n = _grid(h, k)
    axes = [(-h[i] + (2 * np.arange(n[i]) + 1) * h[i] / n[i]) for i in range(3)]
    C = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return C, np.full(len(C), float(np.linalg.norm(h / np.asarray(n))))


def _mesh_cover(V: np.ndarray, F: np.ndarray, k: int, iters: int = 10):
    """Cluster triangles into k groups (farthest-point seeds, then Lloyd steps that assign a
    triangle to the center nearest its farthest vertex and move centers to the middle of their
    vertices' box); one ball per group containing every vertex of its triangles."""
    tri = V[F]                                        # (T, 3, 3)
    cent = tri.mean(1)
    k = max(1, min(k, len(F)))
    seeds = [int(np.argmax(((cent - cent.mean(0)) ** 2).sum(1)))]
    d = ((cent - cent[seeds[0]]) ** 2).sum(1)
    while len(seeds) < k:
        seeds.append(int(np.argmax(d)))
        d = np.minimum(d, ((cent - cent[seeds[-1]]) ** 2).sum(1))
    C = cent[seeds]
    flat = tri.reshape(-1, 3)
    for _ in range(iters + 1):
        cost = ((tri[:, None] - C[None, :, None]) ** 2).sum(-1).max(-1)      # (T, k)
        lab = cost.argmin(1)
        lo, hi = np.full((k, 3), np.inf), np.full((k, 3), -np.inf)
        np.minimum.at(lo, np.repeat(lab, 3), flat)
        np.maximum.at(hi, np.repeat(lab, 3), flat)
        with np.errstate(invalid="ignore"):      # empty clusters (inf + -inf) keep their centre
            C = np.where(np.isfinite(lo), (lo + hi) / 2, C)
    cost = ((tri[:, None] - C[None, :, None]) ** 2).sum(-1).max(-1)
    lab = cost.argmin(1)
    r2 = np.full(k, -1.0)
    np.maximum.at(r2, lab, cost[np.arange(len(lab)), lab])
    keep = r2 >= 0
    return C[keep], np.sqrt(r2[keep])


#: target ball radius of covers (m) and the most balls per geometry
R_TARGET = 0.05
K_MAX = 16
_MESH_COVERS: dict = {}


def cover(shape: Shape, mesh: "MeshData | None", k_max: int = K_MAX,
          r_target: float = R_TARGET, store=None) -> tuple[np.ndarray, np.ndarray]:
    """Balls (centers (m, 3), radii (m,)) in the geometry frame whose union contains it (for a
    mesh: its surface, which is all fcl's BVH test sees). ``store``: a
    :class:`~tmpc.runtime.collision.store.FirstPassStore` keeping mesh covers between runs."""
    if shape.kind == "sphere":
        C, r = np.zeros((1, 3)), np.array([float(shape.radius)])
    elif shape.kind == "box":
        h = np.asarray(shape.size, float)
        C, r = _box_cells(h, int(np.clip(np.prod(np.ceil(h / r_target)), 1, k_max)))
    elif shape.kind == "cylinder":
        m = int(np.clip(np.ceil(shape.length / (2 * shape.radius)), 1, k_max))
        z = -shape.length / 2 + (2 * np.arange(m) + 1) * shape.length / (2 * m)
        C = np.stack([np.zeros(m), np.zeros(m), z], 1)
        r = np.full(m, float(np.hypot(shape.radius, shape.length / (2 * m))))
    else:
        key = (id(mesh), k_max, r_target)
        if key not in _MESH_COVERS:
            _MESH_COVERS[key] = (mesh, _stored_cover(mesh, k_max, r_target, store))
        C, r = _MESH_COVERS[key][1]
    return C, _inflate(r)


def _stored_cover(mesh: "MeshData", k_max: int, r_target: float, store):
    if store is None:
        return _cover_mesh(mesh, k_max, r_target)
    name = "cover/" + mesh_key(mesh.vertices, mesh.faces, k_max, r_target)
    got = store.get(name)
    if got is None:
        C, r = _cover_mesh(mesh, k_max, r_target)
        store.put(name, {"C": C, "r": r})
        return C, r
    return got["C"], got["r"]


def _cover_mesh(mesh: "MeshData", k_max: int, r_target: float):
    import trimesh
    V, F = mesh.vertices, mesh.faces
    tri = V[F]
    area = float(np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
                 .sum() / 2)
    k = int(np.clip(np.ceil(area / (np.pi * r_target ** 2)), 1, k_max))
    edge = max(np.sqrt(area / (np.pi * k)) / 2, 1e-3)
    while True:    # small triangles let the clusters (and balls) be tight
        V2, F2 = trimesh.remesh.subdivide_to_size(V, F, max_edge=edge, max_iter=6)
        if len(F2) <= 20000:
            break
        edge *= 1.5
    return _mesh_cover(np.asarray(V2, float), np.asarray(F2), k)


def ball(shape: Shape, mesh: "MeshData | None", store=None) -> tuple[np.ndarray, float]:
    """One ball containing the geometry (its frame). ``store``: a
    :class:`~tmpc.runtime.collision.store.FirstPassStore` keeping mesh balls between runs (64
    passes over a PR2 link's vertices cost ~10 ms a mesh)."""
    if shape.kind == "sphere":
        c, r = np.zeros(3), float(shape.radius)
    elif shape.kind == "box":
        c, r = np.zeros(3), float(np.linalg.norm(shape.size))
    elif shape.kind == "cylinder":
        c, r = np.zeros(3), float(np.hypot(shape.radius, shape.length / 2))
    elif store is None:
        c, r = bounding_ball(mesh.vertices)
    else:
        name = "ball/" + mesh_key(mesh.vertices, mesh.faces)
        got = store.get(name)
        if got is None:
            c, r = bounding_ball(mesh.vertices)
            store.put(name, {"c": c, "r": np.array(r)})
        else:
            c, r = got["c"], float(got["r"])
    return c, float(_inflate(r))


def box(shape: Shape, aabb_center, aabb_half) -> tuple[np.ndarray, np.ndarray, float]:
    """(center, half-extents, rounding radius) of a rounded box containing the geometry."""
    if shape.kind == "sphere":
        return np.zeros(3), np.zeros(3), float(_inflate(shape.radius))
    return np.asarray(aabb_center, float), _inflate(aabb_half), 0.0


#: a mesh's hull vertex this much deeper than the tolerance inside a box primitive collides for
#: sure (m; :meth:`~tmpc.runtime.collision.world.CollisionWorld._confirm`): fcl's EPA finds the
#: depth to ~1e-6
SURE_DEPTH = 1e-3
#: a mesh whose convex hull has more vertices than this gets no convex stage (its support
#: function, a pass over the vertices, would cost more than the fcl query it saves)
HULL_POINTS_MAX = 512
#: sides of the prism around a cylinder (the convex stage)
_PRISM_SIDES = 12


def hull_points(shape: Shape, mesh: MeshData | None,
                store=None) -> tuple[np.ndarray, np.ndarray, float]:
    """The convex stage's view of a geometry (its frame): ``(points, every, r)``. The geometry
    lies in the hull of ``every`` (None: of ``points``) grown by radius r, and GJK runs on the
    hull of ``points`` grown by r, that same set; a separation it finds is checked on
    ``every``. A box: its corners; a sphere: its center and radius; a cylinder: a prism around
    it; a mesh: its convex hull's vertices, ``every`` None when no mesh vertex lies more than
    :data:`HULL_TRUST` outside a facet plane of the hull (:func:`_hull_outside`; r is then that
    distance), else every vertex of the mesh. No points: no convex stage. ``store``: a
    :class:`~tmpc.runtime.collision.store.FirstPassStore` keeping the mesh check between runs."""
    if shape.kind == "sphere":
        pts, r = np.zeros((1, 3)), float(_inflate(shape.radius))
    elif shape.kind == "box":
        h = _inflate(np.asarray(shape.size, float))
        pts, r = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h, 0.0
    elif shape.kind == "cylinder":
        a = 2 * np.pi * np.arange(_PRISM_SIDES) / _PRISM_SIDES
        rho = float(_inflate(shape.radius)) / np.cos(np.pi / _PRISM_SIDES)
        ring = np.stack([rho * np.cos(a), rho * np.sin(a)], 1)
        z = float(_inflate(shape.length / 2))
        pts = np.concatenate([np.c_[ring, np.full(len(a), -z)], np.c_[ring, np.full(len(a), z)]])
        r = 0.0
    elif mesh is None or len(mesh.hull_vertices) > HULL_POINTS_MAX:
        return np.zeros((0, 3)), None, 0.0
    else:
        H = np.asarray(mesh.hull_vertices, float)
        out = _stored_outside(mesh, store)
        if out <= HULL_TRUST:
            return H, None, float(_inflate(max(out, 0.0)))
        return H, np.asarray(mesh.vertices, float), 0.0
    return pts, None, r


#: a mesh's hull is trusted to hold its vertices when none is farther than this (m) outside a
#: facet plane (qhull's hulls: ~1e-16). A point within t of every facet plane is within t of
#: the hull except near a vertex where facets meet at a needle angle (t / sin(half that
#: angle)): reaching the stage's 1e-6 m gap from 1e-12 takes an angle under 1e-4 degrees.
HULL_TRUST = 1e-12


def _hull_outside(mesh: MeshData) -> float:
    """How far the mesh's farthest vertex lies outside a facet plane of its convex hull (<= 0:
    inside every one)."""
    H, HF, V = mesh.hull_vertices, mesh.hull_faces, np.asarray(mesh.vertices, float)
    a, b, c = H[HF[:, 0]], H[HF[:, 1]], H[HF[:, 2]]
    n = np.cross(b - a, c - a)
    size = np.linalg.norm(n, axis=1)
    keep = size > 0
    n = n[keep] / size[keep, None]
    o = (n * a[keep]).sum(1)
    flip = n @ H.mean(0) > o                       # outward: the centroid is inside
    n[flip], o[flip] = -n[flip], -o[flip]
    worst = -np.inf
    for i in range(0, len(V), 1024):
        worst = max(worst, float((V[i:i + 1024] @ n.T - o).max(initial=-np.inf)))
    return worst


def _stored_outside(mesh: MeshData, store) -> float:
    if store is None:
        return _hull_outside(mesh)
    name = "outside/" + mesh_key(mesh.vertices, mesh.faces)
    got = store.get(name)
    if got is None:
        out = _hull_outside(mesh)
        store.put(name, {"d": np.array(out)})
        return out
    return float(got["d"])


def _ragged(parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Point sets as one (P, 3) array and their starts (len(parts) + 1,)."""
    start = np.zeros(len(parts) + 1, np.int64)
    start[1:] = np.cumsum([len(x) for x in parts])
    flat = np.concatenate(parts) if parts else np.zeros((0, 3))
    return np.ascontiguousarray(flat.reshape(-1, 3), dtype=float), start


# ---------------------------------------------------------------------------------------------
# the pass


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
    # the convex stage (hull_points), geometry i = the moving ones (frame coordinates), then
    # the obstacles (world): its hull points hull_p[hull_s[i]:hull_s[i + 1]], every point of it
    # all_p[all_s[i]:all_s[i + 1]] (none: the hull points), its radius hull_r[i]
    hull_p: np.ndarray           # (P, 3)
    hull_s: np.ndarray           # (M + W + 1,)
    all_p: np.ndarray            # (V, 3)
    all_s: np.ndarray            # (M + W + 1,)
    hull_r: np.ndarray           # (M + W,)
    # pairs sure to collide (CollisionWorld._confirm): moving geometry m a mesh whose hull points
    # are its hull's vertices, obstacle w a box primitive of half-extents box_x[w] (else -1)
    sure_ok: np.ndarray          # (M,) bool
    box_x: np.ndarray            # (W, 3)


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
    """Sphere covers of a :class:`CollisionWorld`'s geometry and the batched candidate search."""

    def __init__(self, world: "CollisionWorld", k_max: int = K_MAX, r_target: float = R_TARGET):
        self.world = world
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

    def plan(self, place: "dict[int, Placement]", allowed: np.ndarray, key=None) -> Plan:
        """The plan of a batch (cached: motions reuse it). ``key``: the world's key of this
        state (:meth:`CollisionWorld._placed`), else one is made from the placements."""
        key = ("state", key) if key is not None else \
            (tuple((b, pl.frame, pl.T.tobytes(), pl.held) for b, pl in sorted(place.items())),
             allowed.tobytes())
        got = self._plans.pop(key, None)
        if got is None:
            # least recently used out: an optimal search's frontier spans ~100 modes (clutter-14
            # with the red sticks built 1,802 plans for 181 modes with 16 kept); ~40 KB each
            if len(self._plans) >= PLANS_KEPT:
                self._plans.pop(next(iter(self._plans)))
            got = self._plan(place, allowed)
            if self.store is not None:
                self.store.save()            # covers and tables built for it, for the next run
        self._plans[key] = got
        return got

    def _plan(self, place: "dict[int, Placement]", allowed: np.ndarray) -> Plan:
        w = self.world
        gframe, local = w.geom_frames(place)
        body = w._geom_body
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
        box_geom = np.unique(one[:, 1])
        boxes = [self._world_box(int(g), world_T[int(g)]) for g in box_geom]
        bb_w = np.searchsorted(box_geom, one[:, 1]).astype(np.int64)
        bb_m = mpos[one[:, 0]].astype(np.int64)
        M = len(mv)
        lm = local[moving]
        cov_c, cov_r = np.zeros((M, self.K, 3)), np.full((M, self.K), _NEVER)
        ball_c, ball_r = np.zeros((M, 3)), np.zeros(M)
        for i, g in enumerate(mv):
            C, r = self.covers[g]
            cov_c[i, :len(r)] = C @ lm[i, :3, :3].T + lm[i, :3, 3]
            cov_r[i, :len(r)] = r
            ball_c[i] = lm[i, :3, :3] @ self.balls[g][0] + lm[i, :3, 3]
            ball_r[i] = self.balls[g][1]
        arr = [np.array([b[j] for b in boxes]).reshape((-1,) + shp)
               for j, shp in enumerate(((3, 3), (3,), (3,), ()))]
        gm = [w.geoms[g] for g in mv]
        obb_c = np.array([L[:3, :3] @ g.aabb_center + L[:3, 3] for L, g in zip(lm, gm)])
        obb_h = np.array([_inflate(g.aabb_half) for g in gm])
        tables = [(k, t) for k, t in
                  ((k, self._table(int(mv[a]), int(mv[b]))) for k, (a, b) in enumerate(mm))
                  if t is not None]
        table_of = np.full(len(mm), -1, np.int64)
        table_of[[k for k, _ in tables]] = np.arange(len(tables))
        order = np.argsort(bb_w, kind="stable")             # the pass visits pairs box by box
        bb_m, bb_w = bb_m[order], bb_w[order]
        bb_start = np.searchsorted(bb_w, np.arange(len(box_geom) + 1)).astype(np.int64)
        box_R, box_t, box_h, box_r = arr
        box_half = (np.abs(box_R) @ box_h[..., None])[..., 0] + box_r[:, None]
        ncov = np.array([len(self.covers[g][1]) for g in mv], np.int64)
        convex = [self._placed_hull(int(g), L) for g, L in zip(mv, lm)] + \
            [self._placed_hull(int(g), world_T[int(g)]) for g in box_geom]
        hull_p, hull_s = _ragged([h[0] for h in convex])
        all_p, all_s = _ragged([h[1] for h in convex])
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
                    tables=tables, hull_p=hull_p, hull_s=hull_s, all_p=all_p, all_s=all_s,
                    hull_r=np.array([h[2] for h in convex], float), sure_ok=sure_ok,
                    box_x=box_x)

    def _placed_hull(self, g: int, T: np.ndarray):
        """Geometry g's :func:`hull_points` placed by T (its frame's or the world's)."""
        fast, every, r = self.hulls[g]
        R, t = T[:3, :3], T[:3, 3]
        return fast @ R.T + t, np.zeros((0, 3)) if every is None else every @ R.T + t, r

    def _table(self, ga: int, gb: int) -> "PairTable | None":
        """The pair table of two robot link geometries (None for held objects, whose placement
        changes from call to call, and for pairs with no table)."""
        if any(self.world.bodies[self.world.geoms[g].body].kind != "link" for g in (ga, gb)):
            return None
        key = (min(ga, gb), max(ga, gb))
        if key not in self._tables:
            self._tables[key] = self._stored_table(*key)
        return self._tables[key]

    def _stored_table(self, ga: int, gb: int) -> "PairTable | None":
        if self.store is None:
            return PairTable.build(self.world, ga, gb)
        name = f"table/{self._gname[ga]}|{self._gname[gb]}"
        got = self.store.get(name)
        if got is not None:
            return None if "none" in got else PairTable(ga, gb, *(got[f] for f in TABLE_FIELDS))
        table = PairTable.build(self.world, ga, gb)
        self.store.put(name, {"none": np.zeros(0)} if table is None else
                       {f: getattr(table, f) for f in TABLE_FIELDS})
        return table

    def _world_box(self, g: int, T: np.ndarray):
        geom = self.world.geoms[g]
        c, h, r = box(geom.shape, geom.aabb_center, geom.aabb_half)
        return T[:3, :3], T[:3, :3] @ c + T[:3, 3], h, r

    @staticmethod
    def load_kernel() -> str | None:
        """Load the compiled pass (:func:`pass_kernel`) and make one call on a batch of one
        state and no pair; returns why it is numba's JIT, not the ahead-of-time module (None
        when it is that module)."""
        pass_kernel()(*empty_pass_args())
        return _KERNEL_STATE["why"]

    def candidates(self, Q: np.ndarray, plan: Plan, frames=None) -> Candidates:
        """The pass over states Q (B, n); ``frames``: their kinematics when known (batch-last,
        :meth:`CollisionWorld.check_batches`), else computed here. One compiled call
        (:func:`~tmpc.runtime.collision.pass_kernel.candidates`) after the pair tables."""
        kernel = pass_kernel()
        n = len(Q)
        R, p = self.world.kinematics(Q) if frames is None else frames
        R = np.ascontiguousarray(np.asarray(R)[plan.used][..., :n])
        p = np.ascontiguousarray(np.asarray(p)[plan.used][..., :n])
        free = np.zeros((len(plan.tables), n), bool)
        for row, (_, table) in enumerate(plan.tables):
            free[row] = table.free(Q)
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
                    self.world.tolerance + SURE_DEPTH, *out, *scratch)
            try:
                got, coarse, covers = kernel(*args)
            except TypeError as exc:
                # the module built ahead of time takes its one signature only: arguments of
                # another type or layout (none known; a test pins the pass's) go to the JIT
                kernel = _fall_back(exc, "candidates")
                got, coarse, covers = kernel(*args)
            if got >= 0:
                break
            cap *= 4
        s, a, b, f = (o[:got] for o in out)
        return Candidates(s, a, b, R, p, coarse, covers, f)


#: the collision checker's compiled loops built ahead of time, in one module:
#: :func:`~tmpc.runtime.collision.pass_kernel.candidates` and
#: :func:`~tmpc.runtime.collision.pass_kernel.kinematics` (their argument types: what
#: :meth:`FirstPass.candidates` and :class:`~tmpc.runtime.collision.kinematics.Kinematics`
#: pass; a test checks them against numba's typeof)
PASS_KERNEL = Kernel("tmpc.runtime.collision.pass_kernel", (
    ("candidates",
     ("UniTuple(i8, 3)(f8[:,:,:,::1], f8[:,:,::1], i8[::1], f8[:,::1], f8[::1], f8[:,::1], "
      "f8[:,:,::1], f8[:,::1], f8[:,:,::1], f8[:,::1], i8[::1], i8[:,::1], i8[::1], b1[:,::1], "
      "i8[::1], i8[::1], f8[:,:,::1], f8[:,::1], f8[:,::1], f8[::1], f8[:,::1], i8[::1], "
      "i8[::1], f8[:,::1], i8[::1], f8[:,::1], i8[::1], f8[::1], b1[::1], f8[:,::1], f8, "
      "i8[::1], i8[::1], i8[::1], b1[::1], f8[:,::1], f8[:,::1], f8[:,::1], f8[:,::1], f8[::1], "
      "i8[::1], i8[::1], i8[::1])")),
    ("kinematics",
     ("void(f8[:,::1], i8[::1], i8[::1], f8[:,:,::1], f8[:,::1], i8[::1], f8[:,::1], i8[::1], "
      "f8[::1], f8[::1], i8, b1, f8[:,::1], f8[::1], f8[:,::1], f8, i8[::1], f8[:,:,:,::1], "
      "f8[:,:,::1])"))), nrt=False)
#: the kernels in use ("candidates", "kinematics": functions of the built module or of numba's
#: JIT) and why the JIT (None: the built module)
_KERNEL_STATE: dict = {"candidates": None, "kinematics": None, "why": None}


def empty_pass_args() -> tuple:
    """Arguments of :func:`~tmpc.runtime.collision.pass_kernel.candidates` for one state with no
    geometry pair (a call that loads the kernel and finds nothing)."""
    f, i = np.zeros((1, 3)), np.zeros(1, np.int64)
    e3, e = np.zeros((0, 3)), np.zeros(0, np.int64)
    return (np.zeros((1, 3, 3, 1)), np.zeros((1, 3, 1)), i, f, np.zeros(1), f,
            np.zeros((1, 3, 3)), f, np.zeros((1, 1, 3)), np.zeros((1, 1)), i,
            np.zeros((0, 2), np.int64), e, np.zeros((0, 1), bool), i, e, np.zeros((0, 3, 3)),
            e3, e3, np.zeros(0), e3, i, e, e3, i, e3, i, np.zeros(0), np.zeros(1, bool), e3,
            0.0, i.copy(), i.copy(), i.copy(), np.zeros(1, bool), f.copy(), f.copy(),
            f.copy(), np.zeros((4, 3)), np.zeros(3), i.copy(), i.copy(), i.copy())


def prepare_kernel() -> None:
    """Start building the pass ahead of time if this machine has not yet (a run calls this
    early: the build overlaps its other setup)."""
    aot.prepare(PASS_KERNEL)


def _fall_back(exc: TypeError, name: str = "candidates"):
    """numba's JIT of the pass from now on (an argument the built module does not take);
    returns the JIT's function ``name``."""
    if _KERNEL_STATE["why"] is not None:       # the JIT already: its refusal is a real error
        raise exc
    _use_jit(f"a refused call: {exc}",
             f"the module built ahead of time refused a call ({exc}); using numba's JIT "
             "from now on (please report this)")
    return _KERNEL_STATE[name]


def pass_kernel(name: str = "candidates"):
    """The compiled function ``name`` (``candidates``: the candidate search; ``kinematics``):
    the module built ahead of time (:mod:`tmpc.compiler.aot`: no numba in the process), else
    numba's JIT of the same source (the reason is kept in ``_KERNEL_STATE["why"]`` and said
    once on stderr when the build has just failed)."""
    if _KERNEL_STATE[name] is None:
        module, why = aot.obtain(PASS_KERNEL)
        if module is not None:
            _KERNEL_STATE.update(candidates=module.candidates, kinematics=module.kinematics)
        else:
            say = why.startswith("the ahead-of-time build failed:") or "rebuilt" in why
            _use_jit(why, f"{why}; using numba's JIT instead (about 0.5 s more setup and 140 MB "
                     "more memory per run; `tmpc cache clear aot` tries the build again)"
                     if say else None)
    return _KERNEL_STATE[name]


def _use_jit(why: str, warning: str | None) -> None:
    """Switch the pass to numba's JIT (imported here: only this path loads numba), saying
    ``warning`` if given."""
    from tmpc.runtime.collision import pass_kernel as jit
    if warning is not None:
        warnings.warn(f"collision pass: {warning}", stacklevel=3)
    _KERNEL_STATE.update(candidates=jit.candidates, kinematics=jit.kinematics, why=why)


# ---------------------------------------------------------------------------------------------
# pair tables


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
        """(B,) bool: the pair certainly does not touch in states Q (B, n)."""
        x = Q[:, self.cols]
        span = np.where(self.wrap, 2 * np.pi, 1.0)
        x = np.where(self.wrap, (x - self.lo) % span + self.lo, x)
        idx = np.rint((x - self.lo) / self.step).astype(np.int64)
        idx = np.where(self.wrap, idx % self.n, np.clip(idx, 0, self.n - 1))
        dev = np.abs(x - (self.lo + idx * self.step))
        dev = np.where(self.wrap, np.minimum(dev, 2 * np.pi - dev), dev)
        flat = np.ravel_multi_index(tuple(idx.T), tuple(self.n))
        return self.dist[flat] > (self.rate * dev).sum(1)

    @staticmethod
    def build(world: "CollisionWorld", ga: int, gb: int) -> "PairTable | None":
        """The table of a pair of robot link geometries, or None when their relative pose depends
        on no or more than two coordinates (or on a joint more than once, or on a prismatic
        joint below another moving joint)."""
        import fcl

        model = world.model
        if any(world.bodies[world.geoms[g].body].kind != "link" for g in (ga, gb)):
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
        T = world.frames(model.default_q[None], world.default_place)
        Tg = _geom_world(world, T, ga), _geom_world(world, T, gb)
        Tj = {e[2].name: _frame_world(world, model.default_q, e[2].child) for e in entries}
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
        fpos, local, R, p = world.frames(Q, world.default_place)
        objs = [world.geoms[g].narrow for g in (ga, gb)]
        k = [world._dyn_pos[g] for g in (ga, gb)]
        dist = np.empty(len(grid))
        for i in range(len(grid)):
            for o, kk in zip(objs, k):
                Tw = np.eye(4)
                Tw[:3, :3], Tw[:3, 3] = R[i, fpos[kk]], p[i, fpos[kk]]
                Tw = Tw @ local[kk]
                o.setTransform(fcl.Transform(Tw[:3, :3], Tw[:3, 3]))
            dist[i] = fcl.distance(objs[0], objs[1], fcl.DistanceRequest(), fcl.DistanceResult())
        return PairTable(ga, gb, cols, lo, step, n, wrap, rate, np.maximum(dist, 0.0) - GJK_MARGIN)


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


def _frame_world(world, q, link: str) -> np.ndarray:
    R, p = world.kinematics(np.asarray(q, float)[None])
    f = world.model.frame(link)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R[f, :, :, 0], p[f, :, 0]
    return T


def _geom_world(world, frames, g: int) -> np.ndarray:
    fpos, local, R, p = frames
    k = world._dyn_pos[g]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R[0, fpos[k]], p[0, fpos[k]]
    return T @ local[k]


def _reach(geom, T: np.ndarray, o: np.ndarray) -> float:
    """Largest distance from point o of the geometry placed at T (world)."""
    if geom.mesh is not None:
        pts = geom.mesh.hull_vertices
    else:
        c, h = geom.aabb_center, geom.aabb_half
        pts = c + h * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    world_pts = pts @ T[:3, :3].T + T[:3, 3]
    return float(np.linalg.norm(world_pts - o, axis=1).max())


#: batch plans kept (least recently used out)
PLANS_KEPT = 256


