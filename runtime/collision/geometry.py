"""Collision geometry from robot and scene descriptions: meshes (BVH + convex hull), fcl shapes,
and the robot pairs never checked (rigidly joined and adjacent links, SRDF-disabled pairs).
Used by :mod:`tmpc.runtime.collision.world`."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tmpc.compiler.meshes import mesh_arrays
from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.world import KinematicTree, Shape


@dataclass(frozen=True)
class MeshData:
    """A triangle mesh (scaled) and its convex hull, as numpy arrays."""

    vertices: np.ndarray        # (V, 3)
    faces: np.ndarray           # (T, 3) int
    hull_vertices: np.ndarray
    hull_faces: np.ndarray


_MESHES: dict[tuple[str, tuple[float, float, float]], MeshData] = {}


def load_mesh(path: Path, scale=(1.0, 1.0, 1.0), owner: str = "") -> MeshData:
    """Load (once per file and scale, and through the cache's arrays across runs) a mesh with
    trimesh. Raises E565 when it cannot be read."""
    key = (str(path), tuple(float(s) for s in scale))
    if key not in _MESHES:
        a = mesh_arrays(path, key[1], owner)
        _MESHES[key] = MeshData(a["vertices"], a["faces"], a["hull_vertices"], a["hull_faces"])
    return _MESHES[key]


@dataclass(eq=False)
class Geom:
    """One collision body part: ``shape`` at ``T_body_geom`` in its body (link or object)."""

    body: int
    shape: Shape
    T_body_geom: np.ndarray
    obj: object                  # fcl.CollisionObject
    hull: object | None          # fcl.CollisionObject of the convex hull (meshes only)
    aabb_center: np.ndarray      # local AABB in the geometry frame
    aabb_half: np.ndarray
    mesh: MeshData | None = None

    @property
    def narrow(self):
        """The fcl object the exact check uses: the convex hull of a mesh, else the shape."""
        return self.hull if self.hull is not None else self.obj


def _shape_problem(shape: Shape) -> str | None:
    if shape.kind == "box":
        return None if min(shape.size) > 0 else "box half-extents must be positive"
    if shape.kind == "sphere":
        return None if shape.radius > 0 else "sphere radius must be positive"
    if shape.kind == "cylinder":
        return None if shape.radius > 0 and shape.length > 0 else \
            "cylinder radius and length must be positive"
    if shape.kind == "mesh":
        return None if shape.mesh is not None else "mesh shape without a file"
    return f"unknown shape kind `{shape.kind}`"


def fcl_geometry(shape: Shape, owner: str):
    """``(geometry, hull or None, AABB center, AABB half-extents, MeshData or None)`` in the
    shape's own frame. Raises E574 for a degenerate shape."""
    import fcl
    bad = _shape_problem(shape)
    if bad is not None:
        raise SceneError(error("E574", f"{owner}: {bad}", None,
                               "shapes are box (half-extents), sphere, cylinder (radius, length) "
                               "or mesh"))
    zero = np.zeros(3)
    if shape.kind == "box":
        h = np.asarray(shape.size, float)
        return fcl.Box(*(2 * h)), None, zero, h, None
    if shape.kind == "sphere":
        return fcl.Sphere(shape.radius), None, zero, np.full(3, float(shape.radius)), None
    if shape.kind == "cylinder":
        return (fcl.Cylinder(shape.radius, shape.length), None, zero,
                np.array([shape.radius, shape.radius, shape.length / 2]), None)
    m = load_mesh(shape.mesh, shape.scale, owner)
    bvh = fcl.BVHModel()
    bvh.beginModel(len(m.vertices), len(m.faces))
    bvh.addSubModel(m.vertices, m.faces)
    bvh.endModel()
    hf = np.hstack([np.full((len(m.hull_faces), 1), 3), m.hull_faces]).ravel()
    hull = fcl.Convex(m.hull_vertices, len(m.hull_faces), hf)
    lo, hi = m.vertices.min(0), m.vertices.max(0)
    return bvh, hull, (lo + hi) / 2, (hi - lo) / 2, m


# ---------------------------------------------------------------------------------------------
# allowed pairs from the robot model


def rigid_groups(tree: KinematicTree) -> dict[str, int]:
    """link -> id of its rigid body (links joined by fixed joints share an id)."""
    parent = {lk.name: lk.name for lk in tree.links}

    def root(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for j in tree.joints:
        if not j.movable:
            parent[root(j.child)] = root(j.parent)
    ids: dict[str, int] = {}
    return {lk.name: ids.setdefault(root(lk.name), len(ids)) for lk in tree.links}


def adjacent_pairs(tree: KinematicTree) -> set[frozenset[str]]:
    """Pairs of links with geometry that are adjacent through one movable joint, across chains of
    fixed joints and geometry-less links, or rigidly joined (their relative pose never changes)."""
    has_geom = {lk.name for lk in tree.links if lk.collision}
    parent_of = {j.child: j for j in tree.joints}
    out: set[frozenset[str]] = set()
    for link in has_geom:
        movable, cur = 0, link
        while cur in parent_of:          # walk up to the first link with geometry
            j = parent_of[cur]
            movable += j.movable
            cur = j.parent
            if movable > 1:
                break
            if cur in has_geom:
                out.add(frozenset((link, cur)))
                break
    groups = rigid_groups(tree)
    by_group: dict[int, list[str]] = {}
    for link in sorted(has_geom):
        by_group.setdefault(groups[link], []).append(link)
    for members in by_group.values():
        out |= {frozenset((a, b)) for i, a in enumerate(members) for b in members[i + 1:]}
    return out


def srdf_disabled_pairs(path: Path) -> list[tuple[str, str]]:
    """``<disable_collisions link1= link2=>`` pairs of an SRDF. Raises E570 for bad XML."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise SceneError(error("E570", f"{path}: not a readable SRDF ({exc})", None,
                               "fix the XML or remove the file")) from None
    return [(e.get("link1", ""), e.get("link2", "")) for e in root.iter("disable_collisions")]
