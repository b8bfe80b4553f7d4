"""Building a collision world: its bodies and geometries, placements in the scene and the pairs never checked.

A :class:`WorldParts` is made once per :class:`tmpc.runtime.collision.CollisionWorld`: the robot's
link geometry (URDF primitives, meshes as BVH and convex hull), one geometry per scene object with
its scene placement (object chains compose; an object whose chain ends at a robot frame rides on
it), the allowed-pair matrix (adjacent and rigidly joined links, the SRDF, the ``allowed``
argument and the scene's ``allowed_collisions``: docs/collision.md, "Allowed pairs") and the
geometry pairs left to check.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from tmpc.compiler.robot import RobotModel
from tmpc.compiler.rotations import pose_matrix
from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.world import Scene, Shape, find_srdf
from tmpc.runtime.collision.geometry import (
    Body,
    Geom,
    PassGeometry,
    Placement,
    adjacent_pairs,
    fcl_geometry,
    rigid_groups,
    srdf_disabled_pairs,
)


class WorldParts:
    """The bodies, geometries, scene placements and pairs of a collision world (arguments as
    :class:`tmpc.runtime.collision.CollisionWorld`'s)."""

    def __init__(self, scene: Scene, model: RobotModel, allowed: Iterable[tuple[str, str]],
                 srdf: bool | str | Path, attach_allowed: Mapping[str, Iterable[str]] | None):
        self.scene, self.model = scene, model
        self.bodies: list[Body] = []
        self.geoms: list[Geom] = []
        self.groups = rigid_groups(model.tree)
        self._add_links()
        self.default_place = self._add_objects()
        #: link name -> body (objects: :attr:`object_index`, by name without case)
        self.link_body = {b.name: i for i, b in enumerate(self.bodies) if b.kind == "link"}
        self.object_index = {b.name.lower(): i for i, b in enumerate(self.bodies)
                             if b.kind == "object"}
        self.unmatched_allowed: tuple[str, ...] = ()
        self.allowed = self._allowed_matrix(allowed, srdf)
        self.attach_allowed = {k: list(v) for k, v in (attach_allowed or {}).items()}
        for frame, links in self.attach_allowed.items():
            self.frame_of(frame, "attach_allowed")
            for ln in links:
                if model.tree.link(ln) is None and model.tree.joint(ln) is None:
                    raise SceneError(error("E568", f"attach_allowed: `{ln}` is no link or joint of "
                                           f"the robot `{model.tree.name}`", None,
                                           "list the links a held object may touch"))
        self.dynamic = np.array([i for i, g in enumerate(self.geoms)
                                 if not self.bodies[g.body].static], np.int64)
        self.static = np.array([i for i, g in enumerate(self.geoms)
                                if self.bodies[g.body].static], np.int64)
        self._build_pairs()

    def pass_geometry(self, tolerance: float) -> PassGeometry:
        """What the first pass reads of these parts."""
        return PassGeometry(self.model, self.bodies, self.geoms, self.geom_body, self.dynamic,
                            self.static, self.dynamic_position, self.dd, self.ds, tolerance)

    def _add_geom(self, body: int, shape: Shape, T: np.ndarray, owner: str) -> None:
        import fcl
        geom, hull, c, h, mesh = fcl_geometry(shape, owner)
        self.geom_ids[id(geom)] = len(self.geoms)
        self.geoms.append(Geom(body, shape, np.asarray(T, float), fcl.CollisionObject(geom),
                               None if hull is None else fcl.CollisionObject(hull), c, h, mesh))
        self.bodies[body].geoms.append(len(self.geoms) - 1)

    def _add_links(self) -> None:
        self.geom_ids: dict[int, int] = {}
        for lk in self.model.tree.links:
            if not lk.collision:
                continue
            self.bodies.append(Body(lk.name, "link", self.model.frame(lk.name)))
            for g in lk.collision:
                self._add_geom(len(self.bodies) - 1, g.shape, np.array(g.origin, float),
                               f"link `{lk.name}`")

    def _add_objects(self) -> dict[int, Placement]:
        """Objects with a shape become bodies; returns their scene placements."""
        place: dict[int, Placement] = {}
        for o in self.scene.objects:
            if o.shape is None:
                continue
            frame, T, static = self._scene_pose(o, ())
            self.bodies.append(Body(o.name, "object", static=static))
            self._add_geom(len(self.bodies) - 1, o.shape, np.eye(4), f"object `{o.name}`")
            place[len(self.bodies) - 1] = Placement(frame, T, held=frame >= 0)
        return place

    def _scene_pose(self, o, seen: tuple[str, ...]) -> tuple[int, np.ndarray, bool]:
        """(robot frame or -1, T_frame_object, static) following ``parent`` links."""
        T = pose_matrix(o.pose)
        if o.parent is None:
            return -1, T, not o.movable
        parent = self.scene.object(o.parent)
        if parent is not None:
            if parent.name in seen + (o.name,):
                raise SceneError(error("E569", f"object `{o.name}`: its parents form a cycle "
                                       f"({' -> '.join(seen + (o.name, parent.name))})", None,
                                       "an object's pose is relative to a parent that is not "
                                       "itself placed on it"))
            frame, Tp, static = self._scene_pose(parent, seen + (o.name,))
            return frame, Tp @ T, static and not o.movable
        robot = self.scene.robot
        if robot is not None and o.parent.lower() == robot.name.lower():
            return self.model.frame(self.model.tree.root), T, False     # the robot's base
        frame = self.model.frame(o.parent)
        if frame is None:
            raise SceneError(error("E569", f"object `{o.name}`: parent `{o.parent}` is no object "
                                   "of the scene and no link or joint of the robot", None,
                                   "name an object, a robot link or a joint"))
        return frame, T, False

    def bodies_named(self, name: str) -> list[int] | None:
        """Bodies a name in an allowed pair stands for ([] = matched, no geometry; None = no
        match)."""
        tree = self.model.tree
        link = name if tree.link(name) is not None else \
            (tree.joint(name).child if tree.joint(name) is not None else None)
        if link is not None:
            if link in self.link_body:
                return [self.link_body[link]]
            g = self.groups[link]
            return [i for i, b in enumerate(self.bodies)
                    if b.kind == "link" and self.groups[b.name] == g]
        if name.lower() in self.object_index:
            return [self.object_index[name.lower()]]
        return [] if self.scene.object(name) is not None else None

    def _allow(self, A: np.ndarray, a: str, b: str, unmatched: list[str] | None) -> None:
        ia, ib = self.bodies_named(a), self.bodies_named(b)
        for name, got in ((a, ia), (b, ib)):
            if got is None and unmatched is not None:
                unmatched.append(name)
        for i in ia or ():
            for k in ib or ():
                A[i, k] = A[k, i] = True

    def _allowed_matrix(self, allowed, srdf) -> np.ndarray:
        n = len(self.bodies)
        A = np.eye(n, dtype=bool)
        for pair in adjacent_pairs(self.model.tree):
            a, b = tuple(pair)
            self._allow(A, a, b, None)
        path = find_srdf(self.model.tree.path) if srdf is True else \
            (Path(srdf) if srdf not in (False, None) else None)
        if path is not None:
            for a, b in srdf_disabled_pairs(path):
                self._allow(A, a, b, None)
        unmatched: list[str] = []
        for a, b in list(allowed) + list(self.scene.allowed_collisions):
            self._allow(A, a, b, unmatched)
        self.unmatched_allowed = tuple(unmatched)
        static = np.array([b.static for b in self.bodies], bool)
        A |= static[:, None] & static[None, :]
        return A

    def _build_pairs(self) -> None:
        """Candidate geometry pairs: dynamic-dynamic (``dd``) and dynamic-static (``ds``), as
        index arrays into ``self.geoms``, without allowed pairs."""
        body = np.array([g.body for g in self.geoms], np.int64)
        d, s = self.dynamic, self.static
        ia, ib = np.triu_indices(len(d), 1)
        keep = ~self.allowed[body[d[ia]], body[d[ib]]]
        self.dd = np.stack([d[ia][keep], d[ib][keep]], 1)
        ga, gb = np.repeat(d, len(s)), np.tile(s, len(d))
        keep = ~self.allowed[body[ga], body[gb]]
        self.ds = np.stack([ga[keep], gb[keep]], 1)
        self.geom_body = body
        self.dynamic_position = np.full(len(self.geoms), -1, np.int64)
        self.dynamic_position[d] = np.arange(len(d))
        self.aabb_c = np.array([g.aabb_center for g in self.geoms]).reshape(-1, 3)
        self.aabb_h = np.array([g.aabb_half for g in self.geoms]).reshape(-1, 3)

    def frame_of(self, name: str, what: str) -> int:
        f = self.model.frame(name)
        if f is None:
            raise SceneError(error("E568", f"{what}: `{name}` is no link or joint of the robot "
                                   f"`{self.model.tree.name}`", None,
                                   "hold objects by a link or joint name (e.g. a tool frame)"))
        return f

    def hand(self, frame: int) -> list[int]:
        """Bodies a held object may touch when held by ``frame``."""
        name = self.model.frames[frame]
        for key, links in self.attach_allowed.items():
            if self.model.frame(key) == frame:
                return sorted({b for ln in links for b in self.bodies_named(ln) or ()})
        tree = self.model.tree
        group = self.groups[name]
        todo = [lk.name for lk in tree.links if self.groups[lk.name] == group]
        children: dict[str, list[str]] = {}
        for j in tree.joints:
            children.setdefault(j.parent, []).append(j.child)
        seen = set()
        while todo:
            ln = todo.pop()
            if ln not in seen:
                seen.add(ln)
                todo += children.get(ln, [])
        return sorted(self.link_body[ln] for ln in seen if ln in self.link_body)
