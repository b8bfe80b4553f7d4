"""`tmpc view INPUT PLAN.json [--html OUT.html] [--png OUT.png] [--state I]`: a plan as an
animated, self-contained HTML page and as a PNG snapshot.

**The page.** One HTML file with everything inline (no network at view time): the robot's visual
meshes (URDF ``<visual>`` elements loaded with trimesh; multi-material COLLADA files keep their
colours), the scene's objects, per-frame poses of every body, and a small WebGL2 renderer
(``assets/viewer.js``, ~300 lines: one vertex buffer per mesh, flat Lambert shading from
screen-space derivatives, per-frame model matrices, an orbit camera, a timeline with action
labels, play/pause, speed, keyboard stepping). It is written for tmpc rather than vendoring
three.js: three.js is large before any data, needs a licence header and package data, and a
plan viewer uses a tiny part of it (no materials, loaders, scene graph or post-processing); the
renderer here is a small part of a page, most of which is meshes and poses.

Meshes (:mod:`tmpc.runtime.viewer.scene`) are decimated by vertex clustering to at most
:data:`HTML_FACES` triangles per file and stored quantized (uint16 per coordinate over the mesh's
box, base64). Poses are computed with the validator's forward kinematics (pinocchio or yourdfpy) at
every state and at intermediate configurations along each straight motion (no coordinate moves more
than ``VIEW_STEP`` between two), positions as float32 and quaternions as int16; the page
interpolates linearly between these frames. Held objects ride on their frame (``mode.held``);
in a bare legacy array, objects are interpolated between the states' poses.

**The snapshot** (:mod:`tmpc.runtime.viewer.png`): a small numpy z-buffer rasterizer, Pillow
for the file.

Every output is written to a temporary file beside it and renamed into place.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.validate import heading, quat_from_matrix
from tmpc.runtime.viewer.png import (
    BACKGROUND,
    CAMERA_YAW,
    as_plan,
    render,
    write_atomic_bytes,
    write_png,
)
from tmpc.runtime.viewer.scene import Poser, decimate

#: triangles per mesh file in the page
HTML_FACES = 2500


# ---------------------------------------------------------------------------------------------
# the page


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def page_data(world, plan, title: str) -> dict:
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
    rot = np.array([[quat_from_matrix(T[:3, :3]) for T in frame] for frame in P]).reshape(
        len(P), len(s.nodes), 4)
    rot = np.round(rot * 32767).astype("<i2")
    bounds = [list(b) for b in world.scene.bounds]
    return {"title": title, "nodes": s.nodes, "meshes": meshes, "parts": parts,
            "frames": {"count": len(s.times), "t": _b64(np.asarray(s.times, "<f4")),
                       "pos": _b64(pos), "rot": _b64(rot)},
            "states": s.states, "bounds": bounds, "focus": _focus(P),
            "labels": [{"node": poser.object_nodes[o.name], "name": o.name}
                       for o in world.scene.objects if o.movable and o.name in poser.object_nodes],
            "yaw": round(_heading0(poser, plan) + CAMERA_YAW, 4)}


def _heading0(poser, plan) -> float:
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
        js = resources.files("tmpc.runtime.viewer").joinpath("assets/viewer.js").read_text(
            "utf-8")
    except (FileNotFoundError, OSError):
        raise InputError(error("E816", "the viewer's script (tmpc/runtime/viewer/assets/"
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
#help{position:fixed;right:12px;top:10px;font-size:12px;color:#556;text-align:right}
.objlabel{position:fixed;transform:translate(24px,-50%);pointer-events:none;font-size:12px;
background:rgba(255,255,255,.8);padding:0 4px;border-radius:3px;white-space:nowrap}"""

_UI = """<div id="hud"><h1>{title}</h1><div id="label"></div></div>
<div id="help">drag: orbit &middot; shift/right-drag: pan &middot; wheel: zoom<br>space: play/pause
&middot; &larr;/&rarr;: previous/next state</div>
<div id="bar"><button id="play">&#9654;</button><span id="time">0.0 s</span>
<div id="track"><input id="slider" type="range" min="0" max="1000" value="0"></div>
<select id="speed"><option value="0.5">0.5&times;</option><option value="1" selected>1&times;
</option><option value="2">2&times;</option><option value="4">4&times;</option></select></div>"""


def write_html(world, plan_dict, path) -> int:
    """Write the animated page of ``plan_dict`` (a tmpc-plan/1 dict, a bare state array, or a
    :class:`~tmpc.runtime.plans.read.Plan`) to ``path``; returns its size in bytes."""
    plan = as_plan(plan_dict)
    src = Path(world.config.path if world.config is not None else world.scene.path)
    name = f"{src.parent.name}/{src.name}" if src.parent.name else src.name
    text = html_page(page_data(world, plan, f"tmpc plan: {name} ({len(plan.states)} states, "
                                            f"{plan.action_count} actions)"))
    data = text.encode("utf-8")
    write_atomic_bytes(path, data)
    return len(data)


# ---------------------------------------------------------------------------------------------
# the snapshot


# ---------------------------------------------------------------------------------------------
# the command


__all__ = ["write_html", "write_png", "page_data", "decimate", "render",
           "BACKGROUND"]
