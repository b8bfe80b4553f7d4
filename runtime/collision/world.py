"""Collision checking of robot states against a scene (python-fcl), exact and batched.

A :class:`CollisionWorld` builds every fcl object once: the robot's link collision geometry (URDF
primitives; meshes as ``fcl.BVHModel`` plus their convex hull as ``fcl.Convex``), the scene
objects, and a ``DynamicAABBTreeCollisionManager`` of the static objects. A state is the robot
configuration ``q`` (layout of :class:`RobotModel`), optional world poses of movable objects and
the held objects ``{obj: (frame, T_frame_obj)}`` (the ``held`` of a ``WorldState``).

What is checked (docs/collision.md): robot self-collision, robot vs objects, object vs object
except static vs static, held objects vs everything except the links of the hand holding them.
Allowed pairs (never checked) come from the URDF tree (adjacent links, rigidly joined links), the
SRDF beside the URDF, the ``allowed`` argument and the scene's ``allowed_collisions``.

A contact counts when its penetration depth exceeds ``tolerance`` (plus :data:`DEPTH_EPS`). fcl's
depth is exact for primitive pairs; for pairs involving a mesh it is the depth between the convex
hulls (EPA), an upper bound that is exact for convex meshes: fcl's per-triangle depths of mesh
pairs are meaningless (measured: 1.0 for any mesh-mesh overlap; wrong sign or far too small for
deep mesh-primitive overlaps). Whether a mesh pair touches at all is decided on the BVH (surfaces).

``check_batch`` and ``check_motion`` run a sound first pass on bounding spheres
(:mod:`tmpc.runtime.collision.spheres`) and confirm only its candidate geometry pairs with fcl.
"""

from __future__ import annotations

import collections
import functools
import math
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from tmpc.compiler.jaxcfg import configured
from tmpc.compiler.robot import RobotModel, make_fk, robot_model
from tmpc.compiler.rotations import pose_matrix
from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.world import Scene, Shape, find_srdf
from tmpc.runtime.collision.batch import CHUNK, pad_batch
from tmpc.runtime.collision.geometry import (
    Geom,
    adjacent_pairs,
    fcl_geometry,
    rigid_groups,
    srdf_disabled_pairs,
)
from tmpc.runtime.collision.kinematics import Kinematics
from tmpc.runtime.collision.spheres import FirstPass

#: numerical slack on penetration depth: a resting contact computed as 1e-12 deep is not a collision
DEPTH_EPS = 1e-9


@dataclass(frozen=True)
class CollisionReport:
    """``pairs``: every colliding pair ``(name_a, name_b, depth)``: links by link name, objects by
    scene name, a link before an object, two links (objects) in model (scene) order; depth in
    metres, the deepest contact between the two. The list is sorted."""

    valid: bool
    pairs: list[tuple[str, str, float]] = field(default_factory=list)


@dataclass(frozen=True)
class MotionReport:
    """``t_first_collision`` in [0, 1] along the straight configuration-space motion (None when
    valid); ``report`` is the :class:`CollisionReport` of that first colliding state."""

    valid: bool
    t_first_collision: float | None
    report: CollisionReport | None
    steps: int = 0


@dataclass
class PassStats:
    """Counters of the first pass over all batch/motion calls (for benchmarks)."""

    states: int = 0
    coarse_pairs: int = 0
    cover_pairs: int = 0         # left after the covers, before the convex stage
    fine_pairs: int = 0
    settled: int = 0             # states with no candidate pair left: free without fcl
    colliding: int = 0
    queries: int = 0             # exact fcl pair queries made on the candidates
    sure: int = 0                # colliding states found with no fcl query (a vertex deep in a box)

    def add(self, n: int, cand, bad) -> None:
        self.states += n
        self.coarse_pairs += cand.coarse
        self.cover_pairs += cand.covers
        self.fine_pairs += len(cand.states)
        self.settled += n - len(np.unique(cand.states))
        self.colliding += len(bad)


# ---------------------------------------------------------------------------------------------
# the world


@dataclass
class Body:
    """A rigid thing that collides: a robot link (``frame`` = its FK frame) or a scene object."""

    name: str
    kind: str                    # "link" | "object"
    frame: int = -1
    geoms: list[int] = field(default_factory=list)
    static: bool = False


@dataclass(frozen=True)
class Placement:
    """Where a body is in one state: ``T`` in the world (``frame`` -1) or relative to a robot
    frame. ``held``: held objects are not checked against the links of their hand."""

    frame: int
    T: np.ndarray
    held: bool = False


class CollisionWorld:
    """Exact (fcl) and batched collision checking of robot states in a scene.

    ``allowed``: extra pairs never checked; a name is a link, a joint (its child link), or an
    object; a link without geometry stands for the links rigidly joined to it. Names matching
    nothing are counted in :attr:`unmatched_allowed`. ``attach_allowed``: robot frame -> links a
    held object may touch when held by that frame (default: the hand = the links with geometry
    rigidly joined to the frame and all links below them). ``srdf``: True looks for one beside the
    URDF (:func:`find_srdf`), a path uses that file, False ignores SRDFs. ``first_pass``: use the
    bounding-sphere pass in batch and motion checks (off: exact fcl on every state).
    """

    def __init__(self, scene: Scene, model: RobotModel, frames=None, tolerance: float = 0.0,
                 allowed: Iterable[tuple[str, str]] = (), *,
                 attach_allowed: Mapping[str, Iterable[str]] | None = None,
                 srdf: bool | str | Path = True, first_pass: bool = True):
        import fcl
        if not (tolerance >= 0 and math.isfinite(tolerance)):
            raise SceneError(error("E572", f"penetration tolerance {tolerance} must be a finite "
                                   "number >= 0", None, "planet used 0.021 m, tmit-star 0.029 m"))
        self.scene, self.model, self.tolerance = scene, model, float(tolerance)
        #: batched kinematics, batch-last: ``frames`` (the JAX kernel,
        #: :func:`tmpc.compiler.robot.make_fk_frames`, padded by :meth:`kinematics`) or the
        #: compiled loop (:class:`~tmpc.runtime.collision.kinematics.Kinematics`)
        self.fk_frames = frames if frames is not None else Kinematics(model)
        self.bodies: list[Body] = []
        self.geoms: list[Geom] = []
        self._groups = rigid_groups(model.tree)
        self._add_links()
        self.default_place = self._add_objects()
        #: link name -> body (objects: :meth:`object_body`, by name without case)
        self.link_body = {b.name: i for i, b in enumerate(self.bodies) if b.kind == "link"}
        self._object_index = {b.name.lower(): i for i, b in enumerate(self.bodies)
                              if b.kind == "object"}
        self.unmatched_allowed: tuple[str, ...] = ()
        self.allowed = self._allowed_matrix(allowed, srdf)
        self._attach_allowed = {k: list(v) for k, v in (attach_allowed or {}).items()}
        for frame, links in self._attach_allowed.items():
            self._frame_of(frame, "attach_allowed")
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
        for b, pl in self.default_place.items():
            if self.bodies[b].static:
                for g in self.bodies[b].geoms:
                    self._set(g, pl.T @ self.geoms[g].T_body_geom)
        self._static_mgr = fcl.DynamicAABBTreeCollisionManager()
        if len(self.static):
            self._static_mgr.registerObjects([self.geoms[i].obj for i in self.static])
            self._static_mgr.setup()
        self._dyn_mgr = fcl.DynamicAABBTreeCollisionManager()
        self._dyn_mgr.registerObjects([self.geoms[i].obj for i in self.dynamic])
        self._dyn_mgr.setup()
        self._req = fcl.CollisionRequest(num_max_contacts=1, enable_contact=True)
        #: whether two geometries touch, without a contact: the mesh test of a pair whose depth
        #: comes from the convex hulls (:meth:`_depth`) needs no contact of its own
        self._touch = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
        self._first_pass_enabled = first_pass
        self._first_pass = None
        #: exact queries and collisions found per geometry pair (:meth:`_confirm` asks a
        #: state's likeliest pairs first: a colliding state then costs about one query)
        self._pair_tries: np.ndarray | None = None
        self._pair_hits: np.ndarray | None = None
        self.stats = PassStats()
        #: placements of recent states by content (batch and motion calls repeat them)
        self._placements: dict = {}
        #: the state key whose non-moving objects' fcl transforms are set, and whether two of
        #: them collide there (:meth:`_constant_collision`)
        self._fixed: tuple | None = None
        #: per state key: the non-moving objects' frames and transforms, and whether two of them
        #: collide (a search alternates between a few modes: fcl answers each once)
        self._fixed_of: dict = {}

    # -- construction -------------------------------------------------------------------------

    def _add_geom(self, body: int, shape: Shape, T: np.ndarray, owner: str) -> None:
        import fcl
        geom, hull, c, h, mesh = fcl_geometry(shape, owner)
        self._geom_ids[id(geom)] = len(self.geoms)
        self.geoms.append(Geom(body, shape, np.asarray(T, float), fcl.CollisionObject(geom),
                               None if hull is None else fcl.CollisionObject(hull), c, h, mesh))
        self.bodies[body].geoms.append(len(self.geoms) - 1)

    def _add_links(self) -> None:
        self._geom_ids: dict[int, int] = {}
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

    def _bodies_named(self, name: str) -> list[int] | None:
        """Bodies a name in an allowed pair stands for ([] = matched, no geometry; None = no
        match)."""
        tree = self.model.tree
        link = name if tree.link(name) is not None else \
            (tree.joint(name).child if tree.joint(name) is not None else None)
        if link is not None:
            if link in self.link_body:
                return [self.link_body[link]]
            g = self._groups[link]
            return [i for i, b in enumerate(self.bodies)
                    if b.kind == "link" and self._groups[b.name] == g]
        if name.lower() in self._object_index:
            return [self._object_index[name.lower()]]
        return [] if self.scene.object(name) is not None else None

    def _allow(self, A: np.ndarray, a: str, b: str, unmatched: list[str] | None) -> None:
        ia, ib = self._bodies_named(a), self._bodies_named(b)
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
        self._geom_body = body
        self._dyn_pos = np.full(len(self.geoms), -1, np.int64)
        self._dyn_pos[d] = np.arange(len(d))
        self._aabb_c = np.array([g.aabb_center for g in self.geoms]).reshape(-1, 3)
        self._aabb_h = np.array([g.aabb_half for g in self.geoms]).reshape(-1, 3)

    def _frame_of(self, name: str, what: str) -> int:
        f = self.model.frame(name)
        if f is None:
            raise SceneError(error("E568", f"{what}: `{name}` is no link or joint of the robot "
                                   f"`{self.model.tree.name}`", None,
                                   "hold objects by a link or joint name (e.g. a tool frame)"))
        return f

    # -- one state ----------------------------------------------------------------------------

    def object_body(self, name: str, what: str = "object") -> int:
        b = self._object_index.get(str(name).lower())
        if b is None:
            raise SceneError(error("E567", f"{what}: `{name}` is no object (with a shape) of the "
                                   "scene", None, "object names are the scene's, e.g. `stick1`"))
        return b

    def placements(self, poses=None, attached=None) -> tuple[dict[int, Placement], np.ndarray]:
        """Placements of the object bodies in a state, and the per-state allowed matrix (held
        objects may touch their hand)."""
        place = dict(self.default_place)
        for name, T in (poses or {}).items():
            b = self.object_body(name, "poses")
            T = _matrix4(T, f"pose of `{name}`")
            if self.bodies[b].static:
                raw = pose_matrix(self.scene.object(name).pose)
                if not (np.allclose(T, self.default_place[b].T, atol=1e-9)
                        or np.allclose(T, raw, atol=1e-9)):
                    raise SceneError(error("E566", f"poses: `{name}` is static in the scene; its "
                                           "pose cannot change", None,
                                           "mark it movable in the scene"))
                continue
            place[b] = Placement(-1, T)
        allowed = self.allowed
        for name, value in (attached or {}).items():
            b = self.object_body(name, "attached")
            if self.bodies[b].static:
                raise SceneError(error("E566", f"attached: `{name}` is static in the scene and "
                                       "cannot be held", None, "mark it movable in the scene"))
            frame, T = value
            place[b] = Placement(self._frame_of(frame, f"attached `{name}`"),
                                 _matrix4(T, f"grasp of `{name}`"), held=True)
        for b, pl in place.items():
            if pl.held:
                if allowed is self.allowed:
                    allowed = self.allowed.copy()
                hand = self._hand(pl.frame)
                allowed[b, hand] = allowed[hand, b] = True
        return place, allowed

    def _placed(self, poses, attached):
        """(key, :meth:`placements`) of a state, remembered for the 256 most recent states:
        the key is the content of ``poses`` and ``attached``, so a caller may pass fresh or
        mutated dicts. Input :meth:`placements` rejects gets its error, uncached."""
        try:
            key = (tuple((str(n), np.asarray(T, float).tobytes())
                         for n, T in sorted((poses or {}).items())),
                   tuple((str(n), str(v[0]), np.asarray(v[1], float).tobytes())
                         for n, v in sorted((attached or {}).items())))
        except (TypeError, ValueError, IndexError):
            return None, self.placements(poses, attached)
        got = self._placements.pop(key, None)
        if got is None:
            got = self.placements(poses, attached)
            if len(self._placements) >= 256:         # least recently used out
                self._placements.pop(next(iter(self._placements)))
        self._placements[key] = got
        return key, got

    def _hand(self, frame: int) -> list[int]:
        """Bodies a held object may touch when held by ``frame``."""
        name = self.model.frames[frame]
        for key, links in self._attach_allowed.items():
            if self.model.frame(key) == frame:
                return sorted({b for ln in links for b in self._bodies_named(ln) or ()})
        tree = self.model.tree
        group = self._groups[name]
        todo = [lk.name for lk in tree.links if self._groups[lk.name] == group]
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

    def geom_frames(self, place: dict[int, Placement]) -> tuple[np.ndarray, np.ndarray]:
        """For the dynamic geometries: robot frame (-1: world) and T_frame_geom (Gd, 4, 4)."""
        frames = np.empty(len(self.dynamic), np.int64)
        local = np.empty((len(self.dynamic), 4, 4))
        for k, g in enumerate(self.dynamic):
            geom = self.geoms[g]
            body = self.bodies[geom.body]
            if body.kind == "link":
                frames[k], local[k] = body.frame, geom.T_body_geom
            else:
                pl = place[geom.body]
                frames[k], local[k] = pl.frame, pl.T @ geom.T_body_geom
        return frames, local

    def _set(self, g: int, T: np.ndarray) -> None:
        self._place(g, T[:3, :3], T[:3, 3])

    def _place(self, g: int, R: np.ndarray, t: np.ndarray) -> None:
        """Geometry g's fcl objects (the shape, and a mesh's hull) at rotation R, translation t."""
        import fcl
        tf = fcl.Transform(R, t)
        geom = self.geoms[g]
        geom.obj.setTransform(tf)
        if geom.hull is not None:
            geom.hull.setTransform(tf)

    def _depth(self, ga: int, gb: int) -> float | None:
        """Penetration depth of two geometries (transforms set), or None when they do not touch."""
        import fcl
        A, B = self.geoms[ga], self.geoms[gb]
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

    def _counts(self, depth: float | None) -> bool:
        return depth is not None and depth > self.tolerance + DEPTH_EPS

    def check(self, q, poses=None, attached=None) -> CollisionReport:
        """Every colliding pair at configuration ``q`` (poses: world 4x4 of movable objects;
        attached: ``{object: (robot frame, T_frame_object)}``)."""
        Q = self._Q(q, single=True)
        place, allowed = self.placements(poses, attached)
        fpos, local, R, p = self.frames(Q, place)
        hits = self._exact(_world(R[0], p[0], fpos, local), allowed, first_only=False)
        return self._report(hits)

    def check_state(self, state) -> CollisionReport:
        """:meth:`check` of a :class:`tmpc.compiler.state.WorldState`."""
        return self.check(state.q, state.poses, state.held)

    def kinematics(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of states Q (B, n), batch-last numpy: (R (F, 3, 3, B), p (F, 3,
        B)) over ``model.frames``. A kinematics that compiles per batch shape (JAX's, ``pads``
        not False) gets Q padded (:func:`pad_batch`)."""
        if not getattr(self.fk_frames, "pads", True):
            return self.fk_frames(Q)
        R, p = self.fk_frames(pad_batch(Q))
        return np.asarray(R)[..., :len(Q)], np.asarray(p)[..., :len(Q)]

    def frames(self, Q: np.ndarray, place) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                    np.ndarray]:
        """Forward kinematics of the frames the dynamic geometries hang on, for states Q (B, n):
        ``(fpos (Gd,), T_frame_geom (Gd, 4, 4), R (B, U+1, 3, 3), p (B, U+1, 3))``; geometry k
        hangs on frame ``fpos[k]`` of R/p, whose last entry is the world (identity)."""
        gframe, local = self.geom_frames(place)
        used = np.unique(gframe[gframe >= 0])
        fpos = np.where(gframe >= 0, np.searchsorted(used, gframe), len(used))
        R, p = self.kinematics(Q)
        R = R[used].transpose(3, 0, 1, 2)
        p = p[used].transpose(2, 0, 1)
        R = np.concatenate([R, np.broadcast_to(np.eye(3), (len(Q), 1, 3, 3))], 1)
        p = np.concatenate([p, np.zeros((len(Q), 1, 3))], 1)
        return fpos, local, R, p

    def _exact(self, Tg: np.ndarray, allowed, first_only: bool) -> dict[tuple[int, int], float]:
        """Exact check of one state from the world transforms of the dynamic geometries (Gd, 4,
        4): {(body a, body b): depth}."""
        self._fixed = None                 # every dynamic geometry moves here
        for k, g in enumerate(self.dynamic):
            self._set(g, Tg[k])
        hits: dict[tuple[int, int], float] = {}
        c, h = _aabb(Tg, self._aabb_c[self.dynamic], self._aabb_h[self.dynamic])
        a, b = self._dyn_pos[self.dd[:, 0]], self._dyn_pos[self.dd[:, 1]]
        body = self._geom_body
        over = np.all(np.abs(c[a] - c[b]) <= h[a] + h[b], axis=1)
        over &= ~allowed[body[self.dd[:, 0]], body[self.dd[:, 1]]]
        for k in np.nonzero(over)[0]:
            ga, gb = self.dd[k]
            if self._record(hits, ga, gb, self._depth(ga, gb)) and first_only:
                return hits
        if len(self.static):
            self._dyn_mgr.update()
            self._dyn_mgr.collide(self._static_mgr, None, self._callback(hits, allowed, first_only))
        return hits

    def _record(self, hits, ga: int, gb: int, depth: float | None) -> bool:
        if not self._counts(depth):
            return False
        key = tuple(sorted((int(self._geom_body[ga]), int(self._geom_body[gb]))))
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
            ga, gb = self._geom_ids[id(c.o1)], self._geom_ids[id(c.o2)]
            if allowed[self._geom_body[ga], self._geom_body[gb]]:
                return False
            if self.geoms[ga].hull is None and self.geoms[gb].hull is None:
                depth = abs(c.penetration_depth)
            else:
                depth = self._depth(ga, gb)
            return self._record(hits, ga, gb, depth) and first_only
        return cb

    def _report(self, hits: dict[tuple[int, int], float]) -> CollisionReport:
        pairs = sorted((self.bodies[a].name, self.bodies[b].name, float(d))
                       for (a, b), d in hits.items())
        return CollisionReport(not pairs, pairs)

    # -- batches and motions --------------------------------------------------------------------

    def check_batch(self, Q, poses=None, attached=None) -> np.ndarray:
        """Validity (B,) bool of states Q (B, n) sharing the object poses and held objects."""
        Q = self._Q(Q)
        key, (place, allowed) = self._placed(poses, attached)
        out = np.ones(len(Q), bool)
        if not len(Q):
            return out
        for start, bad in self._invalid_states(Q, place, allowed, first_state_only=False,
                                               key=key):
            out[start + bad] = False
        return out

    def check_batches(self, groups) -> list[np.ndarray]:
        """:meth:`check_batch` of several groups ``(Q, poses, attached)`` (states of different
        modes): the kinematics of all their states in shared calls (one per :data:`CHUNK`
        states, not one per group at least), the object poses' stages per group."""
        return self._batches([(Q, poses, attached, None) for Q, poses, attached in groups])

    def check_segments(self, groups) -> list[np.ndarray]:
        """Validity of motions given by their states: groups ``(Q, poses, attached, lens)``,
        ``Q`` the states of ``len(lens)`` motions one after another (``lens[i]`` states each);
        returns (len(lens),) bool per group, True when every state of the motion is free.
        Batched as :meth:`check_batches`, but exact fcl stops confirming a motion at its first
        colliding state and visits each motion's states in bisection order (middle first:
        where a straight motion most likely collides), so an invalid motion costs a few exact
        queries, not one per state. The answers are :meth:`check_batches`' states, reduced."""
        return self._batches(groups)

    def _batches(self, groups) -> list[np.ndarray]:
        groups = [(self._Q(Q) if len(Q) else np.zeros((0, self.model.dof)), poses, attached,
                   None if lens is None else np.asarray(lens, np.int64))
                  for Q, poses, attached, lens in groups]
        if self.first_pass() is None or len(groups) < 2:
            out = []
            for Q, poses, attached, lens in groups:
                ok = self.check_batch(Q, poses, attached) if lens is None else \
                    self._segments_ok(Q, poses, attached, lens, None)
                out.append(ok)
            return out
        allQ = np.concatenate([Q for Q, _, _, _ in groups])
        if not len(allQ):
            return [np.ones(0 if lens is None else len(lens), bool) for _, _, _, lens in groups]
        R, p = [], []
        for start in range(0, len(allQ), CHUNK):
            chunk = allQ[start:start + CHUNK]
            Rc, pc = self.kinematics(chunk)
            R.append(Rc)
            p.append(pc)
        R, p = np.concatenate(R, -1), np.concatenate(p, -1)
        out, at = [], 0
        for Q, poses, attached, lens in groups:
            frames = (R[..., at:at + len(Q)], p[..., at:at + len(Q)])
            if lens is not None:
                out.append(self._segments_ok(Q, poses, attached, lens, frames))
            else:
                ok = np.ones(len(Q), bool)
                if len(Q):
                    key, (place, allowed) = self._placed(poses, attached)
                    for start, bad in self._invalid_states(Q, place, allowed, False, key,
                                                           frames):
                        ok[start + bad] = False
                out.append(ok)
            at += len(Q)
        return out

    def _segments_ok(self, Q, poses, attached, lens, frames) -> np.ndarray:
        """Per motion (``lens`` states each, in Q in turn): no colliding state."""
        if lens.sum() != len(Q):
            raise ValueError(f"motion lengths sum to {lens.sum()}, not {len(Q)} states")
        seg = np.repeat(np.arange(len(lens)), lens)
        if not len(Q):
            return np.ones(len(lens), bool)
        dead = np.zeros(len(lens), bool)
        key, (place, allowed) = self._placed(poses, attached)
        ranks = _bisection_ranks(lens)
        for start, bad in self._invalid_states(Q, place, allowed, False, key, frames,
                                               (seg, ranks, dead)):
            dead[seg[start + bad]] = True
        return ~dead

    def check_motion(self, q0, q1, resolution: float = 0.02, poses=None,
                     attached=None, details: bool = True) -> MotionReport:
        """Check the straight motion q0 -> q1 (wrapping coordinates the short way round) at
        steps that move no coordinate more than ``resolution`` (rad or m); both ends included.
        ``details=False`` skips naming the colliding pairs (``report`` None): planners only need
        where the motion stops being valid."""
        if not (resolution > 0 and math.isfinite(resolution)):
            raise SceneError(error("E575", f"motion resolution {resolution} must be a finite "
                                   "number > 0", None, "e.g. 0.02 (rad or m per step)"))
        Q = self.interpolate(q0, q1, resolution)
        key, (place, allowed) = self._placed(poses, attached)
        for start, bad in self._invalid_states(Q, place, allowed, first_state_only=True,
                                               key=key):
            if len(bad):
                i = start + int(bad[0])
                if not details:
                    return MotionReport(False, i / (len(Q) - 1), None, len(Q) - 1)
                fpos, local, R, p = self.frames(Q[i:i + 1], place)
                hits = self._exact(_world(R[0], p[0], fpos, local), allowed, first_only=False)
                return MotionReport(False, i / (len(Q) - 1), self._report(hits), len(Q) - 1)
        return MotionReport(True, None, None, len(Q) - 1)

    def interpolate(self, q0, q1, resolution: float) -> np.ndarray:
        """States (N+1, n) of the motion q0 -> q1, N = ceil(max |step| / resolution)."""
        a, b = self._Q(q0, single=True)[0], self._Q(q1, single=True)[0]
        d = b - a
        w = self.model.wraps
        d[w] = (d[w] + math.pi) % (2 * math.pi) - math.pi
        n = max(1, int(math.ceil(np.abs(d).max() / resolution - 1e-12)))
        return a + np.linspace(0.0, 1.0, n + 1)[:, None] * d

    def interpolate_many(self, Q0, Q1, resolution: float,
                         ends: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The states of the motions Q0[i] -> Q1[i] (k, n each) one after another, and how many
        each has: :meth:`interpolate`'s states, the same numbers, without each motion's two
        end states unless ``ends``; in one numpy pass (a search's lookahead interpolates
        hundreds of edges a call: ~20 us each one by one)."""
        A, B = self._Q(Q0), self._Q(Q1)
        d = B - A
        w = self.model.wraps
        d[:, w] = (d[:, w] + math.pi) % (2 * math.pi) - math.pi
        n = np.maximum(1, np.ceil(np.abs(d).max(1, initial=0.0) / resolution - 1e-12)
                       ).astype(np.int64)
        cut = 0 if ends else 1
        lens = n + 1 - 2 * cut
        row = np.repeat(np.arange(len(n)), lens)
        first = np.cumsum(lens) - lens
        j = (np.arange(len(row)) - first[row] + cut).astype(float)
        frac = j * (1.0 / n)[row]                  # np.linspace's numbers, its last one exact
        frac[j == n[row]] = 1.0
        return A[row] + frac[:, None] * d[row], lens

    @property
    def first_pass_enabled(self) -> bool:
        return self._first_pass_enabled

    def first_pass(self):
        """The :class:`tmpc.runtime.collision.spheres.FirstPass` (built on first use), or None if off."""
        if self._first_pass is None and self._first_pass_enabled:
            self._first_pass = FirstPass(self)
        return self._first_pass

    def _invalid_states(self, Q, place, allowed, first_state_only: bool, key=None,
                        frames=None, motions=None):
        """Yield (chunk start, sorted indices of colliding states in the chunk); with
        ``first_state_only``, stop after the first colliding state. ``key``: the state's
        :meth:`_placed` key (its batch plan and fixed objects are then reused). ``frames``:
        the kinematics of Q, batch-last ``(R (F, 3, 3, B), p (F, 3, B))``, when known (the
        first pass only). ``motions``: ``(segment of each state, its bisection rank, dead
        segments)`` (:meth:`check_segments`): a state of a dead segment is not confirmed, and
        ``dead`` is updated as colliding states are found; the indices yielded are then only
        some of the colliding states, at least one per segment that has one."""
        fp = self.first_pass()
        if fp is None:
            for start in range(0, len(Q), CHUNK):
                fpos, local, R, p = self.frames(Q[start:start + CHUNK], place)
                bad = []
                for i in range(len(R)):
                    if motions is not None and motions[2][motions[0][start + i]]:
                        continue
                    if self._exact(_world(R[i], p[i], fpos, local), allowed, first_only=True):
                        bad.append(i)
                        if motions is not None:
                            motions[2][motions[0][start + i]] = True
                        if first_state_only:
                            break
                yield start, np.array(bad, np.int64)
                if bad and first_state_only:
                    return
            return
        plan = fp.plan(place, allowed, key)
        if self._constant_collision(plan, place, key):
            yield 0, np.arange(1 if first_state_only else len(Q))
            return
        for start in range(0, len(Q), CHUNK):
            cut = None if frames is None else \
                tuple(f[..., start:start + CHUNK] for f in frames)
            cand = fp.candidates(Q[start:start + CHUNK], plan, cut)
            part = None if motions is None else \
                tuple(m[start:start + CHUNK] for m in motions[:2]) + (motions[2],)
            bad = self._confirm(cand, plan, first_state_only, part)
            self.stats.add(len(cand.R[0, 0, 0]), cand, bad)
            yield start, bad
            if len(bad) and first_state_only:
                return

    def _constant_collision(self, plan, place, key=None) -> bool:
        """Set the world poses of objects that stay put in the batch; True if two of them
        collide (then every state of the batch is invalid). Nothing to do when they are set
        for this state already (``key``, :meth:`_placed`)."""
        if key is not None and self._fixed is not None and self._fixed[0] == key:
            return self._fixed[1]
        known = self._fixed_of.get(key) if key is not None else None
        frames, local = self.geom_frames(place) if known is None else known[:2]
        for k, g in enumerate(self.dynamic):
            if frames[k] < 0:
                self._set(g, local[k])
        if known is not None:
            hit = known[2]
        else:
            hit = any(self._counts(self._depth(ga, gb)) for ga, gb in plan.ff)
            if key is not None:
                if len(self._fixed_of) >= 256:
                    self._fixed_of.pop(next(iter(self._fixed_of)))
                self._fixed_of[key] = (frames, local, hit)
        self._fixed = None if key is None else (key, hit)
        return hit

    def _confirm(self, cand, plan, first_state_only: bool, motions=None) -> np.ndarray:
        """Exact fcl on the candidate pairs of the first pass; the sorted colliding states.

        The world transforms of every (moving geometry, state) the candidates name are computed
        at once in numpy; the loop only hands them to fcl, for the pairs it reaches (a state's
        remaining pairs are skipped after its first collision; a state's pairs are asked in
        the order of how often each pair was found colliding so far). ``motions``: the chunk's
        ``(segment, bisection rank)`` per state and the dead segments (:meth:`_invalid_states`):
        states are visited by rank, and a dead segment's are skipped.

        States with a pair the pass marked sure to collide (a mesh with a convex hull, one of
        whose hull vertices lies deeper than ``tolerance`` + :data:`~tmpc.runtime.collision.
        spheres.SURE_DEPTH` inside a box primitive) are colliding with no query. That is fcl's
        answer: qhull's hull vertices are vertices of the mesh, so a triangle of the mesh
        reaches into the solid box and fcl's mesh-box test touches; and any translation that
        separates the hull from the box moves that vertex out of it, so their penetration
        depth, the one :meth:`_depth` compares, is at least the vertex's depth. Box against box
        is left to fcl (its box test reports a contact point's depth, not the pair's)."""
        n = len(cand.states)
        if not n:
            return np.zeros(0, np.int64)
        G = len(self.geoms)
        if self._pair_tries is None:
            self._pair_tries = np.zeros((G, G), np.int64)
            self._pair_hits = np.zeros((G, G), np.int64)
        bad: list[int] = []
        if motions is not None:
            seg, rank, dead = motions
        # states certain to collide need no fcl call (nor do the rest of their segments); with
        # ``first_state_only`` the states before the first of them are still asked
        sure = np.unique(cand.states[cand.sure]) if cand.sure is not None else cand.states[:0]
        if len(sure):
            self.stats.sure += len(sure)
            if first_state_only:
                sure = sure[:1]
                keep = cand.states < sure[0]
            else:
                bad = sure.tolist()
                keep = ~np.isin(cand.states, sure)
                if motions is not None:
                    dead[seg[sure]] = True
            cand = cand.take(np.nonzero(keep)[0])
        if motions is not None:
            cand = cand.take(np.nonzero(~dead[seg[cand.states]])[0])
        likely = (self._pair_hits[cand.ga, cand.gb] + 1.0) / \
            (self._pair_tries[cand.ga, cand.gb] + 2.0)
        if motions is not None:
            order = np.lexsort((-likely, cand.states, rank[cand.states]))
        else:
            order = np.lexsort((-likely, cand.states))
        cand = cand.take(order)
        states = cand.states
        Rw, tw, slot = self._moving_poses(cand, plan)
        asked, hit = [], []
        cur, done, placed = -1, False, set()
        dead_of = None if motions is None else seg.tolist()
        for row, (st, a, b) in enumerate(zip(states.tolist(), cand.ga.tolist(),
                                             cand.gb.tolist())):
            if st != cur:
                cur, done, placed = st, False, set()
                if dead_of is not None and dead[dead_of[st]]:
                    done = True
            if done:
                continue
            for g, k in ((a, slot[row, 0]), (b, slot[row, 1])):
                if k >= 0 and g not in placed:
                    self._place(g, Rw[k], tw[k])
                    placed.add(g)
            asked.append(row)
            if self._counts(self._depth(a, b)):
                hit.append(row)
                bad.append(st)
                done = True
                if dead_of is not None:
                    dead[dead_of[st]] = True
                if first_state_only:
                    break
        if first_state_only and not bad and len(sure):
            bad = [int(sure[0])]
        self.stats.queries += len(asked)
        np.add.at(self._pair_tries, (cand.ga[asked], cand.gb[asked]), 1)
        np.add.at(self._pair_hits, (cand.ga[hit], cand.gb[hit]), 1)
        return np.unique(np.array(bad, np.int64))

    def _moving_poses(self, cand, plan):
        """World rotations and translations (Rw (k, 3, 3), tw (k, 3)) of the moving geometries
        of candidate rows, and per row and side the position there (``slot`` (n, 2), -1: the
        geometry does not move in the batch)."""
        mpos = np.full(len(self.geoms), -1, np.int64)
        mpos[plan.mv] = np.arange(len(plan.mv))
        pos = np.stack([mpos[cand.ga], mpos[cand.gb]], 1)                  # (n, 2), -1: fixed
        moving = pos >= 0
        i, s = pos[moving], np.broadcast_to(cand.states[:, None], pos.shape)[moving]
        f = plan.fpos[i]
        Rf = cand.R[f, :, :, s]                                          # (k, 3, 3)
        loc = plan.local[i]
        Rw = Rf @ loc[:, :3, :3]
        tw = (Rf @ loc[:, :3, 3, None])[..., 0] + cand.p[f, :, s]
        slot = np.full(pos.shape, -1, np.int64)
        slot[moving] = np.arange(len(i))
        return Rw, tw, slot

    def _Q(self, q, single: bool = False) -> np.ndarray:
        Q = np.asarray(q, float)
        if single and Q.ndim == 1:
            Q = Q[None]
        if Q.ndim != 2 or Q.shape[1] != self.model.dof or (single and len(Q) != 1) \
                or not np.isfinite(Q).all():
            want = f"({self.model.dof},)" if single else f"(B, {self.model.dof})"
            raise SceneError(error("E573", f"configuration of shape {np.shape(q)}; the robot "
                                   f"`{self.model.tree.name}` needs {want} finite values", None,
                                   "order: " + ", ".join(self.model.q_names[:6]) + ", ..."))
        return Q


# ---------------------------------------------------------------------------------------------
# helpers


def _bisection_ranks(lens: np.ndarray) -> np.ndarray:
    """For motions of ``lens`` states each (one after another): each state's place in its
    motion's bisection order (0: the middle state, then the middles of the two halves, ...)."""
    return np.concatenate([_bisection_order(int(n)) for n in lens]) if len(lens) else \
        np.zeros(0, np.int64)


@functools.lru_cache(maxsize=1024)
def _bisection_order(n: int) -> np.ndarray:
    rank = np.empty(n, np.int64)
    queue, k = collections.deque([(0, n)]), 0
    while queue:
        lo, hi = queue.popleft()
        if lo >= hi:
            continue
        mid = (lo + hi) // 2
        rank[mid], k = k, k + 1
        queue.append((lo, mid))
        queue.append((mid + 1, hi))
    rank.flags.writeable = False
    return rank


_JITTED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _jit_fk(model: RobotModel):
    """The jitted FK of a model, shared by every world built on it (XLA compiles once)."""
    if model not in _JITTED:
        _JITTED[model] = configured().jit(make_fk(model))
    return _JITTED[model]


def _world(R: np.ndarray, p: np.ndarray, fpos: np.ndarray, local: np.ndarray) -> np.ndarray:
    """World transforms (..., Gd, 4, 4) of geometries hanging on frames ``fpos`` of R/p."""
    Rf, pf = R[..., fpos, :, :], p[..., fpos, :]
    T = np.empty(Rf.shape[:-2] + (4, 4))
    T[..., :3, :3] = Rf @ local[:, :3, :3]
    T[..., :3, 3] = (Rf @ local[:, :3, 3, None])[..., 0] + pf
    T[..., 3, :] = (0.0, 0.0, 0.0, 1.0)
    return T


def _aabb(T: np.ndarray, c: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World AABBs (center, half-extents) of local boxes (c, h) moved by T (..., G, 4, 4)."""
    R = T[..., :3, :3]
    return (R @ c[..., None])[..., 0] + T[..., :3, 3], (np.abs(R) @ h[..., None])[..., 0]


def _matrix4(T, what: str) -> np.ndarray:
    M = np.asarray(T, float)
    if M.shape != (4, 4) or not np.isfinite(M).all():
        raise SceneError(error("E573", f"{what}: expected a finite 4x4 matrix, got shape "
                               f"{M.shape}", None, "use tmpc.compiler.robot.pose_matrix(pose)"))
    return M


def collision_world(world, compiled, tolerance: float = 0.0) -> CollisionWorld:
    """The collision checker of a loaded world (``compiled``: its
    :class:`~tmpc.compiler.compile.CompiledProgram`; without a robot model, no robot). Its
    kinematics is the compiled loop (:class:`~tmpc.runtime.collision.kinematics.Kinematics`).
    Every link mesh must load here (E562 names a missing one); kinematics alone does not need
    them."""
    model = robot_model(world.scene, strict_meshes=True) if compiled.model is not None else None
    return CollisionWorld(world.scene, model, tolerance=tolerance,
                          allowed=world.allowed_pairs())
