"""Where a mobile base can drive: the part of the floor connected to where it starts.

A scene's bounds say where a base may be; they do not say that it can get there. Sort Clutter's
arena is a wall 0.4 m high at 2.75 m around the tables, and the bounds (the objects' extent plus
2 m, W505) reach 4.3 m: from outside the wall an arm reaches over it to a table, so the
projections put bases there, and no motion leads out of the arena to them (23 failed motions in
one run, each its whole budget; docs/planning.md, "The base's floor").

:func:`floor_bounds` finds the floor the base can reach: on a grid of cells over the bounds, a
cell is blocked where a vertical cylinder inside the base (the largest circle about the base's
origin within its widest geometry's footprint, less half a cell's diagonal, over the middle half
of that geometry's height) collides with the fixed scene; the free cells joined to the start's
(sides shared) are the floor. A base that stands free somewhere has that cylinder free about
every point within half a diagonal of it, so every cell its path crosses is free: the floor
holds every position the base can drive to (the base's solid holds the cylinder: a convex
footprint, as a PR2's). The floor's bounding box, half a cell wider, is returned; the planners
then sample, project and plan within it (:class:`tmpc.runtime.problem.PlanningProblem`).
:class:`FloorMap` makes the grid once and fills a region the first time a start stands in it;
a replan from another start looks its region up.
"""

from __future__ import annotations

import numpy as np

from tmpc.runtime.collision.geometry import rigid_groups

#: the grid's cell (metres), at most; a grid has at most this many cells a side
CELL = 0.1
MAX_SIDE = 400


def floor_bounds(world, q0: np.ndarray, lower: np.ndarray, upper: np.ndarray
                 ) -> tuple[float, float, float, float] | None:
    """``(xlo, xhi, ylo, yhi)``: the bounding box of the floor the base at ``q0`` reaches,
    within the bounds ``lower``/``upper`` (the first two coordinates: the base's x and y), or
    None when it is all of them (or the base has no geometry to test, or its start cell is
    blocked). ``world``: a :class:`tmpc.runtime.collision.CollisionWorld` of a mobile base.
    One call of :class:`FloorMap`."""
    return FloorMap(world, lower, upper).bounds(q0)


class FloorMap:
    """The grid of a base's floor within ``lower``/``upper``, made once: its blocked cells
    (module docstring), and the free regions joined by shared sides with their bounding boxes,
    each filled the first time a start stands in it; a replan from a start in a region already
    filled is a look-up."""

    def __init__(self, world, lower: np.ndarray, upper: np.ndarray):
        import fcl

        self.labels: np.ndarray | None = None
        probe = base_probe(world)
        if probe is None or not len(world.parts.static):
            return
        radius, zlo, zhi = probe
        (xlo, ylo), (xhi, yhi) = lower[:2], upper[:2]
        cell = max(CELL, (xhi - xlo) / MAX_SIDE, (yhi - ylo) / MAX_SIDE)
        nx, ny = int(np.ceil((xhi - xlo) / cell)), int(np.ceil((yhi - ylo) / cell))
        r = radius - cell / np.sqrt(2.0)
        if r <= 0.0 or nx < 3 or ny < 3:
            return
        self.lo, self.span, self.n = np.array([xlo, ylo]), np.array([xhi - xlo, yhi - ylo]), \
            np.array([nx, ny])
        xs = xlo + (np.arange(nx) + 0.5) * (xhi - xlo) / nx
        ys = ylo + (np.arange(ny) + 0.5) * (yhi - ylo) / ny
        cyl = fcl.CollisionObject(fcl.Cylinder(r, zhi - zlo))
        zmid = 0.5 * (zlo + zhi)
        blocked = np.zeros((nx, ny), bool)
        eye = np.eye(3)
        # only cells whose cylinder's box meets a static geometry's box need fcl
        near = np.zeros((nx, ny), bool)
        for lo, hi in static_boxes(world):
            if lo[2] <= zhi and hi[2] >= zlo:
                near |= ((xs[:, None] >= lo[0] - r) & (xs[:, None] <= hi[0] + r)
                         & (ys[None, :] >= lo[1] - r) & (ys[None, :] <= hi[1] + r))
        for i, j in zip(*np.nonzero(near)):
            cyl.setTransform(fcl.Transform(eye, np.array([xs[i], ys[j], zmid])))
            blocked[i, j] = world.exact.hits_static(cyl)
        #: each cell's region (-2: blocked, -1: not visited yet), found as starts need them
        self.labels = np.where(blocked, -2, -1)
        self.xs, self.ys = xs, ys
        #: per region: its box, half a cell wider than its cells, or None where it reaches
        #: the bounds' edge (nothing to narrow)
        self.boxes: list = []

    def bounds(self, q0: np.ndarray) -> tuple[float, float, float, float] | None:
        """The box of the region the base at ``q0`` stands in (None: see
        :func:`floor_bounds`); a region is filled the first time a start stands in it."""
        if self.labels is None:
            return None
        i, j = np.clip(((np.asarray(q0[:2], float) - self.lo) / self.span * self.n)
                       .astype(int), 0, self.n - 1)
        if self.labels[i, j] == -1:
            ii, jj = _fill(self.labels, (i, j), len(self.boxes))
            (nx, ny), (dx, dy) = self.n, self.span / self.n
            edge = ii.min() == 0 or jj.min() == 0 or ii.max() == nx - 1 or jj.max() == ny - 1
            self.boxes.append(None if edge else (
                float(self.xs[ii.min()] - dx), float(self.xs[ii.max()] + dx),
                float(self.ys[jj.min()] - dy), float(self.ys[jj.max()] + dy)))
        label = self.labels[i, j]
        return None if label < 0 else self.boxes[label]


def static_boxes(world) -> list[tuple[np.ndarray, np.ndarray]]:
    """The world axis-aligned box ``(lo, hi)`` of each static geometry, where the scene puts
    it (the corners of its own box, moved)."""
    parts = world.parts
    out = []
    for g in parts.static:
        geom = parts.geoms[g]
        T = parts.default_place[geom.body].T @ geom.T_body_geom
        W = _box_corners(geom) @ T[:3, :3].T + T[:3, 3]
        out.append((W.min(0), W.max(0)))
    return out


def base_probe(world) -> tuple[float, float, float] | None:
    """``(radius, zlo, zhi)`` of the cylinder inside the base (module docstring) with the base
    at the origin, or None: the largest circle about the base's origin inside the footprint (the
    convex hull of the vertices, seen from above) of one geometry rigid with the base, the one
    whose circle is widest, and the middle half of that geometry's height."""
    parts, model = world.parts, world.model
    groups = rigid_groups(model.tree)
    root = groups[model.tree.root]
    q = np.array(model.default_q, float)
    q[:3] = 0.0                  # the base at the origin; what is rigid with it moves with it
    R, p = world.kinematics(q[None])
    best = None
    for g, geom in enumerate(parts.geoms):
        body = parts.bodies[geom.body]
        if body.kind != "link" or groups.get(body.name) != root:
            continue
        f = model.frame(body.name)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R[f, :, :, 0], p[f, :, 0]
        V = _vertices(geom)
        W = (T @ geom.T_body_geom @ np.c_[V, np.ones(len(V))].T).T[:, :3]
        radius = inscribed_radius(W[:, :2])
        if radius > 0 and (best is None or radius > best[0]):
            zlo, zhi = W[:, 2].min(), W[:, 2].max()
            quarter = 0.25 * (zhi - zlo)
            best = (radius, zlo + quarter, zhi - quarter)
    if best is None or best[2] - best[1] <= 1e-6:
        return None
    return best


def _vertices(geom) -> np.ndarray:
    """A geometry's points in its frame: a mesh's vertices, else its box's corners (a box's
    footprint; a cylinder's or a sphere's square has the same inscribed circle)."""
    if geom.mesh is not None:
        return np.asarray(geom.mesh.vertices, float)
    return _box_corners(geom)


#: the eight corners of a unit box about the origin
_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)


def _box_corners(geom) -> np.ndarray:
    """The corners (8, 3) of a geometry's own axis-aligned box, in its frame."""
    return np.asarray(geom.aabb_center, float) + _SIGNS * np.asarray(geom.aabb_half, float)


def inscribed_radius(P: np.ndarray) -> float:
    """The distance from the origin to the boundary of the convex hull of the 2-D points P
    (0 when the origin is not inside it). The hull by Andrew's monotone chain (scipy's qhull
    would cost its import, 0.3 s, at every mobile base's set-up)."""
    pts = sorted(set(map(tuple, np.round(np.asarray(P, float), 12))))
    if len(pts) < 3:
        return 0.0

    def half(points):
        out: list = []
        for q in points:
            while len(out) >= 2 and _cross(out[-2], out[-1], q) <= 0:
                out.pop()
            out.append(q)
        return out[:-1]

    hull = np.array(half(pts) + half(pts[::-1]))          # counter-clockwise
    if len(hull) < 3:
        return 0.0
    a, b = hull, np.roll(hull, -1, axis=0)
    edge = b - a
    length = np.hypot(edge[:, 0], edge[:, 1])
    # the origin's signed distance to each edge's line, positive on the inner side
    inside = (edge[:, 0] * -a[:, 1] - edge[:, 1] * -a[:, 0]) / np.where(length > 0, length, 1)
    return float(max(0.0, inside[length > 0].min()))


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _fill(labels: np.ndarray, start: tuple[int, int], k: int) -> tuple[np.ndarray, np.ndarray]:
    """Label ``k`` on the unvisited free cells (-1) joined to ``start`` by shared sides; their
    indices ``(ii, jj)``."""
    nx, ny = labels.shape
    labels[start] = k
    todo, ii, jj = [start], [], []
    while todo:
        i, j = todo.pop()
        ii.append(i)
        jj.append(j)
        for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
            if 0 <= a < nx and 0 <= b < ny and labels[a, b] == -1:
                labels[a, b] = k
                todo.append((a, b))
    return np.array(ii), np.array(jj)
