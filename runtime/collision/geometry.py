"""Collision geometry of a world: bodies, their geometries and fcl shapes, and the robot pairs never checked.

Meshes are loaded once per file and scale (a BVH and its convex hull); the never-checked robot
pairs are the rigidly joined and adjacent links and the SRDF's disabled pairs.
:class:`PassGeometry` is what the first pass (:mod:`tmpc.runtime.collision.first_pass`) and the
pair tables read of a built world. Used by :mod:`tmpc.runtime.collision.build`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tmpc.compiler.meshes import mesh_arrays
from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.world import KinematicTree, Shape, ShapeKindError, dispatch_shape

if TYPE_CHECKING:
    from tmpc.compiler.robot import RobotModel


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


#: what makes a shape of each kind degenerate (None: nothing)
_PROBLEM = {
    "box": lambda shape: None if min(shape.size) > 0 else "box half-extents must be positive",
    "sphere": lambda shape: None if shape.radius > 0 else "sphere radius must be positive",
    "cylinder": lambda shape: None if shape.radius > 0 and shape.length > 0 else
    "cylinder radius and length must be positive",
    "mesh": lambda shape: None if shape.mesh is not None else "mesh shape without a file",
}


def _shape_problem(shape: Shape) -> str | None:
    try:
        return dispatch_shape(_PROBLEM, shape, "a collision shape")(shape)
    except ShapeKindError:
        return f"unknown shape kind `{shape.kind}`"


def fcl_geometry(shape: Shape, owner: str):
    """``(geometry, hull or None, AABB center, AABB half-extents, MeshData or None)`` in the
    shape's own frame. Raises E574 for a degenerate shape."""
    bad = _shape_problem(shape)
    if bad is not None:
        raise SceneError(error("E574", f"{owner}: {bad}", None,
                               "shapes are box (half-extents), sphere, cylinder (radius, length) "
                               "or mesh"))
    return dispatch_shape(_FCL, shape, "fcl geometry")(shape, owner)


def _fcl_box(shape: Shape, owner: str):
    import fcl
    h = np.asarray(shape.size, float)
    return fcl.Box(*(2 * h)), None, np.zeros(3), h, None


def _fcl_sphere(shape: Shape, owner: str):
    import fcl
    return fcl.Sphere(shape.radius), None, np.zeros(3), np.full(3, float(shape.radius)), None


def _fcl_cylinder(shape: Shape, owner: str):
    import fcl
    return (fcl.Cylinder(shape.radius, shape.length), None, np.zeros(3),
            np.array([shape.radius, shape.radius, shape.length / 2]), None)


def _fcl_mesh(shape: Shape, owner: str):
    import fcl
    m = load_mesh(shape.mesh, shape.scale, owner)
    bvh = fcl.BVHModel()
    bvh.beginModel(len(m.vertices), len(m.faces))
    bvh.addSubModel(m.vertices, m.faces)
    bvh.endModel()
    hf = np.hstack([np.full((len(m.hull_faces), 1), 3), m.hull_faces]).ravel()
    hull = fcl.Convex(m.hull_vertices, len(m.hull_faces), hf)
    lo, hi = m.vertices.min(0), m.vertices.max(0)
    return bvh, hull, (lo + hi) / 2, (hi - lo) / 2, m


_FCL = {"box": _fcl_box, "sphere": _fcl_sphere, "cylinder": _fcl_cylinder, "mesh": _fcl_mesh}


# ---------------------------------------------------------------------------------------------
# bodies and where they are


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


@dataclass(frozen=True, eq=False)
class PassGeometry:
    """What the first pass and the pair tables read of a built collision world: its bodies and
    geometries and the geometry pairs to check (index arrays into ``geoms``)."""

    model: "RobotModel | None"
    bodies: list[Body]
    geoms: list[Geom]
    geom_body: np.ndarray        # (G,) body of each geometry
    dynamic: np.ndarray          # (Gd,) geometries whose body may move
    static: np.ndarray           # (Gs,) the others
    dynamic_position: np.ndarray  # (G,) position of each geometry in ``dynamic``, -1: static
    dd: np.ndarray               # (P, 2) dynamic-dynamic pairs, allowed ones left out
    ds: np.ndarray               # (Q, 2) dynamic-static pairs, allowed ones left out
    tolerance: float             # penetration depth that counts (m)

    def is_link(self, g: int) -> bool:
        """Geometry g belongs to a robot link."""
        return self.bodies[self.geoms[g].body].kind == "link"


def geom_frames(geometry: PassGeometry,
                place: dict[int, Placement]) -> tuple[np.ndarray, np.ndarray]:
    """For the dynamic geometries: robot frame (-1: world) and T_frame_geom (Gd, 4, 4)."""
    frames = np.empty(len(geometry.dynamic), np.int64)
    local = np.empty((len(geometry.dynamic), 4, 4))
    for k, g in enumerate(geometry.dynamic):
        geom = geometry.geoms[g]
        body = geometry.bodies[geom.body]
        if body.kind == "link":
            frames[k], local[k] = body.frame, geom.T_body_geom
        else:
            pl = place[geom.body]
            frames[k], local[k] = pl.frame, pl.T @ geom.T_body_geom
    return frames, local


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
