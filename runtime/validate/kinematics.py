"""The validator's own robot model and forward kinematics, independent of :mod:`tmpc.compiler.robot`.

The URDF is read here with yourdfpy directly (not through :mod:`tmpc.lang.world.robot`'s tree; the
reading is kept in the cache, :func:`read_urdf`), and
link poses come from pinocchio (``buildModelFromUrdf`` + ``framesForwardKinematics``), the same
independent implementation ``tests/compiler/test_fk.py`` checks the JAX kinematics against. Without
pinocchio, a walk down the joint tree of this module's own description (``urdf``: each joint's
origin times its motion about its axis) stands in; yourdfpy's scene-graph kinematics
(``update_cfg`` / ``get_transform``, backend ``yourdfpy``) is the reference its tests hold it to.
The walk is preferred to yourdfpy's scene graph because it is much cheaper per state (a page
poses every body at every frame). All three are independent of the planner's generated JAX code.

The robot's root link is placed at a world pose given per state (the plan's ``base_pose``): the
validator never reconstructs it from (x, y, yaw) except to interpolate a motion
(:func:`planar_base`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tmpc.compiler.cache import package_version, urdf_entry

# Quaternion <-> matrix conversion is arithmetic, not kinematics: the validator shares numpy's
# one copy (tmpc.compiler.rotations imports numpy only, nothing of the planner or JAX) and
# re-exports it through tmpc.runtime.validate. Its forward kinematics (below) stays its own
# (pinocchio / yourdfpy), independent of tmpc.compiler.robot.
from tmpc.compiler.rotations import quat_matrix as quat_matrix
from tmpc.compiler.rotations import quat_from_matrix as quat_from_matrix
from tmpc.lang.fileio import atomic_write_text
from tmpc.lang.world import find_file, import_yourdfpy, load_urdf


@dataclass(frozen=True)
class UJoint:
    name: str
    type: str                   # revolute continuous prismatic fixed (floating/planar: rejected)
    parent: str
    child: str
    origin: np.ndarray          # (4, 4) T_parent_joint
    axis: np.ndarray            # (3,) unit
    lower: float | None
    upper: float | None
    mimic: tuple[str, float, float] | None    # (source joint, multiplier, offset)

    @property
    def movable(self) -> bool:
        return self.type in ("revolute", "continuous", "prismatic")


@dataclass(frozen=True)
class UGeom:
    """A collision or visual element: ``kind`` box (``size`` full extents), sphere, cylinder,
    mesh (``path``, ``scale``); ``origin`` T_link_geom; ``rgba`` for visuals."""

    kind: str
    origin: np.ndarray
    size: tuple[float, ...] = ()
    radius: float = 0.0
    length: float = 0.0
    path: Path | None = None
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    uri: str = ""
    rgba: tuple[float, float, float, float] | None = None


@dataclass
class RobotDescription:
    """A URDF as the validator reads it (yourdfpy, without tmpc's KinematicTree)."""

    path: str
    name: str
    root: str
    links: list[str]
    joints: list[UJoint]
    collision: dict[str, list[UGeom]] = field(default_factory=dict)
    visual: dict[str, list[UGeom]] = field(default_factory=dict)
    #: mesh URIs that could not be resolved to a file (collision elements left out)
    missing_meshes: list[str] = field(default_factory=list)

    def joint(self, name: str) -> UJoint | None:
        return self._joints.get(name)

    def __post_init__(self):
        self._joints = {j.name: j for j in self.joints}
        self.parent_joint = {j.child: j for j in self.joints}


def urdf_path(scene) -> str:
    """The resolved path of the scene's robot URDF (``package://`` and $TMPC_MESH_PATH), found
    without parsing it (none found: the loader's E560, saying where it looked)."""
    base = Path(scene.path).parent
    found = find_file(str(scene.robot.urdf), base)
    if found is None:
        return load_urdf(scene.robot.urdf, base, strict_meshes=False).path
    return str(found.resolve())


def read_urdf(path: str | Path) -> RobotDescription:
    """:func:`parse_urdf` through the cache (``viewer/``, JSON): importing yourdfpy and the
    trimesh it imports would dominate `tmpc run --html`'s own time. The key is the file's path and
    contents, the mesh search path, yourdfpy's version and tmpc's code; an entry naming a mesh
    file that is gone, or that cannot be read, is parsed again. A description with unresolved
    meshes is not kept (they may appear)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError:
        return parse_urdf(path)           # the parser says what is wrong
    entry = urdf_entry("viewer", path, data, package_version("yourdfpy"), prefix="urdf-")
    try:
        desc = _description_from_data(json.loads(entry.read_text("utf-8")))
        if all(g.path is None or g.path.is_file()
               for geoms in (*desc.collision.values(), *desc.visual.values()) for g in geoms):
            return desc
    except (OSError, ValueError, KeyError, TypeError, IndexError):
        pass
    load_urdf(str(path), path.parent, strict_meshes=False)    # tmpc's diagnostics for bad input
    desc = parse_urdf(path)
    if not desc.missing_meshes:
        try:
            entry.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_text(entry, json.dumps(_description_to_data(desc)))
        except OSError:
            pass                          # a read-only cache is fine: just slower
    return desc


def _geom_to_data(g: UGeom) -> dict:
    return {"kind": g.kind, "origin": g.origin.tolist(), "size": list(g.size),
            "radius": g.radius, "length": g.length,
            "path": None if g.path is None else str(g.path), "scale": list(g.scale),
            "uri": g.uri, "rgba": None if g.rgba is None else list(g.rgba)}


def _geom_from_data(d: dict) -> UGeom:
    return UGeom(str(d["kind"]), np.asarray(d["origin"], float).reshape(4, 4),
                 tuple(float(x) for x in d["size"]), float(d["radius"]), float(d["length"]),
                 None if d["path"] is None else Path(d["path"]),
                 tuple(float(x) for x in d["scale"]), str(d["uri"]),
                 None if d["rgba"] is None else tuple(float(x) for x in d["rgba"]))


def _description_to_data(desc: RobotDescription) -> dict:
    return {"path": desc.path, "name": desc.name, "root": desc.root, "links": desc.links,
            "joints": [{"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
                        "origin": j.origin.tolist(), "axis": j.axis.tolist(),
                        "lower": j.lower, "upper": j.upper,
                        "mimic": None if j.mimic is None else list(j.mimic)}
                       for j in desc.joints],
            "collision": {k: [_geom_to_data(g) for g in v] for k, v in desc.collision.items()},
            "visual": {k: [_geom_to_data(g) for g in v] for k, v in desc.visual.items()}}


def _description_from_data(d: dict) -> RobotDescription:
    def bound(x):
        return None if x is None else float(x)
    joints = [UJoint(str(j["name"]), str(j["type"]), str(j["parent"]), str(j["child"]),
                     np.asarray(j["origin"], float).reshape(4, 4),
                     np.asarray(j["axis"], float).reshape(3), bound(j["lower"]),
                     bound(j["upper"]),
                     None if j["mimic"] is None else (str(j["mimic"][0]), float(j["mimic"][1]),
                                                      float(j["mimic"][2])))
              for j in d["joints"]]
    desc = RobotDescription(str(d["path"]), str(d["name"]), str(d["root"]),
                            [str(x) for x in d["links"]], joints)
    desc.collision = {str(k): [_geom_from_data(g) for g in v] for k, v in d["collision"].items()}
    desc.visual = {str(k): [_geom_from_data(g) for g in v] for k, v in d["visual"].items()}
    return desc


def parse_urdf(path: str | Path) -> RobotDescription:
    """Read a resolved URDF file with yourdfpy; mesh URIs resolved as tmpc resolves them."""
    yourdfpy = import_yourdfpy()
    path = Path(path)
    urdf = yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)
    robot = urdf.robot
    materials = {m.name: m for m in (robot.materials or []) if m.name}
    joints = []
    for j in robot.joints:
        axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), float)
        n = np.linalg.norm(axis)
        lim = j.limit
        bounded = lim is not None and j.type != "continuous"
        lo = float(lim.lower) if bounded and lim.lower is not None else None
        hi = float(lim.upper) if bounded and lim.upper is not None else None
        mimic = None if j.mimic is None else (
            j.mimic.joint, float(1.0 if j.mimic.multiplier is None else j.mimic.multiplier),
            float(j.mimic.offset or 0.0))
        joints.append(UJoint(j.name, j.type, j.parent, j.child,
                             np.asarray(j.origin if j.origin is not None else np.eye(4), float),
                             axis / n if n > 0 else np.array([1.0, 0.0, 0.0]), lo, hi, mimic))
    children = {j.child for j in joints}
    links = [lk.name for lk in robot.links]
    root = next((n for n in links if n not in children), links[0])
    desc = RobotDescription(str(path), robot.name or path.stem, root, links, joints)
    for lk in robot.links:
        desc.collision[lk.name] = [g for g in (_geom(c, path.parent, desc, None, materials)
                                               for c in lk.collisions) if g is not None]
        desc.visual[lk.name] = [g for g in (_geom(v, path.parent, desc, v.material, materials)
                                            for v in lk.visuals) if g is not None]
    return desc


def _geom(el, base: Path, desc: RobotDescription, material, materials) -> UGeom | None:
    g = el.geometry
    T = np.asarray(el.origin if el.origin is not None else np.eye(4), float)
    rgba = None
    if material is not None:
        m = material if material.color is not None else materials.get(material.name)
        if m is not None and m.color is not None:
            rgba = tuple(float(c) for c in m.color.rgba)
    if g.box is not None:
        return UGeom("box", T, size=tuple(float(v) for v in g.box.size), rgba=rgba)
    if g.sphere is not None:
        return UGeom("sphere", T, radius=float(g.sphere.radius), rgba=rgba)
    if g.cylinder is not None:
        return UGeom("cylinder", T, radius=float(g.cylinder.radius),
                     length=float(g.cylinder.length), rgba=rgba)
    if g.mesh is not None:
        found = find_file(g.mesh.filename, base)
        if found is None:
            desc.missing_meshes.append(g.mesh.filename)
            return None
        s = g.mesh.scale
        scale = (1.0, 1.0, 1.0) if s is None else (
            tuple(float(v) for v in s) if hasattr(s, "__len__") else (float(s),) * 3)
        return UGeom("mesh", T, path=found, scale=scale, uri=g.mesh.filename, rgba=rgba)
    return None


# ---------------------------------------------------------------------------------------------
# joint values


def full_joint_values(desc: RobotDescription, values: dict[str, float]) -> dict[str, float]:
    """Every movable joint's value: ``values`` for the independent ones (missing: 0), mimic
    joints from their source (chains followed)."""
    out: dict[str, float] = {}

    def value(name: str, depth: int = 0) -> float:
        if name in out:
            return out[name]
        j = desc.joint(name)
        if j is not None and j.mimic is not None and depth < 32:
            src, mult, off = j.mimic
            v = mult * value(src, depth + 1) + off
        else:
            v = float(values.get(name, 0.0))
        out[name] = v
        return v
    for j in desc.joints:
        if j.movable:
            value(j.name)
    return out


def wrap_angle(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def planar_base(T0: np.ndarray, x: float, y: float, yaw: float) -> np.ndarray:
    """The base pose with T0's height and tilt, at (x, y) and heading ``yaw`` (the x axis's angle
    in the world xy plane)."""
    yaw0 = heading(T0)
    c, s = math.cos(yaw - yaw0), math.sin(yaw - yaw0)
    T = np.eye(4)
    T[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ T0[:3, :3]
    T[:3, 3] = (x, y, T0[2, 3])
    return T


def heading(T: np.ndarray) -> float:
    return math.atan2(T[1, 0], T[0, 0])


# ---------------------------------------------------------------------------------------------
# forward kinematics


class Kinematics:
    """``poses(T_world_root, values) -> (L, 4, 4)`` world poses of ``desc.links`` (in order);
    ``values``: every movable joint (see :func:`full_joint_values`)."""

    def __init__(self, desc: RobotDescription, backend: str | None = None):
        self.desc = desc
        self.index = {n: i for i, n in enumerate(desc.links)}
        if backend is None:
            try:
                import pinocchio  # noqa: F401
                backend = "pinocchio"
            except ImportError:
                backend = "urdf"
        self.backend = backend
        if backend == "pinocchio":
            self._init_pinocchio()
        elif backend == "yourdfpy":
            self._init_yourdfpy()
        else:
            self._init_urdf()

    def _init_pinocchio(self) -> None:
        import pinocchio as pin
        self._pin = pin
        self._model = pin.buildModelFromUrdf(self.desc.path)
        self._data = self._model.createData()
        self._frames = [self._model.getFrameId(n, pin.BODY) for n in self.desc.links]
        self._slots = []
        for jid in range(1, self._model.njoints):
            jm = self._model.joints[jid]
            self._slots.append((self._model.names[jid], jm.idx_q, jm.nq))
        self._q = pin.neutral(self._model)

    def _init_yourdfpy(self) -> None:
        yourdfpy = import_yourdfpy()
        self._urdf = yourdfpy.URDF.load(self.desc.path, build_scene_graph=True, load_meshes=False,
                                        build_collision_scene_graph=False,
                                        load_collision_meshes=False)

    def _init_urdf(self) -> None:
        """The joints parent before child (a walk from the root)."""
        below: dict[str, list[UJoint]] = {}
        for j in self.desc.joints:
            below.setdefault(j.parent, []).append(j)
        order, todo = [], [self.desc.root]
        while todo:
            for j in below.get(todo.pop(), ()):
                order.append(j)
                todo.append(j.child)
        self._order = order

    def _walk(self, values: dict[str, float], out: np.ndarray) -> None:
        """Root-relative link poses into ``out``, every movable joint at its value in
        ``values`` (:func:`full_joint_values`: mimic joints included; missing: 0, as with
        pinocchio); a link the walk does not reach stays at the root."""
        at = {self.desc.root: np.eye(4)}
        for j in self._order:
            M = j.origin
            if j.movable:
                v = values.get(j.name, 0.0)
                m = np.eye(4)
                if j.type == "prismatic":
                    m[:3, 3] = j.axis * v
                else:                               # Rodrigues: rotation by v about the axis
                    x, y, z = j.axis
                    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
                    m[:3, :3] += math.sin(v) * K + (1.0 - math.cos(v)) * (K @ K)
                M = M @ m
            at[j.child] = at[j.parent] @ M
        for k, name in enumerate(self.desc.links):
            out[k] = at.get(name, np.eye(4))

    def poses(self, T_root: np.ndarray, values: dict[str, float]) -> np.ndarray:
        out = np.empty((len(self.desc.links), 4, 4))
        if self.backend == "urdf":
            self._walk(values, out)
        elif self.backend == "pinocchio":
            q = self._q.copy()
            for name, i, nq in self._slots:
                v = values.get(name, 0.0)
                if nq == 2:
                    q[i], q[i + 1] = math.cos(v), math.sin(v)
                else:
                    q[i] = v
            self._pin.framesForwardKinematics(self._model, self._data, q)
            oMf = self._data.oMf
            for k, fid in enumerate(self._frames):
                out[k] = oMf[fid].homogeneous
        else:
            u = self._urdf
            u.update_cfg({n: values.get(n, 0.0) for n in u.actuated_joint_names})
            for k, name in enumerate(self.desc.links):
                out[k] = u.get_transform(name, self.desc.root)
        return np.einsum("ij,ljk->lik", T_root, out)


# ---------------------------------------------------------------------------------------------
# the scene's start and straight motions


def scene_defaults(desc: RobotDescription, spec) -> tuple[dict[str, float], set[str]]:
    """(value of every independent movable joint at the scene's start, the controllable ones).
    Controllable joints are clipped into their limits (continuous ones into [-pi, pi]); others
    keep the scene's value (unset: 0 clipped into the limits)."""
    given = dict(spec.joint_values)
    free = [j for j in desc.joints if j.movable and j.mimic is None]
    ctrl = set(spec.controllable) if spec.controllable is not None else {j.name for j in free}
    out = {}
    for j in free:
        lo = j.lower if j.lower is not None else -math.inf
        hi = j.upper if j.upper is not None else math.inf
        if j.name in ctrl and (j.type == "continuous" or j.lower is None or j.upper is None):
            lo, hi = -math.pi, math.pi
        v = given.get(j.name, 0.0)
        out[j.name] = min(max(v, lo), hi) if (j.name in ctrl or j.name not in given) else v
    return out, ctrl


def joint_delta(desc: RobotDescription | None, name: str, b: float, a: float) -> float:
    """b - a; continuous joints the short way round."""
    j = desc.joint(name) if desc is not None else None
    return wrap_angle(b - a) if j is not None and j.type == "continuous" else b - a


@dataclass
class Motion:
    """The straight configuration-space motion between two (joint values, root pose) pairs: joints
    linearly (continuous ones the short way), a mobile base in x, y and heading (the short way),
    keeping the first pose's height and tilt. ``span``: the largest coordinate change."""

    names: list[str]
    start: np.ndarray
    delta: np.ndarray
    T0: np.ndarray
    base: np.ndarray             # (x, y, heading) at the start
    base_delta: np.ndarray
    mobile: bool
    span: float

    def at(self, t: float) -> tuple[dict[str, float], np.ndarray]:
        values = dict(zip(self.names, self.start + t * self.delta))
        if not self.mobile:
            return values, self.T0
        x, y, h = self.base + t * self.base_delta
        return values, planar_base(self.T0, x, y, h)


def straight_motion(desc, mobile: bool, va: dict, Ta: np.ndarray, vb: dict,
                    Tb: np.ndarray, short_way: bool = True) -> Motion:
    """``short_way``: continuous joints the short way round (tmpc, planet); False: linearly
    in value, as tmit-star interpolates them (its cspace.cc)."""
    names = sorted(set(va) | set(vb))
    start = np.array([va.get(n, 0.0) for n in names])
    delta = np.array([joint_delta(desc, n, vb.get(n, 0.0), va.get(n, 0.0)) if short_way
                      else vb.get(n, 0.0) - va.get(n, 0.0) for n in names])
    base = np.array([Ta[0, 3], Ta[1, 3], heading(Ta)])
    bd = np.array([Tb[0, 3] - Ta[0, 3], Tb[1, 3] - Ta[1, 3], wrap_angle(heading(Tb) - base[2])]) \
        if mobile else np.zeros(3)
    span = float(max(np.abs(delta).max(initial=0.0), np.abs(bd).max()))
    return Motion(names, start, delta, Ta, base, bd, mobile, span)
