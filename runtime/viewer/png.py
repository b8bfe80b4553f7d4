"""The plan snapshot: a PNG of the whole scene at one state, drawn by a small
numpy z-buffer rasterizer (:func:`render`: perspective, flat shading like the page, 2x
supersampling) over a checkered floor, titled with the state's action; Pillow writes the file.

matplotlib's ``Poly3DCollection`` was tried first: its per-polygon depth sort drew a table top
over the thin tray lying on it, and subdividing faces to help it left seams.
"""

from __future__ import annotations

import io
import json
import math

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_bytes
from tmpc.lang.source import SourceFile
from tmpc.runtime.plans import Plan, parse_plan
from tmpc.runtime.validate import heading
from tmpc.runtime.viewer.scene import Poser, Scene3D

#: triangles per mesh file in the snapshot
PNG_FACES = 500
#: the camera looks from this angle (rad) relative to the robot's heading: behind, to its right
CAMERA_YAW = -2.2
BACKGROUND = (0.933, 0.941, 0.953)


def write_png(world, plan_dict, path, state_index: int | None = None,
              size: tuple[int, int] = (1200, 900)) -> None:
    """A PNG of the whole scene at one state (default: the last), ``size`` = (width, height)
    pixels, seen from the robot's front right and framed to show every object (a view of the
    robot and what was near it left the tables out of clutter's first state)."""
    plan = as_plan(plan_dict)
    n = len(plan.states)
    i = n - 1 if state_index is None else state_index
    if not -n <= i < n:
        raise InputError(error("E814", f"--state {state_index}: the plan has states 0 to "
                               f"{n - 1}", None))
    i %= n
    poser = Poser(world, PNG_FACES)
    states = poser.resolve(plan)
    st = states[i]
    P = poser.node_poses(st["links"], st["objects"])
    tris, cols = _triangles(poser.scene3d, P, set(range(len(poser.scene3d.nodes))))
    floor, fcols = _floor(tris)
    moved = _moved(world.scene, states)
    az, frame = heading(st["T_root"]) + CAMERA_YAW, tris
    elevation = math.radians(26)
    nodes = {poser.object_nodes[name] for name in moved if name in poser.object_nodes}
    if nodes:
        # frame what the plan moves, with a margin so its surroundings show, from the side
        # where the robot hides the least of it
        targets = [_triangles(poser.scene3d, P, {k})[0] for k in sorted(nodes)]
        robot, _ = _triangles(poser.scene3d, P, set(poser.link_nodes.values()))
        frame = _padded(np.concatenate(targets), 0.2)
        az = _clearest_azimuth(targets, robot, frame, size, az, elevation)
    img = render(np.concatenate([floor, tris]), np.concatenate([fcols, cols]), size, az,
                 elevation, frame=frame)
    labels = _labels(world.scene, poser, P, frame, size, az, elevation)
    _save_png(img, _png_title(plan, i, n), path, labels)


def _clearest_azimuth(targets, robot, frame, size, preferred: float, elevation: float) -> float:
    """Of 12 directions around, the one that shows most of the least visible of ``targets``
    (one triangle array per object) past the ``robot``'s triangles, by a small z-buffer of
    object ids; ties go to the direction nearest ``preferred``."""
    if not len(robot):
        return preferred
    small = (96, max(24, int(96 * size[1] / size[0])))
    tris = np.concatenate([robot, *targets])
    ids = np.concatenate([np.full(len(robot), -1)] +
                         [np.full(len(t), k) for k, t in enumerate(targets)])
    best = None
    for k in range(12):
        az = preferred + k * math.pi / 6
        cam = camera(frame.reshape(-1, 3), small, az, elevation)
        seen = _coverage(cam, tris, ids, len(targets))
        key = (-int(seen.min()), -int(seen.sum()), min(k, 12 - k))
        if best is None or key < best[0]:
            best = (key, az)
    return best[1]


def _coverage(cam: Camera, tris: np.ndarray, ids: np.ndarray, n: int) -> np.ndarray:
    """Pixels (n,) where each object id 0..n-1 is the nearest surface (id -1: occluders)."""
    W, H = cam.size
    sx, sy, cz = (a.reshape(-1, 3) for a in cam.project(tris.reshape(-1, 3)))
    # only what overlaps the objects on the picture can hide them
    t = ids >= 0
    lo_x, hi_x, lo_y, hi_y = sx[t].min(), sx[t].max(), sy[t].min(), sy[t].max()
    keep = (cz.min(1) > 1e-3) & (sx.max(1) >= lo_x) & (sx.min(1) <= hi_x) & \
        (sy.max(1) >= lo_y) & (sy.min(1) <= hi_y)
    sx, sy, cz, ids = sx[keep], sy[keep], cz[keep], ids[keep]
    zbuf, idbuf = np.zeros((H, W)), np.full((H, W), -1)
    for k, box, inside, depth in _fragments(sx, sy, cz, W, H):
        zb = zbuf[box]
        win = inside & (depth > zb)
        zb[win] = depth[win]
        idbuf[box][win] = ids[k]
    return np.bincount(idbuf[idbuf >= 0].ravel(), minlength=n)[:n]


def _moved(scene, states) -> list[str]:
    """Names of the scene objects whose pose changes along the plan."""
    out = []
    for o in scene.objects:
        poses = [s["objects"].get(o.name) for s in states]
        poses = [T for T in poses if T is not None]
        if len(poses) > 1 and any(not np.allclose(T, poses[0], atol=1e-6) for T in poses):
            out.append(o.name)
    return out


def _padded(tris: np.ndarray, margin: float) -> np.ndarray:
    """``tris`` plus a degenerate triangle at each corner of their box grown by ``margin``."""
    pts = tris.reshape(-1, 3)
    lo, hi = pts.min(0) - margin, pts.max(0) + margin
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    return np.concatenate([tris, np.repeat(corners[:, None], 3, 1)])


def _labels(scene, poser, P, frame, size, az, elevation) -> list[tuple[str, float, float]]:
    """(name, x, y) in pixels of every movable object's origin, where the camera of
    :func:`render` sees it (objects out of the picture left out); the tag goes beside it."""
    cam = camera(frame.reshape(-1, 3), size, az, elevation)
    out = []
    for o in scene.objects:
        node = poser.object_nodes.get(o.name)
        if not o.movable or node is None:
            continue
        x, y, z = cam.project(P[node][:3, 3][None])
        if z[0] > 1e-3 and 0 <= x[0] < size[0] and 0 <= y[0] < size[1]:
            out.append((o.name, float(x[0]), float(y[0])))
    return out


def _png_title(plan, i: int, n: int) -> str:
    st = plan.states[i]
    if st.action_text:
        return f"state {i} of {n - 1}: {st.action_text}"
    before = next((s.action_text for s in reversed(plan.states[:i]) if s.action_text), None)
    return f"state {i} of {n - 1}" + (f" (after {before})" if before else " (start)")


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


def render(tris: np.ndarray, cols: np.ndarray, size: tuple[int, int], azimuth: float,
           elevation: float, fov: float = math.radians(32), supersample: int = 2,
           frame: np.ndarray | None = None) -> np.ndarray:
    """A z-buffered perspective picture (H, W, 3) uint8 of triangles (T, 3, 3) with base colours
    (T, 3), flat-shaded like the page (two lights, ambient, a little headlight), seen from the
    direction (azimuth, elevation) at the distance that frames ``frame`` (default: all the
    triangles); anti-aliased by supersampling."""
    W, H = size[0] * supersample, size[1] * supersample
    pts = (tris if frame is None or not len(frame) else frame).reshape(-1, 3)
    cam = camera(pts, (W, H), azimuth, elevation, fov)
    eye = cam.eye
    sx, sy, cz = cam.project(tris.reshape(-1, 3))
    sx, sy, cz = sx.reshape(-1, 3), sy.reshape(-1, 3), cz.reshape(-1, 3)    # (T, 3) each
    keep = cz.min(1) > 1e-3
    tris, cols, sx, sy, cz = tris[keep], cols[keep], sx[keep], sy[keep], cz[keep]
    shade = _shade(tris, eye)
    rgb = np.clip(cols * shade[:, None], 0.0, 1.0)
    img = np.empty((H, W, 3))
    img[:] = BACKGROUND
    zbuf = np.zeros((H, W))                                      # 1/depth: larger is nearer
    for k, box, inside, depth in _fragments(sx, sy, cz, W, H):
        zb = zbuf[box]
        win = inside & (depth > zb)
        zb[win] = depth[win]
        img[box][win] = rgb[k]
    if supersample > 1:
        img = img.reshape(size[1], supersample, size[0], supersample, 3).mean((1, 3))
    return np.round(img * 255).astype(np.uint8)


class Camera:
    """A pinhole camera: ``eye``, its axes (``side``, ``up``, forward ``f``), the focal length
    in pixels and the picture's (W, H)."""

    def __init__(self, eye, side, up, f, focal: float, size: tuple[int, int]):
        self.eye, self.side, self.up, self.f, self.focal, self.size = eye, side, up, f, focal, size

    def project(self, points: np.ndarray):
        """Pixel coordinates (x, y) and depth z of world points (k, 3)."""
        rel = points - self.eye
        cx, cy, cz = rel @ self.side, rel @ self.up, rel @ self.f
        W, H = self.size
        z = np.where(np.abs(cz) > 1e-12, cz, 1e-12)
        return W / 2 + self.focal * cx / z, H / 2 - self.focal * cy / z, cz


def camera(pts: np.ndarray, size: tuple[int, int], azimuth: float, elevation: float,
           fov: float = math.radians(32)) -> Camera:
    """The camera looking from direction (azimuth, elevation) at the distance that frames the
    points (k, 3) in a picture of ``size`` = (W, H) pixels."""
    W, H = size
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
    return Camera(center - f * dist, side, up, f, (H / 2) / t, (W, H))


def _fragments(sx: np.ndarray, sy: np.ndarray, cz: np.ndarray, W: int, H: int):
    """The pixels of each triangle (screen corners ``sx``, ``sy`` and depths ``cz``, (T, 3)
    each) in a W x H picture: ``(k, box, inside, depth)`` with ``box`` the (rows, columns)
    slices of its bounding box, ``inside`` the pixels (centres) it covers there and ``depth``
    their interpolated 1/depth (larger is nearer)."""
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
        if inside.any():
            depth = w0 * inv[k, 0] + w1 * inv[k, 1] + w2 * inv[k, 2]
            yield k, (slice(y0[k], y1[k]), slice(x0[k], x1[k])), inside, depth


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


def _save_png(img: np.ndarray, title: str, path, labels=()) -> None:
    """Write ``img`` with ``title`` on a band at the top and ``labels`` ((text, x, y) pixels)
    on small white tags (Pillow), atomically."""
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
    try:
        small = ImageFont.load_default(size=max(11, H // 55))
    except TypeError:
        small = ImageFont.load_default()
    placed: list[tuple[float, float, float, float]] = []
    for text, x, y in sorted(labels, key=lambda lb: lb[2]):   # beside each object, top down
        b = draw.textbbox((0, 0), text, font=small)
        w, h = b[2] - b[0], b[3] - b[1]
        x0, y0 = x + 28, y - h / 2 - 3
        while any(x0 < r[2] and r[0] < x0 + w + 8 and y0 < r[3] and r[1] < y0 + h + 6
                  for r in placed):
            y0 += h + 8                     # below a tag already there
        placed.append((x0, y0, x0 + w + 8, y0 + h + 6))
        draw.line((x + 4, y, x0, y0 + h / 2 + 3), fill=(34, 34, 51, 160), width=1)
        draw.rectangle((x0, y0, x0 + w + 8, y0 + h + 6), fill=(255, 255, 255, 200))
        draw.text((x0 + 4 - b[0], y0 + 3 - b[1]), text, fill=(34, 34, 51), font=small)
    buf = io.BytesIO()
    im.save(buf, format="PNG", optimize=True)
    write_atomic_bytes(path, buf.getvalue())


def as_plan(plan_dict):
    """A :class:`tmpc.runtime.plans.Plan` of a plan or of its JSON (a dict)."""
    if isinstance(plan_dict, Plan):
        return plan_dict
    return parse_plan(SourceFile("<plan>", json.dumps(plan_dict)))


def write_atomic_bytes(path, data: bytes) -> None:
    """lang.fileio's atomic write; an unwritable place is E815, not a traceback."""
    try:
        atomic_write_bytes(path, data)
    except OSError as exc:
        raise InputError(error("E815", f"cannot write {path}: {exc.strerror or exc}", None)) \
            from None
