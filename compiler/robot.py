"""Forward kinematics, generated from a :class:`KinematicTree` as a JAX function.

``RobotModel`` fixes the configuration layout shared by the compiler and the runtime:
``q = [base_x, base_y, base_yaw]`` (only with a mobile base: the base's absolute planar pose in
the world) followed by the controllable joints in scene order. ``make_fk(model)`` returns ``fk(q: (n,)) -> T_world_frame: (F, 4, 4)`` for every
link frame; ``jax.vmap`` batches it. Joints that are not controllable stay at their scene values;
mimic joints follow their source joint. The function has no square roots or divisions, so its
gradients are finite everywhere.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from tmpc.compiler.cache import robot_tree
from tmpc.compiler.jaxcfg import configured
from tmpc.compiler.rotations import pose_matrix
from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.world import KinematicTree, Pose, RobotSpec, Scene

BASE_DOFS = ("base_x", "base_y", "base_yaw")


@dataclass(frozen=True, eq=False)
class RobotModel:
    tree: KinematicTree
    #: configuration coordinate names: base dofs (mobile base only), then controllable joints
    q_names: tuple[str, ...]
    lower: np.ndarray            # (n,)
    upper: np.ndarray            # (n,)
    #: coordinates that wrap around (base yaw, continuous joints)
    wraps: np.ndarray            # (n,) bool
    default_q: np.ndarray        # (n,) the scene's initial configuration
    #: values of all non-controllable, non-mimic movable joints
    fixed: dict[str, float]
    mobile_base: bool
    base_pose: Pose
    #: link names in the order of ``fk``'s output
    frames: tuple[str, ...]
    #: link or joint name -> frame index (a joint names its child link's frame, as tmit-star does)
    frame_index: dict[str, int] = field(default_factory=dict)

    @property
    def dof(self) -> int:
        return len(self.q_names)

    def frame(self, name: str) -> int | None:
        return self.frame_index.get(name)


def _suggest(name: str, choices) -> str:
    close = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.6)
    return f"did you mean `{close[0]}`?" if close else "see the URDF for joint names"


def build_robot_model(tree: KinematicTree, spec: RobotSpec,
                      bounds=((-10.0, 10.0), (-10.0, 10.0), (0.0, 3.0))) -> RobotModel:
    """The configuration layout for ``tree`` as the scene ``spec`` configures it."""
    joints = {j.name: j for j in tree.joints}
    movable = [j for j in tree.joints if j.movable and j.mimic is None]
    values = dict(spec.joint_values)
    for name in values:
        if name not in joints:
            raise SceneError(error("E564", f"the scene sets joint `{name}`, which the robot "
                                   f"`{tree.name}` ({tree.path}) does not have", None,
                                   _suggest(name, joints)))
    if spec.controllable is None:
        ctrl = [j.name for j in movable]
    else:
        ctrl = list(spec.controllable)
        for name in ctrl:
            j = joints.get(name)
            if j is None or not j.movable or j.mimic is not None:
                what = "does not have" if j is None else "has as a fixed or mimic joint"
                raise SceneError(error("E564", f"controllable joint `{name}`: the robot "
                                       f"`{tree.name}` {what} it", None, _suggest(name, joints)))
    names, lo, hi, wraps, q0 = [], [], [], [], []
    if spec.mobile_base:
        (xlo, xhi), (ylo, yhi) = bounds[0], bounds[1]
        x0, y0, _ = spec.base_pose.translation
        names += BASE_DOFS
        lo += [xlo, ylo, -math.pi]
        hi += [xhi, yhi, math.pi]
        wraps += [False, False, True]
        q0 += [x0, y0, base_yaw(spec.base_pose)]
    for name in ctrl:
        j = joints[name]
        cont = j.type == "continuous" or j.lower is None or j.upper is None
        jlo, jhi = (-math.pi, math.pi) if cont else (j.lower, j.upper)
        names.append(name)
        lo.append(jlo)
        hi.append(jhi)
        wraps.append(j.type == "continuous")
        q0.append(min(max(values.get(name, 0.0), jlo), jhi))
    fixed = {j.name: values.get(j.name, _clip0(j)) for j in movable if j.name not in ctrl}
    frames = tuple(lk.name for lk in tree.links)
    index = {n: i for i, n in enumerate(frames)}
    for j in tree.joints:
        index.setdefault(j.name, index[j.child])
    return RobotModel(tree, tuple(names), np.array(lo, float), np.array(hi, float),
                      np.array(wraps, bool), np.array(q0, float), fixed, spec.mobile_base,
                      spec.base_pose, frames, index)


def base_yaw(p: Pose) -> float:
    """Heading of a pose: the angle of its x axis in the world xy plane."""
    R = pose_matrix(p)
    return math.atan2(R[1, 0], R[0, 0])


def _clip0(j) -> float:
    lo = j.lower if j.lower is not None else -math.inf
    hi = j.upper if j.upper is not None else math.inf
    return min(max(0.0, lo), hi)


# ---------------------------------------------------------------------------------------------
# code generation


@dataclass(frozen=True)
class _Step:
    """One joint of the generated program."""

    parent: int
    child: int
    origin: np.ndarray
    kind: str            # fixed | revolute | prismatic
    axis: np.ndarray
    source: int          # index into q, or -1 (constant value)
    scale: float
    offset: float


def _program(model: RobotModel) -> list[_Step]:
    tree = model.tree
    frame = {n: i for i, n in enumerate(model.frames)}
    qidx = {n: i for i, n in enumerate(model.q_names)}
    joints = {j.name: j for j in tree.joints}
    steps = []
    for j in tree.joints:
        kind = "fixed" if not j.movable else ("prismatic" if j.type == "prismatic" else "revolute")
        src, scale, offset = -1, 0.0, 0.0
        if j.movable:
            name, scale, offset = j.name, 1.0, 0.0
            if j.mimic is not None:
                name, scale, offset = j.mimic.joint, j.mimic.multiplier, j.mimic.offset
            if name in qidx:
                src = qidx[name]
            else:
                offset = scale * model.fixed.get(name, _clip0(joints[name])) + offset
                scale = 0.0
        axis = np.asarray(j.axis, float)
        n = np.linalg.norm(axis)
        axis = axis / n if n > 0 else np.array([1.0, 0.0, 0.0])
        steps.append(_Step(frame[j.parent], frame[j.child], np.asarray(j.origin, float), kind,
                           axis, src, scale, offset))
    return steps


class Frames(NamedTuple):
    """World transforms of frames (a JAX pytree). ``R``: (..., F, 3, 3); ``p``: (..., F, 3)."""

    R: "object"
    p: "object"


def _mm(A, B):
    """(..., 3, 3) @ (..., 3, 3) as broadcast multiply-and-sum: XLA fuses this across a batch,
    where a batched dot_general of 3x3 blocks does not fuse on CPU."""
    return (A[..., :, :, None] * B[..., None, :, :]).sum(-2)


def _mv(A, v):
    return (A * v[..., None, :]).sum(-1)


def _prune(steps: list[_Step], wanted: set[int]) -> list[_Step]:
    """The steps on the paths from the root to the wanted frames, in order."""
    parent_step = {st.child: st for st in steps}
    keep: set[int] = set()
    for f in wanted:
        while f in parent_step and f not in keep:
            keep.add(f)
            f = parent_step[f].parent
    return [st for st in steps if st.child in keep]


def _root(model: RobotModel) -> tuple[int, np.ndarray, np.ndarray, float]:
    """The root frame's index, the scene's base pose (4, 4), and for a mobile base its tilt and
    height. A mobile base's q = (x, y, yaw) is its absolute planar pose; the scene base pose's
    height and any tilt (rotation other than yaw) stay fixed: T = Trans(x, y, z0) Rz(yaw) R_tilt."""
    base = pose_matrix(model.base_pose)
    yaw0 = base_yaw(model.base_pose)
    c0, s0 = math.cos(yaw0), math.sin(yaw0)
    tilt = np.array([[c0, s0, 0.0], [-s0, c0, 0.0], [0.0, 0.0, 1.0]]) @ base[:3, :3]
    return model.frames.index(model.tree.root), base, tilt, float(base[2, 3])


def make_fk(model: RobotModel, only=None):
    """``fk(q: (..., n)) -> Frames`` of every frame in ``model.frames`` (any leading batch
    shape; not jitted: wrap with ``jax.jit`` as needed).

    ``only`` (frame indices): compute just these frames and their ancestors; the others are NaN,
    so a kernel that reads a frame it was not built for cannot give a silently wrong answer.
    """
    jax = configured()
    jnp = jax.numpy
    steps = _program(model)
    if only is not None:
        steps = _prune(steps, set(only))
    root, base, tilt, z0 = _root(model)
    n_frames = len(model.frames)

    def root_frame(q):
        batch = q.shape[:-1]
        if not model.mobile_base:
            return (jnp.broadcast_to(jnp.asarray(base[:3, :3]), batch + (3, 3)),
                    jnp.broadcast_to(jnp.asarray(base[:3, 3]), batch + (3,)))
        c, s = jnp.cos(q[..., 2]), jnp.sin(q[..., 2])
        z, o = jnp.zeros_like(c), jnp.ones_like(c)
        Rb = jnp.stack([jnp.stack([c, -s, z], -1), jnp.stack([s, c, z], -1),
                        jnp.stack([z, z, o], -1)], -2)
        return _mm(Rb, jnp.asarray(tilt)), jnp.stack([q[..., 0], q[..., 1], z + z0], -1)

    def fk(q):
        q = jnp.asarray(q)
        Rs, ps = [None] * n_frames, [None] * n_frames
        Rs[root], ps[root] = root_frame(q)
        nan_R = jnp.full(q.shape[:-1] + (3, 3), jnp.nan)
        nan_p = jnp.full(q.shape[:-1] + (3,), jnp.nan)
        for st in steps:
            Rp, pp = Rs[st.parent], ps[st.parent]
            R = _mm(Rp, jnp.asarray(st.origin[:3, :3]))
            p = pp + _mv(Rp, jnp.asarray(st.origin[:3, 3]))
            if st.kind != "fixed":
                v = st.offset + (st.scale * q[..., st.source] if st.source >= 0 else 0.0)
                v = jnp.broadcast_to(jnp.asarray(v, q.dtype), q.shape[:-1])
                if st.kind == "prismatic":
                    p = p + _mv(R, jnp.asarray(st.axis)) * v[..., None]
                else:
                    # Rodrigues, R_j = I + sin(v) K + (1 - cos(v)) K^2: smooth, no division
                    kx, ky, kz = st.axis
                    K = np.array([[0.0, -kz, ky], [kz, 0.0, -kx], [-ky, kx, 0.0]])
                    R = R + _mm(R, jnp.asarray(K)) * jnp.sin(v)[..., None, None] + \
                        _mm(R, jnp.asarray(K @ K)) * (1.0 - jnp.cos(v))[..., None, None]
            Rs[st.child], ps[st.child] = R, p
        Rs = [nan_R if R is None else R for R in Rs]
        ps = [nan_p if p is None else p for p in ps]
        return Frames(jnp.stack(Rs, -3), jnp.stack(ps, -2))

    return fk


class FkTables(NamedTuple):
    """:func:`make_fk`'s program as arrays, for a compiled loop over it (the collision
    checker's kinematics, :mod:`tmpc.runtime.collision.pass_kernel`). Step k sets frame
    ``child[k]`` from frame ``parent[k]``: ``R = R_parent origin_R[k]``, ``p = p_parent +
    R_parent origin_p[k]``, then for ``kind`` 1 (revolute) the Rodrigues rotation by
    v = ``offset[k] + scale[k] q[source[k]]`` (no q term when ``source[k]`` < 0) about
    ``axis[k]``, for ``kind`` 2 (prismatic) a shift by v along it; kind 0 is fixed. The root
    frame is the fixed ``base_R``/``base_p``, or for a mobile base ``Rz(q[2]) tilt`` at
    (q[0], q[1], ``z0``). Frames in ``missing`` are reached by no step: NaN, as in
    :func:`make_fk`."""

    parent: np.ndarray       # (S,) int64
    child: np.ndarray        # (S,) int64
    origin_R: np.ndarray     # (S, 3, 3)
    origin_p: np.ndarray     # (S, 3)
    kind: np.ndarray         # (S,) int64
    axis: np.ndarray         # (S, 3)
    source: np.ndarray       # (S,) int64
    scale: np.ndarray        # (S,)
    offset: np.ndarray       # (S,)
    root: int
    mobile: bool
    base_R: np.ndarray       # (3, 3)
    base_p: np.ndarray       # (3,)
    tilt: np.ndarray         # (3, 3)
    z0: float
    missing: np.ndarray      # (M,) int64


_KINDS = {"fixed": 0, "revolute": 1, "prismatic": 2}


def fk_tables(model: RobotModel) -> FkTables:
    """:class:`FkTables` of a model (the same program and numbers as :func:`make_fk`)."""
    steps = _program(model)
    root, base, tilt, z0 = _root(model)
    child = np.array([st.child for st in steps], np.int64).reshape(-1)

    def rows(values, shape, dtype=float):
        return np.ascontiguousarray(np.array(values, dtype).reshape((len(steps),) + shape))

    return FkTables(
        rows([st.parent for st in steps], (), np.int64), child,
        rows([st.origin[:3, :3] for st in steps], (3, 3)),
        rows([st.origin[:3, 3] for st in steps], (3,)),
        rows([_KINDS[st.kind] for st in steps], (), np.int64),
        rows([st.axis for st in steps], (3,)),
        rows([st.source for st in steps], (), np.int64),
        rows([st.scale for st in steps], ()), rows([st.offset for st in steps], ()),
        root, bool(model.mobile_base), np.ascontiguousarray(base[:3, :3]),
        np.ascontiguousarray(base[:3, 3]), np.ascontiguousarray(tilt), z0,
        np.array(sorted(set(range(len(model.frames))) - set(child.tolist()) - {root}),
                 np.int64).reshape(-1))


def make_fk_frames(model: RobotModel):
    """``frames(Q: (B, n)) -> (R (F, 3, 3, B), p (F, 3, B))``: :func:`make_fk` of a batch,
    batch-last, the layout of the collision checker's kinematics (its numpy stages select the
    frames they need as contiguous rows and run over states along the last axis, instead of
    gathering from batch-first arrays). The checker itself runs the same program
    as a compiled loop (:func:`fk_tables`, :mod:`tmpc.runtime.collision.kinematics`); this
    JAX version is the artifact's ``fk/frames`` and the tests' reference."""
    jnp = configured().numpy
    fk = make_fk(model)

    def frames(Q):
        f = fk(Q)
        return jnp.transpose(f.R, (1, 2, 3, 0)), jnp.transpose(f.p, (1, 2, 0))

    return frames


def homogeneous(frames: Frames):
    """(..., F, 4, 4) matrices from :class:`Frames` (numpy or JAX arrays)."""
    R, p = np.asarray(frames.R), np.asarray(frames.p)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def robot_model(scene: Scene, strict_meshes: bool = False) -> RobotModel | None:
    """The scene's robot as a kinematic model (None without a robot). ``strict_meshes``: every
    link mesh must load (E562), as collision checking needs."""
    if scene.robot is None:
        return None
    tree = robot_tree(scene.robot.urdf, Path(scene.path).parent, strict_meshes=strict_meshes)
    return build_robot_model(tree, scene.robot, scene.bounds)
