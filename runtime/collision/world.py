"""Collision checking of robot states against a scene (python-fcl), exact and batched.

A :class:`CollisionWorld` builds every fcl object once (:mod:`tmpc.runtime.collision.build`): the
robot's link collision geometry (URDF primitives; meshes as ``fcl.BVHModel`` plus their convex
hull as ``fcl.Convex``), the scene objects, and a ``DynamicAABBTreeCollisionManager`` of the
static objects. A state is the robot configuration ``q`` (layout of :class:`RobotModel`),
optional world poses of movable objects and the held objects ``{obj: (frame, T_frame_obj)}`` (the
``held`` of a ``WorldState``).

What is checked (docs/collision.md): robot self-collision, robot vs objects, object vs object
except static vs static, held objects vs everything except the links of the hand holding them.
Allowed pairs (never checked) come from the URDF tree (adjacent links, rigidly joined links), the
SRDF beside the URDF, the ``allowed`` argument and the scene's ``allowed_collisions``.

One state is answered by exact fcl (:mod:`tmpc.runtime.collision.exact`: depths, tolerance);
``check_batch``, ``check_segments`` and ``check_motion`` (:mod:`tmpc.runtime.collision.motion`)
run a sound first pass on bounding volumes (:mod:`tmpc.runtime.collision.first_pass`) and
confirm only its candidate geometry pairs with fcl. This module is the facade.
"""

from __future__ import annotations

import math
import weakref
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from tmpc.compiler.jaxcfg import configured
from tmpc.compiler.robot import RobotModel, make_fk, robot_model
from tmpc.compiler.rotations import pose_matrix
from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.world import Scene, find_srdf
from tmpc.runtime.collision.batch import CHUNK, pad_batch
from tmpc.runtime.collision.build import WorldParts
from tmpc.runtime.collision.exact import DEPTH_EPS, CollisionReport, ExactChecker, world_transforms
from tmpc.runtime.collision.first_pass import FirstPass
from tmpc.runtime.collision.geometry import Body, Placement, geom_frames, srdf_disabled_pairs
from tmpc.runtime.collision.kinematics import Kinematics
from tmpc.runtime.collision.motion import BatchChecker, MotionReport, PassStats

__all__ = ["CHUNK", "DEPTH_EPS", "Body", "CollisionReport", "CollisionWorld", "MotionReport",
           "PassStats", "Placement", "collision_world", "find_srdf", "srdf_disabled_pairs"]


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
        if not (tolerance >= 0 and math.isfinite(tolerance)):
            raise SceneError(error("E572", f"penetration tolerance {tolerance} must be a finite "
                                   "number >= 0", None, "planet used 0.021 m, tmit-star 0.029 m"))
        self.scene, self.model, self.tolerance = scene, model, float(tolerance)
        #: batched kinematics, batch-last: ``frames`` (the JAX kernel,
        #: :func:`tmpc.compiler.robot.make_fk_frames`, padded by :meth:`kinematics`) or the
        #: compiled loop (:class:`tmpc.runtime.collision.kinematics.Kinematics`)
        self.fk_frames = frames if frames is not None else Kinematics(model)
        #: the world's bodies, geometries, scene placements and pairs (:mod:`tmpc.runtime.collision.build`)
        self.parts = parts = WorldParts(scene, model, allowed, srdf, attach_allowed)
        self.bodies, self.geoms, self.default_place = parts.bodies, parts.geoms, parts.default_place
        #: link name -> body (objects: :meth:`object_body`, by name without case)
        self.link_body = parts.link_body
        self.unmatched_allowed: tuple[str, ...] = parts.unmatched_allowed
        self.allowed = parts.allowed
        self.dynamic, self.static, self.dd, self.ds = parts.dynamic, parts.static, parts.dd, parts.ds
        #: body of each geometry, and each geometry's position in ``dynamic`` (-1: static)
        self.geom_body, self.dynamic_position = parts.geom_body, parts.dynamic_position
        #: what the first pass reads of this world
        self.geometry = parts.pass_geometry(self.tolerance)
        #: fcl's answers on one state (:mod:`tmpc.runtime.collision.exact`)
        self.exact = ExactChecker(parts, self.tolerance)
        self._first_pass_enabled = first_pass
        self._first_pass: FirstPass | None = None
        #: placements of recent states by content (batch and motion calls repeat them)
        self._placements: dict = {}
        #: batches, batched motions and motions (:mod:`tmpc.runtime.collision.motion`), with their counters
        self.batch = BatchChecker(self)

    @property
    def stats(self) -> PassStats:
        """Counters of the first pass over all batch and motion calls (for benchmarks)."""
        return self.batch.stats

    @stats.setter
    def stats(self, value: PassStats) -> None:
        self.batch.stats = value

    # -- one state ----------------------------------------------------------------------------

    def object_body(self, name: str, what: str = "object") -> int:
        b = self.parts.object_index.get(str(name).lower())
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
            place[b] = Placement(self.parts.frame_of(frame, f"attached `{name}`"),
                                 _matrix4(T, f"grasp of `{name}`"), held=True)
        for b, pl in place.items():
            if pl.held:
                if allowed is self.allowed:
                    allowed = self.allowed.copy()
                hand = self.parts.hand(pl.frame)
                allowed[b, hand] = allowed[hand, b] = True
        return place, allowed

    def placed(self, poses, attached):
        """(key, :meth:`placements`) of a state, remembered for the 256 most recent states:
        the key is the content of ``poses`` and ``attached``, so a caller may pass fresh or
        mutated dicts. Input :meth:`placements` rejects gets its error, uncached."""
        try:
            names = sorted(poses or {})
            held = sorted((attached or {}).items())
            # the poses' bytes in one array (a key of 34 objects, one by one, cost most of a
            # one-state check of Sort Clutter)
            key = (tuple(map(str, names)),
                   np.array([poses[n] for n in names], float).tobytes() if names else b"",
                   tuple((str(n), str(v[0]), np.asarray(v[1], float).tobytes())
                         for n, v in held))
        except (TypeError, ValueError, IndexError):
            return None, self.placements(poses, attached)
        got = self._placements.pop(key, None)
        if got is None:
            got = self.placements(poses, attached)
            if len(self._placements) >= 256:         # least recently used out
                self._placements.pop(next(iter(self._placements)))
        self._placements[key] = got
        return key, got

    def geom_frames(self, place: dict[int, Placement]) -> tuple[np.ndarray, np.ndarray]:
        """For the dynamic geometries: robot frame (-1: world) and T_frame_geom (Gd, 4, 4)."""
        return geom_frames(self.geometry, place)

    def check(self, q, poses=None, attached=None) -> CollisionReport:
        """Every colliding pair at configuration ``q`` (poses: world 4x4 of movable objects;
        attached: ``{object: (robot frame, T_frame_object)}``)."""
        Q = self.as_states(q, single=True)
        place, allowed = self.placements(poses, attached)
        fpos, local, R, p = self.frames(Q, place)
        hits = self.exact.exact(world_transforms(R[0], p[0], fpos, local), allowed, first_only=False)
        return self.exact.report(hits)

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

    def check_batch(self, Q, poses=None, attached=None) -> np.ndarray:
        """Validity (B,) bool of states Q (B, n) sharing the object poses and held objects."""
        return self.batch.check_batch(Q, poses, attached)

    def check_batches(self, groups) -> list[np.ndarray]:
        """:meth:`check_batch` of several groups ``(Q, poses, attached)`` (states of different
        modes): the kinematics of all their states in shared calls (one per :data:`CHUNK`
        states, not one per group at least), the object poses' stages per group."""
        return self.batch.check_batches(groups)

    def check_segments(self, groups) -> list[np.ndarray]:
        """Validity of motions given by their states: groups ``(Q, poses, attached, lens)``,
        ``Q`` the states of ``len(lens)`` motions one after another (``lens[i]`` states each);
        returns (len(lens),) bool per group, True when every state of the motion is free.
        Batched as :meth:`check_batches`, but exact fcl stops confirming a motion at its first
        colliding state and visits each motion's states in bisection order (middle first:
        where a straight motion most likely collides), so an invalid motion costs a few exact
        queries, not one per state. The answers are :meth:`check_batches`' states, reduced."""
        return self.batch.check_segments(groups)

    def check_motion(self, q0, q1, resolution: float = 0.02, poses=None,
                     attached=None, details: bool = True) -> MotionReport:
        """Check the straight motion q0 -> q1 (wrapping coordinates the short way round) at
        steps that move no coordinate more than ``resolution`` (rad or m); both ends included.
        ``details=False`` skips naming the colliding pairs (``report`` None): planners only need
        where the motion stops being valid."""
        return self.batch.check_motion(q0, q1, resolution, poses, attached, details)

    def interpolate(self, q0, q1, resolution: float) -> np.ndarray:
        """States (N+1, n) of the motion q0 -> q1, N = ceil(max |step| / resolution)."""
        a, b = self.as_states(q0, single=True)[0], self.as_states(q1, single=True)[0]
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
        hundreds of edges a call)."""
        A, B = self.as_states(Q0), self.as_states(Q1)
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
        """The :class:`tmpc.runtime.collision.first_pass.FirstPass` (built on first use), or None if off."""
        if self._first_pass is None and self._first_pass_enabled:
            self._first_pass = FirstPass(self.geometry, self.kinematics)
        return self._first_pass

    def as_states(self, q, single: bool = False) -> np.ndarray:
        """``q`` as states (B, n) of finite floats (``single``: exactly one); E573 otherwise."""
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



_JITTED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def jit_fk(model: RobotModel):
    """The jitted FK of a model, shared by every world built on it (XLA compiles once)."""
    if model not in _JITTED:
        _JITTED[model] = configured().jit(make_fk(model))
    return _JITTED[model]


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
