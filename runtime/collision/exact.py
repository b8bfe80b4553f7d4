"""Exact collision queries of one state with python-fcl: placing geometries, penetration depths and the colliding pairs.

A contact counts when its penetration depth exceeds the tolerance (plus :data:`DEPTH_EPS`).
fcl's depth is exact for primitive pairs; for a pair involving a mesh, whether it touches is
decided on the BVH (surfaces) and the depth is EPA's between the convex hulls, an upper bound
exact for convex meshes (fcl's per-triangle depths of mesh pairs are meaningless:
docs/collision.md, "Penetration tolerance"). A numpy broad phase on world AABBs drops the
moving pairs that cannot touch; the static objects stand in an fcl manager.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tmpc.runtime.collision.build import WorldParts

#: numerical slack on penetration depth: a resting contact computed as 1e-12 deep is not a collision
DEPTH_EPS = 1e-9


@dataclass(frozen=True)
class CollisionReport:
    """``pairs``: every colliding pair ``(name_a, name_b, depth)``: links by link name, objects by
    scene name, a link before an object, two links (objects) in model (scene) order; depth in
    metres, the deepest contact between the two. The list is sorted."""

    valid: bool
    pairs: list[tuple[str, str, float]] = field(default_factory=list)


class ExactChecker:
    """fcl's answers on a world's geometry (``parts``) at a penetration ``tolerance``. The fcl
    objects hold the last transforms set: not thread-safe."""

    def __init__(self, parts: WorldParts, tolerance: float):
        import fcl
        self.parts, self.tolerance = parts, tolerance
        for b, pl in parts.default_place.items():
            if parts.bodies[b].static:
                for g in parts.bodies[b].geoms:
                    self.set_pose(g, pl.T @ parts.geoms[g].T_body_geom)
        self._static_mgr = fcl.DynamicAABBTreeCollisionManager()
        if len(parts.static):
            self._static_mgr.registerObjects([parts.geoms[i].obj for i in parts.static])
            self._static_mgr.setup()
        self._dyn_mgr = fcl.DynamicAABBTreeCollisionManager()
        self._dyn_mgr.registerObjects([parts.geoms[i].obj for i in parts.dynamic])
        self._dyn_mgr.setup()
        self._req = fcl.CollisionRequest(num_max_contacts=1, enable_contact=True)
        #: whether two geometries touch, without a contact: the mesh test of a pair whose depth
        #: comes from the convex hulls (:meth:`depth`) needs no contact of its own
        self._touch = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
        #: the state key whose non-moving objects' fcl transforms are set, and whether two of
        #: them collide there (:meth:`tmpc.runtime.collision.motion.BatchChecker.constant_collision`;
        #: None once :meth:`exact` moves every dynamic geometry)
        self.fixed: tuple | None = None

    def set_pose(self, g: int, T: np.ndarray) -> None:
        self.place(g, T[:3, :3], T[:3, 3])

    def place(self, g: int, R: np.ndarray, t: np.ndarray) -> None:
        """Geometry g's fcl objects (the shape, and a mesh's hull) at rotation R, translation t."""
        import fcl
        tf = fcl.Transform(R, t)
        geom = self.parts.geoms[g]
        geom.obj.setTransform(tf)
        if geom.hull is not None:
            geom.hull.setTransform(tf)

    def depth(self, ga: int, gb: int) -> float | None:
        """Penetration depth of two geometries (transforms set), or None when they do not touch."""
        import fcl
        A, B = self.parts.geoms[ga], self.parts.geoms[gb]
        res = fcl.CollisionResult()
        if A.hull is None and B.hull is None:
            if not fcl.collide(A.obj, B.obj, self._req, res):
                return None
            return abs(res.contacts[0].penetration_depth)
        if not fcl.collide(A.obj, B.obj, self._touch, res):
            return None
        res = fcl.CollisionResult()
        if not fcl.collide(A.narrow, B.narrow, self._req, res):
            return 0.0
        return abs(res.contacts[0].penetration_depth)

    def hits_static(self, obj) -> bool:
        """Does the fcl object ``obj`` (its transform set) touch any static geometry?"""
        import fcl
        data = fcl.CollisionData(request=fcl.CollisionRequest())
        self._static_mgr.collide(obj, data, fcl.defaultCollisionCallback)
        return bool(data.result.is_collision)

    def counts(self, depth: float | None) -> bool:
        return depth is not None and depth > self.tolerance + DEPTH_EPS

    def exact(self, Tg: np.ndarray, allowed, first_only: bool) -> dict[tuple[int, int], float]:
        """Exact check of one state from the world transforms of the dynamic geometries (Gd, 4,
        4): {(body a, body b): depth}."""
        self.fixed = None                 # every dynamic geometry moves here
        for k, g in enumerate(self.parts.dynamic):
            self.set_pose(g, Tg[k])
        hits: dict[tuple[int, int], float] = {}
        c, h = aabbs(Tg, self.parts.aabb_c[self.parts.dynamic], self.parts.aabb_h[self.parts.dynamic])
        a, b = self.parts.dynamic_position[self.parts.dd[:, 0]], self.parts.dynamic_position[self.parts.dd[:, 1]]
        body = self.parts.geom_body
        over = np.all(np.abs(c[a] - c[b]) <= h[a] + h[b], axis=1)
        over &= ~allowed[body[self.parts.dd[:, 0]], body[self.parts.dd[:, 1]]]
        for k in np.nonzero(over)[0]:
            ga, gb = self.parts.dd[k]
            if self._record(hits, ga, gb, self.depth(ga, gb)) and first_only:
                return hits
        if len(self.parts.static):
            self._dyn_mgr.update()
            self._dyn_mgr.collide(self._static_mgr, None, self._callback(hits, allowed, first_only))
        return hits

    def _record(self, hits, ga: int, gb: int, depth: float | None) -> bool:
        if not self.counts(depth):
            return False
        key = tuple(sorted((int(self.parts.geom_body[ga]), int(self.parts.geom_body[gb]))))
        hits[key] = max(hits.get(key, 0.0), depth)
        return True

    def _callback(self, hits, allowed, first_only: bool):
        import fcl
        req = self._req

        def cb(o1, o2, _data):
            res = fcl.CollisionResult()
            if not fcl.collide(o1, o2, req, res):
                return False
            c = res.contacts[0]
            ga, gb = self.parts.geom_ids[id(c.o1)], self.parts.geom_ids[id(c.o2)]
            if allowed[self.parts.geom_body[ga], self.parts.geom_body[gb]]:
                return False
            if self.parts.geoms[ga].hull is None and self.parts.geoms[gb].hull is None:
                depth = abs(c.penetration_depth)
            else:
                depth = self.depth(ga, gb)
            return self._record(hits, ga, gb, depth) and first_only
        return cb

    def report(self, hits: dict[tuple[int, int], float]) -> CollisionReport:
        pairs = sorted((self.parts.bodies[a].name, self.parts.bodies[b].name, float(d))
                       for (a, b), d in hits.items())
        return CollisionReport(not pairs, pairs)


def world_transforms(R: np.ndarray, p: np.ndarray, fpos: np.ndarray, local: np.ndarray) -> np.ndarray:
    """World transforms (..., Gd, 4, 4) of geometries hanging on frames ``fpos`` of R/p."""
    Rf, pf = R[..., fpos, :, :], p[..., fpos, :]
    T = np.empty(Rf.shape[:-2] + (4, 4))
    T[..., :3, :3] = Rf @ local[:, :3, :3]
    T[..., :3, 3] = (Rf @ local[:, :3, 3, None])[..., 0] + pf
    T[..., 3, :] = (0.0, 0.0, 0.0, 1.0)
    return T


def aabbs(T: np.ndarray, c: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World AABBs (center, half-extents) of local boxes (c, h) moved by T (..., G, 4, 4)."""
    R = T[..., :3, :3]
    return (R @ c[..., None])[..., 0] + T[..., :3, 3], (np.abs(R) @ h[..., None])[..., 0]
