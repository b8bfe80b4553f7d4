"""`tmpc view INPUT PLAN.json [--html OUT.html] [--png OUT.png] [--state I]`: a plan as an
animated, self-contained HTML page and as a PNG snapshot.

**The page.** One HTML file with everything inline (no network at view time): the robot's visual
meshes (URDF ``<visual>`` elements loaded with trimesh; multi-material COLLADA files keep their
colours), the scene's objects, per-frame poses of every body, and a small WebGL2 renderer
(``viewer_assets/viewer.js``, ~300 lines: one vertex buffer per mesh, flat Lambert shading from
screen-space derivatives, per-frame model matrices, an orbit camera, a timeline with action
labels, play/pause, speed, keyboard stepping). It is written for tmpc rather than vendoring
three.js: three.js is ~700 kB minified before any data, needs a licence header and package data,
and a plan viewer uses a tiny part of it (no materials, loaders, scene graph or post-processing);
the page for the PR2 clutter plan is ~0.5 MB with the renderer under 20 kB.

Meshes are decimated by vertex clustering (a grid whose cell grows until the mesh has at most
:data:`HTML_FACES` triangles) and stored quantized (uint16 per coordinate over the mesh's box,
base64). Poses are computed here with the validator's forward kinematics (pinocchio or
yourdfpy, :mod:`.validate_kinematics`) at every state and at intermediate configurations along
each straight motion (no coordinate moves more than :data:`VIEW_STEP` between two), positions as
float32 and quaternions as int16; the page interpolates linearly between these frames. Held
objects ride on their frame (``mode.held``); in a bare legacy array, objects are interpolated
between the states' poses.

**The snapshot.** A small numpy z-buffer rasterizer (:func:`render`): the robot and the objects
near it at one state (coarser decimation), flat-shaded like the page, over a checkered floor,
2x supersampled, with the state's action as the title (Pillow writes the PNG). matplotlib's
``Poly3DCollection`` was tried first: its per-polygon depth sort draws a table top over the thin
tray lying on it, and subdividing faces to help it left seams.

Every output is written to a temporary file beside it and renamed into place.
"""

from __future__ import annotations

import base64
import json
import math
import os
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tmpc.lang.diagnostics import InputError, error

#: the most a coordinate (rad or m) moves between two animation frames
VIEW_STEP = 0.05
#: animation speed of motions (rad or m per second of the largest coordinate) and action pauses
SPEED, ACTION_SECONDS, MIN_MOTION_SECONDS = 0.6, 0.8, 0.3
#: at most this many animation frames (VIEW_STEP grows for longer plans)
MAX_FRAMES = 6000
#: triangle budgets per mesh for the page and the snapshot
HTML_FACES, PNG_FACES = 2500, 500
DEFAULT_COLOR = (0.72, 0.74, 0.78)
#: the cameras look from this angle (rad) relative to the robot's heading: behind, to its right
CAMERA_YAW = -2.2


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
    """The parts of a mesh file (one per material; COLLADA colours kept), scaled."""
    key = (str(path), tuple(scale))
    if key not in _LOADED:
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
        _LOADED[key] = parts
    return _LOADED[key]


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
    """A box (``size``: full extents), sphere or cylinder as triangles."""
    import trimesh
    if kind == "box":
        m = trimesh.creation.box(extents=size)
    elif kind == "sphere":
        m = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    else:
        m = trimesh.creation.cylinder(radius=radius, height=length, sections=28)
    return TriMesh(np.asarray(m.vertices, float), np.asarray(m.faces, np.int64))


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
        from .validate_kinematics import Kinematics, read_urdf, scene_defaults
        self.world, self.scene = world, world.scene
        spec = self.scene.robot
        self.desc = read_urdf(world.model.tree.path) if spec is not None else None
        self.kin = Kinematics(self.desc) if self.desc is not None else None
        self.mobile = bool(spec is not None and spec.mobile_base)
        from .plan_file import pose_matrix
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
                for g in self.desc.visual.get(link, []):
                    if link not in self.link_nodes:
                        self.link_nodes[link] = len(s.nodes)
                        s.nodes.append(link)
                    color = g.rgba[:3] if g.rgba is not None else None
                    for m in self._geom_meshes(g, faces):
                        if color is not None:
                            m = TriMesh(m.vertices, m.faces, tuple(color))
                        s.parts.append(Part(self.link_nodes[link], m, g.origin))
        self.object_nodes: dict[str, int] = {}
        for o in self.scene.objects:
            if o.shape is None:
                continue
            self.object_nodes[o.name] = len(s.nodes)
            s.nodes.append(o.name)
            for m in self._shape_meshes(o.shape, faces):
                s.parts.append(Part(len(s.nodes) - 1, TriMesh(m.vertices, m.faces,
                                                              object_color(o.name, o.movable)),
                                    np.eye(4)))

    def _geom_meshes(self, g, faces) -> list[TriMesh]:
        if g.kind == "mesh":
            return _decimated(load_visual(g.path, g.scale), faces)
        return [primitive(g.kind, g.size, g.radius, g.length)]

    def _shape_meshes(self, shape, faces) -> list[TriMesh]:
        if shape.kind == "box":
            return [primitive("box", tuple(2 * x for x in shape.size))]
        if shape.kind in ("sphere", "cylinder"):
            return [primitive(shape.kind, radius=shape.radius, length=shape.length)]
        return _decimated(load_visual(shape.mesh, shape.scale), faces)

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
        from .validate_kinematics import full_joint_values
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
        from .plan_file import pose_matrix
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
        from .validate_kinematics import straight_motion
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
        from .validate_kinematics import straight_motion
        return straight_motion(self.desc, self.mobile, a["values"], a["T_root"], b["values"],
                               b["T_root"]).span

    def _frame(self, t: float, links, objects) -> None:
        self.scene3d.times.append(t)
        self.scene3d.poses.append(self.node_poses(links, objects))


def _blend(A: np.ndarray, B: np.ndarray, a: float) -> np.ndarray:
    """Pose between A and B: translation linear, rotation along the shortest arc."""
    if np.allclose(A, B):
        return A
    from .validate_kinematics import quat_of, quat_matrix
    qa, qb = quat_of(A[:3, :3]), quat_of(B[:3, :3])
    if qa @ qb < 0:
        qb = -qb
    q = (1 - a) * qa + a * qb
    T = np.eye(4)
    T[:3, :3] = quat_matrix(q / np.linalg.norm(q))
    T[:3, 3] = (1 - a) * A[:3, 3] + a * B[:3, 3]
    return T


# ---------------------------------------------------------------------------------------------
# the page


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def page_data(world, plan, title: str) -> dict:
    from .validate_kinematics import quat_of
    poser = Poser(world, HTML_FACES)
    s = poser.animate(plan)
    meshes, parts = [], []
    index: dict[int, int] = {}
    for p in s.parts:
        key = id(p.mesh.vertices)
        if key not in index:
            v, f = p.mesh.vertices, p.mesh.faces
            lo, hi = v.min(0), v.max(0)
            q = np.round((v - lo) / np.maximum(hi - lo, 1e-12) * 65535).astype("<u2")
            big = len(v) > 65535
            meshes.append({"lo": lo.round(6).tolist(), "hi": hi.round(6).tolist(),
                           "v": _b64(q), "i": _b64(f.astype("<u4" if big else "<u2")),
                           "i32": big})
            index[key] = len(meshes) - 1
        parts.append({"node": p.node, "mesh": index[key],
                      "color": [round(float(c), 3) for c in p.mesh.color],
                      "T": [round(float(x), 6) for x in p.local.T.ravel()]})
    P = np.stack(s.poses) if s.poses else np.zeros((0, len(s.nodes), 4, 4))
    pos = P[..., :3, 3].astype("<f4")
    rot = np.array([[quat_of(T[:3, :3]) for T in frame] for frame in P]).reshape(
        len(P), len(s.nodes), 4)
    rot = np.round(rot * 32767).astype("<i2")
    bounds = [list(b) for b in world.scene.bounds]
    return {"title": title, "nodes": s.nodes, "meshes": meshes, "parts": parts,
            "frames": {"count": len(s.times), "t": _b64(np.asarray(s.times, "<f4")),
                       "pos": _b64(pos), "rot": _b64(rot)},
            "states": s.states, "bounds": bounds, "focus": _focus(P),
            "yaw": round(_heading0(poser, plan) + CAMERA_YAW, 4)}


def _heading0(poser, plan) -> float:
    from .validate_kinematics import heading
    b = plan.states[0].base
    return heading(b if b is not None else poser.T_base0)


def _focus(P: np.ndarray) -> list[float]:
    """Centre and radius of what moves (for the initial camera)."""
    if not len(P):
        return [0.0, 0.0, 0.5, 2.0]
    pts = P[..., :3, 3].reshape(-1, 3)
    lo, hi = np.percentile(pts, 2, axis=0), np.percentile(pts, 98, axis=0)
    c = (lo + hi) / 2
    return [round(float(x), 3) for x in c] + [round(float(max(np.linalg.norm(hi - lo) / 2,
                                                               0.8)), 3)]


def html_page(data: dict) -> str:
    from importlib import resources
    try:
        js = resources.files("tmpc.runtime").joinpath("viewer_assets/viewer.js").read_text(
            "utf-8")
    except (FileNotFoundError, OSError):
        raise InputError(error("E816", "the viewer's script (tmpc/runtime/viewer_assets/"
                               "viewer.js) is missing from this installation", None,
                               "reinstall tmpc; the file is package data")) from None
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    title = _escape(data["title"])
    return (f"<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">"
            f"<title>{title}</title>\n<style>{_CSS}</style></head>\n<body>\n"
            f"<canvas id=\"view\"></canvas>\n{_UI.format(title=title)}\n"
            f"<script id=\"plan-data\" type=\"application/json\">{payload}</script>\n"
            f"<script>\n{js}\n</script>\n</body></html>\n")


def _escape(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


_CSS = """html,body{margin:0;height:100%;overflow:hidden;background:#eef0f3;font:14px system-ui,
sans-serif;color:#223}canvas{display:block;width:100vw;height:100vh}#hud{position:fixed;left:12px;
top:10px;background:rgba(255,255,255,.85);padding:6px 10px;border-radius:6px;max-width:60vw}
#hud h1{font-size:15px;margin:0 0 2px}#label{font-family:ui-monospace,monospace;font-size:13px}
#bar{position:fixed;left:0;right:0;bottom:0;background:rgba(255,255,255,.9);padding:8px 12px;
display:flex;gap:10px;align-items:center}#bar button,#bar select{font:inherit}#track{flex:1;
position:relative;height:34px}#slider{width:100%;margin:0;position:absolute;top:16px}
.tick{position:absolute;top:0;width:2px;height:14px;background:#c33;cursor:pointer}
.tick:hover::after{content:attr(data-label);position:absolute;bottom:16px;left:-4px;
white-space:nowrap;background:#223;color:#fff;padding:2px 6px;border-radius:4px;font-size:12px}
#help{position:fixed;right:12px;top:10px;font-size:12px;color:#556;text-align:right}"""

_UI = """<div id="hud"><h1>{title}</h1><div id="label"></div></div>
<div id="help">drag: orbit &middot; shift/right-drag: pan &middot; wheel: zoom<br>space: play/pause
&middot; &larr;/&rarr;: previous/next state</div>
<div id="bar"><button id="play">&#9654;</button><span id="time">0.0 s</span>
<div id="track"><input id="slider" type="range" min="0" max="1000" value="0"></div>
<select id="speed"><option value="0.5">0.5&times;</option><option value="1" selected>1&times;
</option><option value="2">2&times;</option><option value="4">4&times;</option></select></div>"""


def write_html(world, plan_dict, path) -> int:
    """Write the animated page of ``plan_dict`` (a tmpc-plan/1 dict, a bare state array, or a
    :class:`~tmpc.runtime.plan_file.Plan`) to ``path``; returns its size in bytes."""
    plan = _as_plan(plan_dict)
    name = Path(world.scene.path).stem if world.config is None else Path(world.config.path).stem
    text = html_page(page_data(world, plan, f"tmpc plan: {name} ({len(plan.states)} states, "
                                            f"{plan.action_count} actions)"))
    data = text.encode("utf-8")
    _atomic_write(path, data)
    return len(data)


# ---------------------------------------------------------------------------------------------
# the snapshot


def write_png(world, plan_dict, path, state_index: int | None = None,
              size: tuple[int, int] = (1200, 900)) -> None:
    """A PNG of the robot and objects at one state (default: the last), ``size`` = (width,
    height) pixels: the robot and the objects near it, seen from its front right."""
    from .validate_kinematics import heading
    plan = _as_plan(plan_dict)
    n = len(plan.states)
    i = n - 1 if state_index is None else state_index
    if not -n <= i < n:
        raise InputError(error("E814", f"--state {state_index}: the plan has states 0 to "
                               f"{n - 1}", None))
    i %= n
    poser = Poser(world, PNG_FACES)
    st = poser.resolve(plan)[i]
    P = poser.node_poses(st["links"], st["objects"])
    tris, cols = _triangles(poser.scene3d, P, _near_robot(poser, P))
    floor, fcols = _floor(tris)
    az = heading(st["T_root"]) + CAMERA_YAW
    img = render(np.concatenate([floor, tris]), np.concatenate([fcols, cols]), size, az,
                 math.radians(26), frame=tris)
    _save_png(img, _png_title(plan, i, n), path)


def _png_title(plan, i: int, n: int) -> str:
    st = plan.states[i]
    if st.action_text:
        return f"state {i} of {n - 1}: {st.action_text}"
    before = next((s.action_text for s in reversed(plan.states[:i]) if s.action_text), None)
    return f"state {i} of {n - 1}" + (f" (after {before})" if before else " (start)")


def _near_robot(poser: "Poser", P: np.ndarray, margin: float = 1.0) -> set[int]:
    """Nodes to draw: the robot's, and objects within ``margin`` (xy) of the robot's box (all
    objects when there is no robot)."""
    s = poser.scene3d
    robot = set(poser.link_nodes.values())
    if not robot:
        return set(range(len(s.nodes)))
    pts = _part_points(s, P, robot)
    lo, hi = pts.min(0) - margin, pts.max(0) + margin
    keep = set(robot)
    for k in poser.object_nodes.values():
        q = _part_points(s, P, {k})
        if len(q) and np.all(q.max(0)[:2] >= lo[:2]) and np.all(q.min(0)[:2] <= hi[:2]):
            keep.add(k)
    return keep


def _part_points(s: "Scene3D", P: np.ndarray, nodes: set[int]) -> np.ndarray:
    pts = []
    for p in s.parts:
        if p.node in nodes:
            T = P[p.node] @ p.local
            pts.append(p.mesh.vertices @ T[:3, :3].T + T[:3, 3])
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def _triangles(s: Scene3D, P: np.ndarray, nodes: set[int]):
    """World triangles (T, 3, 3) and base colours (T, 3) of the parts of ``nodes``."""
    tris, cols = [], []
    for p in s.parts:
        if p.node in nodes:
            T = P[p.node] @ p.local
            v = p.mesh.vertices @ T[:3, :3].T + T[:3, 3]
            tris.append(v[p.mesh.faces])
            cols.append(np.broadcast_to(np.asarray(p.mesh.color, float), (len(p.mesh.faces), 3)))
    if not tris:
        return np.zeros((0, 3, 3)), np.zeros((0, 3))
    return np.concatenate(tris), np.concatenate(cols)


def _floor(tris: np.ndarray, n: int = 14):
    """A checkered floor under the drawn triangles (two triangles per tile)."""
    pts = tris.reshape(-1, 3) if len(tris) else np.zeros((1, 3))
    lo, hi = pts.min(0), pts.max(0)
    pad = 0.25 * max(float((hi - lo)[:2].max()), 1.0)
    xs = np.linspace(lo[0] - pad, hi[0] + pad, n + 1)
    ys = np.linspace(lo[1] - pad, hi[1] + pad, n + 1)
    z = min(0.0, lo[2]) - 1e-3
    out, cols = [], []
    for a in range(n):
        for b in range(n):
            p00, p10 = (xs[a], ys[b], z), (xs[a + 1], ys[b], z)
            p11, p01 = (xs[a + 1], ys[b + 1], z), (xs[a], ys[b + 1], z)
            c = (0.86, 0.87, 0.89) if (a + b) % 2 else (0.79, 0.8, 0.83)
            out += [(p00, p10, p11), (p00, p11, p01)]
            cols += [c, c]
    return np.array(out, float), np.array(cols, float)


BACKGROUND = (0.933, 0.941, 0.953)


def render(tris: np.ndarray, cols: np.ndarray, size: tuple[int, int], azimuth: float,
           elevation: float, fov: float = math.radians(32), supersample: int = 2,
           frame: np.ndarray | None = None) -> np.ndarray:
    """A z-buffered perspective picture (H, W, 3) uint8 of triangles (T, 3, 3) with base colours
    (T, 3), flat-shaded like the page (two lights, ambient, a little headlight), seen from the
    direction (azimuth, elevation) at the distance that frames ``frame`` (default: all the
    triangles); anti-aliased by supersampling."""
    W, H = size[0] * supersample, size[1] * supersample
    pts = (tris if frame is None or not len(frame) else frame).reshape(-1, 3)
    d = np.array([math.cos(elevation) * math.cos(azimuth),
                  math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])
    f = -d
    side = np.cross(f, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    up = np.cross(side, f)
    center = (pts.min(0) + pts.max(0)) / 2
    rel = pts - center
    x, y, z = rel @ side, rel @ up, rel @ f
    center = center + side * (x.max() + x.min()) / 2 + up * (y.max() + y.min()) / 2
    hx, hy = (x.max() - x.min()) / 2, (y.max() - y.min()) / 2
    t = math.tan(fov / 2)
    dist = max(hy / t, hx / (t * W / H)) * 1.08 - z.min()
    eye = center - f * dist
    rel = tris - eye
    cx, cy, cz = rel @ side, rel @ up, rel @ f                    # (T, 3) each
    keep = cz.min(1) > 1e-3
    tris, cols, cx, cy, cz = tris[keep], cols[keep], cx[keep], cy[keep], cz[keep]
    focal = (H / 2) / t
    sx, sy = W / 2 + focal * cx / cz, H / 2 - focal * cy / cz
    shade = _shade(tris, eye)
    rgb = np.clip(cols * shade[:, None], 0.0, 1.0)
    img = np.empty((H, W, 3))
    img[:] = BACKGROUND
    zbuf = np.zeros((H, W))                                      # 1/depth: larger is nearer
    inv = 1.0 / cz
    x0 = np.clip(np.floor(sx.min(1)), 0, W).astype(int)
    x1 = np.clip(np.ceil(sx.max(1)) + 1, 0, W).astype(int)
    y0 = np.clip(np.floor(sy.min(1)), 0, H).astype(int)
    y1 = np.clip(np.ceil(sy.max(1)) + 1, 0, H).astype(int)
    for k in np.nonzero((x1 > x0) & (y1 > y0))[0]:
        px = np.arange(x0[k], x1[k]) + 0.5
        py = (np.arange(y0[k], y1[k]) + 0.5)[:, None]
        (ax, bx, qx), (ay, by, qy) = sx[k], sy[k]
        area = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
        if abs(area) < 1e-12:
            continue
        w0 = ((bx - px) * (qy - py) - (by - py) * (qx - px)) / area
        w1 = ((qx - px) * (ay - py) - (qy - py) * (ax - px)) / area
        w2 = 1.0 - w0 - w1
        inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        if not inside.any():
            continue
        depth = w0 * inv[k, 0] + w1 * inv[k, 1] + w2 * inv[k, 2]
        zb = zbuf[y0[k]:y1[k], x0[k]:x1[k]]
        win = inside & (depth > zb)
        zb[win] = depth[win]
        img[y0[k]:y1[k], x0[k]:x1[k]][win] = rgb[k]
    if supersample > 1:
        img = img.reshape(size[1], supersample, size[0], supersample, 3).mean((1, 3))
    return np.round(img * 255).astype(np.uint8)


def _shade(tris: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """Per-face brightness: normals turned toward the eye, the page's two lights."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    v = eye - tris.mean(1)
    v /= np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12)
    n *= np.where((n * v).sum(1) < 0, -1.0, 1.0)[:, None]
    l1 = np.array([0.35, -0.45, 0.82])
    l2 = np.array([-0.6, 0.5, 0.35])
    l1, l2 = l1 / np.linalg.norm(l1), l2 / np.linalg.norm(l2)
    return 0.32 + 0.5 * np.maximum(n @ l1, 0) + 0.18 * np.maximum(n @ l2, 0) + \
        0.12 * np.maximum((n * v).sum(1), 0)


def _save_png(img: np.ndarray, title: str, path) -> None:
    """Write ``img`` with ``title`` on a band at the top (Pillow), atomically."""
    from PIL import Image, ImageDraw, ImageFont
    im = Image.fromarray(img)
    H = im.height
    draw = ImageDraw.Draw(im, "RGBA")
    try:
        font = ImageFont.load_default(size=max(12, H // 40))
    except TypeError:          # Pillow < 10.1: the fixed bitmap font
        font = ImageFont.load_default()
    box = draw.textbbox((0, 0), title, font=font)
    tw, th = box[2] - box[0], box[3] - box[1]
    band = th + 2 * max(6, H // 90)
    draw.rectangle((0, 0, im.width, band), fill=(255, 255, 255, 215))
    draw.text(((im.width - tw) / 2 - box[0], (band - th) / 2 - box[1]), title,
              fill=(34, 34, 51), font=font)
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent or Path("."))
    try:
        with os.fdopen(fd, "wb") as fh:
            im.save(fh, format="PNG", optimize=True)
        _publish(tmp, path)
    except BaseException:
        _unlink(tmp)
        raise


# ---------------------------------------------------------------------------------------------
# the command


def _as_plan(plan_dict):
    from .plan_file import Plan, parse_plan
    from tmpc.lang.source import SourceFile
    if isinstance(plan_dict, Plan):
        return plan_dict
    return parse_plan(SourceFile("<plan>", json.dumps(plan_dict)))


def _atomic_write(path, data: bytes) -> None:
    path = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent or Path("."))
    except OSError as exc:
        raise InputError(error("E815", f"cannot write {path}: {exc.strerror or exc}", None)) \
            from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        _publish(tmp, path)
    except BaseException:
        _unlink(tmp)
        raise


def _publish(tmp, path) -> None:
    """Rename ``tmp`` onto ``path`` with the permissions a new file gets (mkstemp's are 0600)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)


def _unlink(p) -> None:
    try:
        os.unlink(p)
    except OSError:
        pass


def run_view(args) -> int:
    from .plan_file import read_plan
    from .world import load_world
    if not args.html and not args.png:
        sys.stderr.write("tmpc view: give --html OUT.html and/or --png OUT.png\n")
        return 2
    plan = read_plan(args.plan)
    world = load_world(args.input, with_program=False)
    for out in (args.html, args.png):
        if out and not Path(out).resolve().parent.is_dir():
            raise InputError(error("E815", f"cannot write {out}: no such directory", None))
    if args.png:
        write_png(world, plan, args.png, args.state)
        sys.stderr.write(f"wrote {args.png}\n")
    if args.html:
        size = write_html(world, plan, args.html)
        sys.stderr.write(f"wrote {args.html} ({size / 1e6:.2f} MB)\n")
    return 0


__all__ = ["write_html", "write_png", "run_view", "page_data", "decimate"]
