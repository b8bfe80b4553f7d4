"""What the viewer draws: triangle meshes of the robot's visual elements and the scene's objects,
and the world pose of every body at each plan state and along each straight motion
(:class:`Poser`), from the validator's kinematics (:mod:`tmpc.runtime.validate.kinematics`).

Meshes are loaded with trimesh (COLLADA files keep one part per material and its colour), kept in
the cache as arrays (a warm page imports no trimesh), and decimated by vertex clustering
(:func:`decimate`) to a triangle budget per file.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tmpc.compiler.cache import cache_root, code_digest, package_version
from tmpc.lang.fileio import atomic_write_bytes
from tmpc.lang.world import dispatch_shape
from tmpc.runtime.plans import pose_matrix
from tmpc.runtime.validate import (
    Kinematics,
    full_joint_values,
    quat_from_matrix,
    quat_matrix,
    read_urdf,
    scene_defaults,
    straight_motion,
    urdf_path,
)

#: the most a coordinate (rad or m) moves between two animation frames
VIEW_STEP = 0.05
#: animation speed of motions (rad or m per second of the largest coordinate) and action pauses
SPEED, ACTION_SECONDS, MIN_MOTION_SECONDS = 0.6, 0.8, 0.3
#: at most this many animation frames (VIEW_STEP grows for longer plans)
MAX_FRAMES = 6000
DEFAULT_COLOR = (0.72, 0.74, 0.78)


# ---------------------------------------------------------------------------------------------
# meshes


@dataclass
class TriMesh:
    vertices: np.ndarray       # (V, 3) float
    faces: np.ndarray          # (F, 3) int
    color: tuple[float, float, float] = DEFAULT_COLOR


def decimate(v: np.ndarray, f: np.ndarray, max_faces: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertex clustering: merge the vertices in each cell of a grid (to their mean), dropping
    faces that collapse or repeat; the cell starts near sqrt(area / max_faces) and grows by 1.25x
    until at most ``max_faces`` remain."""
    if len(f) <= max_faces:
        return v, f
    lo = v.min(0)
    t = v[f]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum()
    cell = max(math.sqrt(area / max_faces), 1e-6)
    for _ in range(40):
        k = np.floor((v - lo) / cell).astype(np.int64)
        key = (k[:, 0] * (1 << 21) + k[:, 1]) * (1 << 21) + k[:, 2]
        _, inv = np.unique(key, return_inverse=True)
        n = int(inv.max()) + 1
        rep = np.zeros((n, 3))
        np.add.at(rep, inv, v)
        rep /= np.bincount(inv, minlength=n)[:, None]
        g = inv[f]
        g = g[(g[:, 0] != g[:, 1]) & (g[:, 1] != g[:, 2]) & (g[:, 0] != g[:, 2])]
        srt = np.sort(g, 1)
        _, first = np.unique((srt[:, 0] * (1 << 21) + srt[:, 1]) * (1 << 21) + srt[:, 2],
                             return_index=True)
        g = g[np.sort(first)]
        if len(g) <= max_faces:
            used, g = np.unique(g, return_inverse=True)
            return rep[used], g.reshape(-1, 3)
        cell *= 1.25
    return v, f


_LOADED: dict = {}


def load_visual(path: Path, scale) -> list[TriMesh]:
    """The parts of a mesh file (one per material; COLLADA colours kept), scaled: decoded by
    trimesh once, then read back from the cache (:func:`_cached`)."""
    key = (str(path), tuple(scale))
    if key not in _LOADED:
        try:
            data = Path(path).read_bytes()
        except OSError:     # an unreadable visual mesh is shown as nothing, not an error
            data = None
        _LOADED[key] = [] if data is None else _cached(
            ["file", Path(path).suffix.lower(), [float(x) for x in scale]], data,
            lambda: _decode(path, scale))
    return _LOADED[key]


def _decode(path: Path, scale) -> list[TriMesh]:
    import trimesh
    try:
        loaded = trimesh.load(str(path))
    except Exception:   # an unreadable visual mesh is shown as nothing, not an error
        loaded = None
    parts = []
    meshes = loaded.dump() if isinstance(loaded, trimesh.Scene) else \
        ([loaded] if isinstance(loaded, trimesh.Trimesh) else [])
    for m in meshes:
        if len(m.faces):
            parts.append(TriMesh(np.asarray(m.vertices, float) * np.asarray(scale),
                                 np.asarray(m.faces, np.int64), _mesh_color(m)))
    return parts


def _cached(key: list, data: bytes, make) -> list[TriMesh]:
    """``make()``'s meshes through the cache (``viewer/``, npz, no pickle), by ``key`` (JSON),
    ``data`` (a mesh file's contents), trimesh's version and tmpc's code: a warm page imports
    no trimesh. An entry that cannot be read is made again; nothing
    made (a file trimesh could not read: COLLADA without pycollada, say) is not kept."""
    h = hashlib.sha256(json.dumps([key, code_digest(), package_version("trimesh")]).encode())
    h.update(hashlib.sha256(data).digest())
    entry = cache_root() / "viewer" / f"mesh-{h.hexdigest()[:32]}.npz"
    try:
        with np.load(entry, allow_pickle=False) as z:
            return [TriMesh(np.asarray(z[f"v{i}"], float), np.asarray(z[f"f{i}"], np.int64),
                            tuple(float(c) for c in z[f"c{i}"])) for i in range(int(z["n"]))]
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        pass
    meshes = make()
    if not meshes:
        return meshes
    arrays = {"n": np.int64(len(meshes))}
    for i, m in enumerate(meshes):
        arrays.update({f"v{i}": np.asarray(m.vertices, float),
                       f"f{i}": np.asarray(m.faces, np.int64),
                       f"c{i}": np.asarray(m.color, float)})
    try:
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        entry.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(entry, buf.getvalue())
    except OSError:
        pass                # a read-only cache is fine: just slower
    return meshes


def _mesh_color(m) -> tuple[float, float, float]:
    try:
        vis = m.visual
        if getattr(vis, "kind", None) == "face" or getattr(vis, "kind", None) == "vertex":
            c = np.asarray(vis.face_colors if vis.kind == "face" else vis.vertex_colors)
            c = c[:, :3].mean(0) / 255.0
            return tuple(float(x) for x in c)
        mat = getattr(vis, "material", None)
        d = getattr(mat, "diffuse", None) if mat is not None else None
        if d is None and mat is not None:
            d = getattr(mat, "main_color", None)
        if d is not None:
            d = np.asarray(d, float)[:3]
            return tuple(float(x) for x in (d / 255.0 if d.max() > 1.0 else d))
    except Exception:   # colours are decoration; any odd material keeps the default
        pass
    return DEFAULT_COLOR


def _decimated(parts: list[TriMesh], faces: int) -> list[TriMesh]:
    """The parts of one mesh file decimated to ``faces`` triangles in all (shared in
    proportion to their sizes)."""
    total = sum(len(m.faces) for m in parts) or 1
    out = []
    for m in parts:
        v, f = decimate(m.vertices, m.faces, max(48, faces * len(m.faces) // total))
        out.append(TriMesh(v, f, m.color))
    return out


def primitive(kind: str, size=(), radius=0.0, length=0.0) -> TriMesh:
    """A box (``size``: full extents), sphere or cylinder as triangles (trimesh's, through the
    cache)."""
    create = dispatch_shape(_PRIMITIVE, kind, "a primitive's triangles")

    def make():
        m = create(size, radius, length)
        return [TriMesh(np.asarray(m.vertices, float), np.asarray(m.faces, np.int64))]
    key = ("primitive", kind, tuple(float(x) for x in size), float(radius), float(length))
    if key not in _LOADED:
        _LOADED[key] = _cached(list(key), b"", make)
    (m,) = _LOADED[key]
    return TriMesh(m.vertices, m.faces)


def _trimesh_box(size, radius, length):
    import trimesh
    return trimesh.creation.box(extents=size)


def _trimesh_sphere(size, radius, length):
    import trimesh
    return trimesh.creation.icosphere(subdivisions=2, radius=radius)


def _trimesh_cylinder(size, radius, length):
    import trimesh
    return trimesh.creation.cylinder(radius=radius, height=length, sections=28)


#: trimesh's primitives per kind (:func:`primitive`)
_PRIMITIVE = {"box": _trimesh_box, "sphere": _trimesh_sphere, "cylinder": _trimesh_cylinder}
#: a scene shape's triangles per kind (a box's size: half-extents)
_SHAPE_MESHES = {
    "box": lambda shape, faces: [primitive("box", tuple(2 * x for x in shape.size))],
    "sphere": lambda shape, faces: [primitive("sphere", radius=shape.radius,
                                              length=shape.length)],
    "cylinder": lambda shape, faces: [primitive("cylinder", radius=shape.radius,
                                                length=shape.length)],
    "mesh": lambda shape, faces: _decimated(load_visual(shape.mesh, shape.scale), faces),
}


#: colours of movable objects whose names name no colour, in scene order (distinct hues)
PALETTE = ((0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16),
           (0.58, 0.4, 0.74), (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.74, 0.74, 0.13),
           (0.09, 0.75, 0.81), (0.5, 0.5, 0.5))


def object_colors(scene) -> dict[str, tuple[float, float, float]]:
    """A colour per scene object: a name with a colour word keeps that colour (tmit-star's
    `blue_stick_1`), other movable objects take the next colour of :data:`PALETTE`, so each
    can be told apart; static ones are wood or grey."""
    out, k = {}, 0
    for o in scene.objects:
        named = _named_color(o.name)
        if named is None and o.movable:
            named, k = PALETTE[k % len(PALETTE)], k + 1
        out[o.name] = named or object_color(o.name, o.movable)
    return out


def _named_color(name: str):
    n = name.lower()
    for word, c in (("red", (0.85, 0.2, 0.18)), ("blue", (0.2, 0.4, 0.9)),
                    ("green", (0.2, 0.7, 0.3)), ("yellow", (0.95, 0.8, 0.2)),
                    ("orange", (0.95, 0.55, 0.15))):
        if word in n:
            return c
    return None


def object_color(name: str, movable: bool) -> tuple[float, float, float]:
    n = name.lower()
    for word, c in (("red", (0.85, 0.2, 0.18)), ("blue", (0.2, 0.4, 0.9)),
                    ("green", (0.2, 0.7, 0.3)), ("yellow", (0.95, 0.8, 0.2)),
                    ("orange", (0.95, 0.55, 0.15)), ("table", (0.62, 0.47, 0.33)),
                    ("bench", (0.62, 0.47, 0.33)), ("tray", (0.35, 0.37, 0.4)),
                    ("shelf", (0.6, 0.5, 0.4))):
        if word in n:
            return c
    return (0.85, 0.6, 0.3) if movable else (0.6, 0.6, 0.62)


# ---------------------------------------------------------------------------------------------
# what moves: bodies and their poses per frame


@dataclass
class Part:
    node: int                  # index into Scene3D.nodes
    mesh: TriMesh
    local: np.ndarray          # T_node_part


@dataclass
class Scene3D:
    """Bodies (robot links with visuals, objects), their parts, and poses per frame."""

    nodes: list[str] = field(default_factory=list)
    parts: list[Part] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    poses: list[np.ndarray] = field(default_factory=list)    # per frame (N, 4, 4)
    states: list[dict] = field(default_factory=list)         # {t, index, action, frame}


class Poser:
    """Resolves plan states against the world (joint defaults, base, objects, held) and computes
    world poses of every body, at states and along motions."""

    def __init__(self, world, faces: int):
        self.world, self.scene = world, world.scene
        spec = self.scene.robot
        self.desc = read_urdf(urdf_path(world.scene)) if spec is not None else None
        self.kin = Kinematics(self.desc) if self.desc is not None else None
        self.mobile = bool(spec is not None and spec.mobile_base)
        self.T_base0 = pose_matrix(spec.base_pose.translation, spec.base_pose.rotation) \
            if spec is not None else np.eye(4)
        self.defaults = scene_defaults(self.desc, spec)[0] if self.desc is not None else {}
        self.link_index = {n: i for i, n in enumerate(self.desc.links)} if self.desc else {}
        self.scene3d = Scene3D()
        self._build(faces)

    def _build(self, faces: int) -> None:
        s = self.scene3d
        self.link_nodes: dict[str, int] = {}
        if self.desc is not None:
            for link in self.desc.links:
                parts = self._link_parts(link, self.desc.visual.get(link, []), faces)
                if not parts:       # no visual, or none loadable (COLLADA without pycollada)
                    parts = self._link_parts(link, self.desc.collision.get(link, []), faces)
                if parts:
                    self.link_nodes[link] = len(s.nodes)
                    s.nodes.append(link)
                    s.parts += [Part(self.link_nodes[link], m, T) for m, T in parts]
        self.object_nodes: dict[str, int] = {}
        colors = object_colors(self.scene)
        for o in self.scene.objects:
            if o.shape is None:
                continue
            self.object_nodes[o.name] = len(s.nodes)
            s.nodes.append(o.name)
            for m in self._shape_meshes(o.shape, faces):
                s.parts.append(Part(len(s.nodes) - 1, TriMesh(m.vertices, m.faces,
                                                              colors[o.name]),
                                    np.eye(4)))

    def _link_parts(self, link: str, geoms, faces) -> list[tuple[TriMesh, np.ndarray]]:
        out = []
        for g in geoms:
            color = g.rgba[:3] if g.rgba is not None else None
            for m in self._geom_meshes(g, faces):
                if color is not None:
                    m = TriMesh(m.vertices, m.faces, tuple(color))
                out.append((m, g.origin))
        return out

    def _geom_meshes(self, g, faces) -> list[TriMesh]:
        if g.kind == "mesh":
            return _decimated(load_visual(g.path, g.scale), faces)
        return [primitive(g.kind, g.size, g.radius, g.length)]

    def _shape_meshes(self, shape, faces) -> list[TriMesh]:
        return dispatch_shape(_SHAPE_MESHES, shape, "a scene shape's triangles")(shape, faces)

    # ---- states ----------------------------------------------------------------------------
    def resolve(self, plan) -> list[dict]:
        """Per state: joint values, root pose, object world poses, held map, action."""
        out, prev = [], None
        for ps in plan.states:
            values = dict(self.defaults if prev is None else prev["values"])
            for name, v in ps.joints.items():
                j = self.desc.joint(name) if self.desc is not None else None
                if j is not None and j.movable and j.mimic is None:
                    values[name] = v
            T_root = ps.base if ps.base is not None else (self.T_base0 if prev is None else
                                                          prev["T_root"])
            st = {"values": values, "T_root": T_root, "action": ps.action_text,
                  "held": ps.mode_held, "index": ps.index}
            st["links"] = self.link_poses(T_root, values)
            objects = self._initial_objects(st) if prev is None else dict(prev["objects"])
            for name, T in ps.objects.items():
                o = self.scene.object(name)
                if o is not None:
                    objects[o.name] = T
            st["objects"] = objects
            out.append(st)
            prev = st
        return out

    def link_poses(self, T_root, values) -> np.ndarray:
        if self.kin is None:
            return np.zeros((0, 4, 4))
        return self.kin.poses(T_root, full_joint_values(self.desc, values))

    def frame_T(self, links: np.ndarray, objects: dict, name: str) -> np.ndarray | None:
        if self.desc is not None:
            link = name if name in self.link_index else (
                self.desc.joint(name).child if self.desc.joint(name) is not None else None)
            if link is not None:
                return links[self.link_index[link]]
        o = self.scene.object(name)
        return objects.get(o.name) if o is not None else None

    def _initial_objects(self, st) -> dict[str, np.ndarray]:
        out = {}
        robot = self.scene.robot
        for o in self.scene.objects:
            T = pose_matrix(o.pose.translation, o.pose.rotation)
            anchor, seen = o.parent, {o.name.lower()}
            while anchor is not None and self.scene.object(anchor) is not None \
                    and anchor.lower() not in seen:
                p = self.scene.object(anchor)
                seen.add(anchor.lower())
                T, anchor = pose_matrix(p.pose.translation, p.pose.rotation) @ T, p.parent
            if anchor is not None and robot is not None and anchor.lower() == robot.name.lower():
                T = st["T_root"] @ T
            elif anchor is not None:
                F = self.frame_T(st["links"], {}, anchor)
                T = F @ T if F is not None else T
            out[o.name] = T
        return out

    def node_poses(self, links: np.ndarray, objects: dict) -> np.ndarray:
        s = self.scene3d
        P = np.empty((len(s.nodes), 4, 4))
        for link, k in self.link_nodes.items():
            P[k] = links[self.link_index[link]]
        for name, k in self.object_nodes.items():
            P[k] = objects[name]
        return P

    # ---- the animation -----------------------------------------------------------------------
    def animate(self, plan) -> Scene3D:
        states = self.resolve(plan)
        total = sum(self._span(a, b) for a, b in zip(states, states[1:]) if a["action"] is None)
        step = max(VIEW_STEP, total / MAX_FRAMES)
        s = self.scene3d
        t = 0.0
        for i, st in enumerate(states):
            s.states.append({"t": round(t, 4), "index": st["index"], "action": st["action"],
                             "frame": len(s.times)})
            self._frame(t, st["links"], st["objects"])
            if i + 1 == len(states):
                break
            nxt = states[i + 1]
            if st["action"] is not None:
                t += ACTION_SECONDS
                continue
            m = straight_motion(self.desc, self.mobile, st["values"], st["T_root"],
                                nxt["values"], nxt["T_root"])
            dur = max(MIN_MOTION_SECONDS, m.span / SPEED)
            n = max(1, int(math.ceil(m.span / step)))
            held = st["held"] or {}
            carried = {}
            for o, p in held.items():
                F = self.frame_T(st["links"], st["objects"], p)
                obj = self.scene.object(o)
                if F is not None and obj is not None:
                    carried[obj.name] = (p, np.linalg.inv(F) @ st["objects"][obj.name])
            for k in range(1, n):
                a = k / n
                vals, T_root = m.at(a)
                links = self.link_poses(T_root, vals)
                objects = {name: _blend(st["objects"][name], nxt["objects"][name], a)
                           for name in st["objects"]}
                for name, (p, rel) in carried.items():
                    F = self.frame_T(links, objects, p)
                    if F is not None:
                        objects[name] = F @ rel
                self._frame(t + a * dur, links, objects)
            t += dur
        return s

    def _span(self, a, b) -> float:
        return straight_motion(self.desc, self.mobile, a["values"], a["T_root"], b["values"],
                               b["T_root"]).span

    def _frame(self, t: float, links, objects) -> None:
        self.scene3d.times.append(t)
        self.scene3d.poses.append(self.node_poses(links, objects))


def _blend(A: np.ndarray, B: np.ndarray, a: float) -> np.ndarray:
    """Pose between A and B: translation linear, rotation along the shortest arc."""
    if np.allclose(A, B):
        return A
    qa, qb = quat_from_matrix(A[:3, :3]), quat_from_matrix(B[:3, :3])
    if qa @ qb < 0:
        qb = -qb
    q = (1 - a) * qa + a * qb
    T = np.eye(4)
    T[:3, :3] = quat_matrix(q / np.linalg.norm(q))
    T[:3, 3] = (1 - a) * A[:3, 3] + a * B[:3, 3]
    return T
