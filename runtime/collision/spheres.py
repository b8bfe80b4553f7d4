"""Bounding volumes of collision geometry: a ball, a cover of balls, a rounded box and hull points.

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

Each function dispatches on the shape's kind through its own table
(:func:`tmpc.lang.world.dispatch_shape`). The pass that uses these volumes is
:mod:`tmpc.runtime.collision.first_pass`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from tmpc.lang.world import Shape, dispatch_shape
from tmpc.runtime.collision.store import mesh_key

if TYPE_CHECKING:
    from tmpc.runtime.collision.geometry import MeshData

SLACK = 1e-9
#: radius of padding balls (never overlap anything)
NEVER = -1e30


def inflate(r):
    """Radii or half-extents grown by :data:`SLACK`, relative and absolute (rounding)."""
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
    C, r = dispatch_shape(_COVER, shape, "a cover of balls")(shape, mesh, k_max, r_target, store)
    return C, inflate(r)


def _cover_sphere(shape, mesh, k_max, r_target, store):
    return np.zeros((1, 3)), np.array([float(shape.radius)])


def _cover_box(shape, mesh, k_max, r_target, store):
    h = np.asarray(shape.size, float)
    return _box_cells(h, int(np.clip(np.prod(np.ceil(h / r_target)), 1, k_max)))


def _cover_cylinder(shape, mesh, k_max, r_target, store):
    m = int(np.clip(np.ceil(shape.length / (2 * shape.radius)), 1, k_max))
    z = -shape.length / 2 + (2 * np.arange(m) + 1) * shape.length / (2 * m)
    C = np.stack([np.zeros(m), np.zeros(m), z], 1)
    return C, np.full(m, float(np.hypot(shape.radius, shape.length / (2 * m))))


def _cover_of_mesh(shape, mesh, k_max, r_target, store):
    key = (id(mesh), k_max, r_target)
    if key not in _MESH_COVERS:
        _MESH_COVERS[key] = (mesh, _stored_cover(mesh, k_max, r_target, store))
    return _MESH_COVERS[key][1]


_COVER = {"sphere": _cover_sphere, "box": _cover_box, "cylinder": _cover_cylinder,
          "mesh": _cover_of_mesh}


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
    passes over a PR2 link's vertices: a mesh's ball is worth keeping)."""
    c, r = dispatch_shape(_BALL, shape, "a bounding ball")(shape, mesh, store)
    return c, float(inflate(r))


def _ball_of_mesh(shape, mesh, store):
    if store is None:
        return bounding_ball(mesh.vertices)
    name = "ball/" + mesh_key(mesh.vertices, mesh.faces)
    got = store.get(name)
    if got is None:
        c, r = bounding_ball(mesh.vertices)
        store.put(name, {"c": c, "r": np.array(r)})
        return c, r
    return got["c"], float(got["r"])


_BALL = {
    "sphere": lambda shape, mesh, store: (np.zeros(3), float(shape.radius)),
    "box": lambda shape, mesh, store: (np.zeros(3), float(np.linalg.norm(shape.size))),
    "cylinder": lambda shape, mesh, store: (np.zeros(3),
                                            float(np.hypot(shape.radius, shape.length / 2))),
    "mesh": _ball_of_mesh,
}


def box(shape: Shape, aabb_center, aabb_half) -> tuple[np.ndarray, np.ndarray, float]:
    """(center, half-extents, rounding radius) of a rounded box containing the geometry: a
    sphere is a box of size 0 rounded by its radius, the others their local AABB."""
    return dispatch_shape(_BOX, shape, "a rounded box")(shape, aabb_center, aabb_half)


def _aabb_box(shape, aabb_center, aabb_half):
    return np.asarray(aabb_center, float), inflate(aabb_half), 0.0


_BOX = {
    "sphere": lambda shape, c, h: (np.zeros(3), np.zeros(3), float(inflate(shape.radius))),
    "box": _aabb_box, "cylinder": _aabb_box, "mesh": _aabb_box,
}


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
    return dispatch_shape(_HULL_POINTS, shape, "the convex stage's points")(shape, mesh, store)


def _hull_box(shape, mesh, store):
    h = inflate(np.asarray(shape.size, float))
    return np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h, None, 0.0


def _hull_cylinder(shape, mesh, store):
    a = 2 * np.pi * np.arange(_PRISM_SIDES) / _PRISM_SIDES
    rho = float(inflate(shape.radius)) / np.cos(np.pi / _PRISM_SIDES)
    ring = np.stack([rho * np.cos(a), rho * np.sin(a)], 1)
    z = float(inflate(shape.length / 2))
    pts = np.concatenate([np.c_[ring, np.full(len(a), -z)], np.c_[ring, np.full(len(a), z)]])
    return pts, None, 0.0


def _hull_mesh(shape, mesh, store):
    if mesh is None or len(mesh.hull_vertices) > HULL_POINTS_MAX:
        return np.zeros((0, 3)), None, 0.0
    H = np.asarray(mesh.hull_vertices, float)
    out = _stored_outside(mesh, store)
    if out <= HULL_TRUST:
        return H, None, float(inflate(max(out, 0.0)))
    return H, np.asarray(mesh.vertices, float), 0.0


_HULL_POINTS = {
    "sphere": lambda shape, mesh, store: (np.zeros((1, 3)), None, float(inflate(shape.radius))),
    "box": _hull_box, "cylinder": _hull_cylinder, "mesh": _hull_mesh,
}


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


#: a watertight mesh whose volume is below this share of its convex hull's is hollow (a
#: table's top on legs, an arena's wall around the floor): the first pass sees it as parts
#: (:func:`mesh_parts`), and a part is halved again while its own share is below it
HOLLOW = 0.5
#: halvings of a hollow mesh at most (at most 2**PARTS_DEPTH parts)
PARTS_DEPTH = 6


def mesh_parts(shape: Shape, mesh: MeshData | None, store=None):
    """A hollow mesh's parts (:data:`HOLLOW`), the first pass's view of it as an obstacle:
    ``(centers (P, 3), half-extents (P, 3), hull points (N, 3), starts (P + 1,), radii (P,))``
    in the geometry's frame, part i's hull points ``points[starts[i]:starts[i + 1]]`` grown by
    its radius (how far qhull left a vertex outside); None for any other geometry. The mesh is
    cut in halves across its box's longest side, triangles cut where the plane crosses them,
    until each part's hull holds at most twice its share of the mesh's volume (by area).
    Every triangle of the mesh lies in the parts' triangles, so in their boxes and hulls: a
    geometry that touches the mesh touches a part, and fcl's answer for a mesh is its surface's
    (a BVH: docs/collision.md). Sort Clutter's arena, a wall 0.4 m high 2.75 m around the
    floor, has a hull the robot never leaves, and its pairs were 94-97% of the exact queries
    of a run (docs/collision.md, "Hollow meshes"). None too when the cut parts' area is not the
    mesh's (a triangle lost on a cut plane). ``store``: a
    :class:`~tmpc.runtime.collision.store.FirstPassStore` keeping them between runs."""
    if shape.kind != "mesh" or mesh is None:
        return None
    if store is None:
        return _mesh_parts(mesh)
    name = "parts/" + mesh_key(mesh.vertices, mesh.faces, HOLLOW, PARTS_DEPTH)
    got = store.get(name)
    if got is None:
        parts = _mesh_parts(mesh)
        store.put(name, {"none": np.zeros(0)} if parts is None else
                  dict(zip(("c", "h", "p", "s", "r"), parts)))
        return parts
    return None if "none" in got else (got["c"], got["h"], got["p"], got["s"], got["r"])


def _mesh_parts(mesh: MeshData):
    import trimesh

    m = trimesh.Trimesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))
    if not m.is_watertight or m.area <= 0:
        return None
    volume = abs(float(m.volume))
    if volume >= HOLLOW * _hull_volume(m.vertices):
        return None
    leaves = _halves(m, volume / m.area, 0)
    if len(leaves) < 2 or abs(sum(x.area for x in leaves) - m.area) > 1e-9 * max(m.area, 1.0):
        return None
    c, h, pts, r = [], [], [], []
    for x in leaves:
        V = np.asarray(x.vertices, float)
        lo, hi = V.min(0), V.max(0)
        c.append((lo + hi) / 2)
        h.append(inflate((hi - lo) / 2))
        H, out = _hull_vertices(V)
        pts.append(H)
        r.append(float(inflate(out)))
    p, start = ragged(pts)
    return np.array(c), np.array(h), p, start, np.array(r)


def _halves(m, density: float, depth: int) -> list:
    """``m`` cut in halves (:func:`mesh_parts`) until each part's hull holds at most twice its
    area's share of the volume (``density``: volume per area), or :data:`PARTS_DEPTH`."""
    import trimesh

    if depth >= PARTS_DEPTH or density * m.area >= HOLLOW * _hull_volume(m.vertices):
        return [m]
    lo, hi = m.bounds
    k = int(np.argmax(hi - lo))
    axis = np.zeros(3)
    axis[k] = 1.0
    # the plane through the middle, moved off every vertex (a triangle in the plane would be
    # neither side's)
    origin = (lo + hi) / 2
    x = np.asarray(m.vertices, float)[:, k]
    for shift in (0.0, 0.0037, -0.0061, 0.0113):
        c = origin[k] + shift * (hi[k] - lo[k])
        if not np.any(np.abs(x - c) <= 1e-9 * (hi[k] - lo[k])):
            break
    else:
        return [m]
    origin[k] = c
    out = []
    for normal in (axis, -axis):
        half = trimesh.intersections.slice_mesh_plane(m, normal, origin, cap=False)
        if half is not None and len(half.faces):
            out += _halves(half, density, depth + 1)
    return out


def _hull_volume(V: np.ndarray) -> float:
    from scipy.spatial import ConvexHull, QhullError

    try:
        return float(ConvexHull(V).volume)
    except (QhullError, ValueError):
        return 0.0                     # flat: no volume to save


def _hull_vertices(V: np.ndarray) -> tuple[np.ndarray, float]:
    """The vertices of ``V``'s convex hull (all of ``V`` when flat) and how far a point of
    ``V`` lies outside its facets (0 when flat); no points (no convex stage) past
    :data:`HULL_POINTS_MAX`."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(V)
    except (QhullError, ValueError):
        H, out = V, 0.0
    else:
        H = V[hull.vertices]
        out = max(float((V @ hull.equations[:, :3].T + hull.equations[:, 3]).max()), 0.0)
    return (H, out) if len(H) <= HULL_POINTS_MAX else (np.zeros((0, 3)), 0.0)


def ragged(parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Point sets as one (P, 3) array and their starts (len(parts) + 1,)."""
    start = np.zeros(len(parts) + 1, np.int64)
    start[1:] = np.cumsum([len(x) for x in parts])
    flat = np.concatenate(parts) if parts else np.zeros((0, 3))
    return np.ascontiguousarray(flat.reshape(-1, 3), dtype=float), start
