"""URDF -> :class:`KinematicTree` (links, joints, collision geometry), with `package://` resolution.

Parsing uses yourdfpy (imported lazily; `tmpc check` never pays for it). Meshes are not loaded
here, only resolved to files: the collision layer loads them with trimesh. `package://NAME/...`
is looked up, in order, in an ancestor directory of the URDF named NAME, in `ROS_PACKAGE_PATH`,
in the models installed by the `example-robot-data` package, and beside the URDF.
"""

from __future__ import annotations

import logging
import os
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.world.scene import Shape

Matrix4 = tuple[tuple[float, float, float, float], ...]
IDENTITY: Matrix4 = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0),
                     (0.0, 0.0, 0.0, 1.0))
MOVABLE_TYPES = ("revolute", "continuous", "prismatic")


@dataclass(frozen=True, slots=True)
class Geometry:
    """A collision body of a link: a shape at ``origin`` (4x4, in the link frame)."""

    shape: Shape
    origin: Matrix4 = IDENTITY


@dataclass(frozen=True, slots=True)
class Link:
    name: str
    collision: tuple[Geometry, ...] = ()


@dataclass(frozen=True, slots=True)
class Mimic:
    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True, slots=True)
class Joint:
    name: str
    type: str                       # revolute | continuous | prismatic | fixed
    parent: str
    child: str
    origin: Matrix4 = IDENTITY      # T_parent_joint
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    lower: float | None = None
    upper: float | None = None
    mimic: Mimic | None = None

    @property
    def movable(self) -> bool:
        return self.type in MOVABLE_TYPES


@dataclass(frozen=True, slots=True)
class KinematicTree:
    """A robot: links, and joints in topological order (parents before children)."""

    name: str
    root: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    path: str

    def joint(self, name: str) -> Joint | None:
        return _index(self.joints).get(name)

    def link(self, name: str) -> Link | None:
        return _index(self.links).get(name)


def _index(items) -> dict:
    return {it.name: it for it in items}


# ---------------------------------------------------------------------------------------------
# package:// resolution


@lru_cache(maxsize=1)
def example_robot_data_dir() -> Path | None:
    """`share/example-robot-data` of the installed `example-robot-data` package, if any."""
    for entry in sys.path:
        cand = Path(entry) / "cmeel.prefix" / "share" / "example-robot-data"
        if cand.is_dir():
            return cand
    return None


def mesh_search_dirs() -> list[str]:
    """The directories of ``$TMPC_MESH_PATH``, where meshes a checkout lacks are looked for
    (robot and object meshes alike; `run`, `check` and every other command)."""
    return [d for d in os.environ.get("TMPC_MESH_PATH", "").split(os.pathsep) if d]


def _search_path(rel: str) -> list[Path]:
    """``$TMPC_MESH_PATH`` directories: by relative path, then by file name (e.g. to point a
    tmit-star checkout, whose .obj meshes are not in its repository, at planet's copies)."""
    out = []
    for root in mesh_search_dirs():
        out += [Path(root) / rel, Path(root) / Path(rel).name]
    return out


def resolve_uri(uri: str, base: Path) -> list[Path]:
    """Candidate files for a URDF/mesh reference, most likely first (existing or not)."""
    if uri.startswith("file://"):
        return [Path(uri[7:]), *_search_path(Path(uri[7:]).name)]
    if not uri.startswith("package://"):
        p = Path(uri)
        return ([p] if p.is_absolute() else [base / p]) + _search_path(uri)
    rest = uri[len("package://"):]
    pkg, _, sub = rest.partition("/")
    cands: list[Path] = []
    for anc in (base, *base.parents):
        if anc.name == pkg:
            cands.append(anc / sub)
    for root in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if root:
            cands.append(Path(root) / pkg / sub)
    erd = example_robot_data_dir()
    if erd is not None:
        cands.append(erd / sub if pkg == "example-robot-data" else erd / "robots" / pkg / sub)
    cands += [base / sub, base.parent / sub, *_search_path(sub)]
    return cands


def find_file(uri: str, base: Path) -> Path | None:
    for cand in resolve_uri(uri, base):
        if cand.is_file():
            return cand
    return None


# ---------------------------------------------------------------------------------------------
# loading


def load_urdf(ref: str | Path, base: Path | None = None, strict_meshes: bool = True) -> KinematicTree:
    """Load a URDF (a path or a `package://` URI). Raises :class:`SceneError` for bad input."""
    base = base or Path.cwd()
    path = find_file(str(ref), base)
    if path is None:
        looked = ", ".join(str(p) for p in resolve_uri(str(ref), base)[:6])
        raise SceneError(error("E560", f"URDF `{ref}` not found", None, f"looked in: {looked}"))
    return _load_urdf_cached(str(path.resolve()), strict_meshes)


def import_yourdfpy():
    """yourdfpy (heavy: numpy, trimesh, lxml), its and trimesh's log quieted to errors: their
    warnings ("joint ... is supposed to mimic ...") were printed once per link and state, in
    thousands, and say nothing a tmpc diagnostic does not."""
    import yourdfpy
    for name in ("yourdfpy", "trimesh"):
        logging.getLogger(name).setLevel(logging.ERROR)
    return yourdfpy


@lru_cache(maxsize=16)
def _load_urdf_cached(path: str, strict_meshes: bool) -> KinematicTree:
    yourdfpy = import_yourdfpy()

    try:
        urdf = yourdfpy.URDF.load(path, build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False, load_collision_meshes=False)
    except Exception as exc:   # yourdfpy/lxml raise many kinds; all mean "malformed URDF"
        raise SceneError(error("E561", f"{path}: not a valid URDF: {exc}", None,
                               "check the XML and that every joint names existing links")) from None
    robot = urdf.robot
    base = Path(path).parent
    links = tuple(_link(lk, base, path, strict_meshes) for lk in robot.links)
    joints = tuple(_joint(j, path) for j in robot.joints)
    root, ordered = _topological(links, joints, path)
    return KinematicTree(robot.name or Path(path).stem, root, links, ordered, path)


def _matrix(m) -> Matrix4:
    if m is None:
        return IDENTITY
    return tuple(tuple(float(v) for v in row) for row in m)


def _link(lk, base: Path, path: str, strict: bool) -> Link:
    geoms = []
    for col in lk.collisions:
        shape = _shape(col.geometry, base, path, lk.name, strict)
        if shape is not None:
            geoms.append(Geometry(shape, _matrix(col.origin)))
    return Link(lk.name, tuple(geoms))


def _shape(g, base: Path, path: str, link: str, strict: bool) -> Shape | None:
    if g.box is not None:
        sx, sy, sz = (float(v) / 2 for v in g.box.size)
        return Shape("box", size=(sx, sy, sz))
    if g.sphere is not None:
        return Shape("sphere", radius=float(g.sphere.radius))
    if g.cylinder is not None:
        return Shape("cylinder", radius=float(g.cylinder.radius), length=float(g.cylinder.length))
    if g.mesh is not None:
        found = find_file(g.mesh.filename, base)
        if found is None:
            if not strict:
                return None
            looked = ", ".join(str(p) for p in resolve_uri(g.mesh.filename, base)[:6])
            raise SceneError(error("E562", f"{path}: mesh `{g.mesh.filename}` of link `{link}` "
                                   "not found", None, f"looked in: {looked}; set TMPC_MESH_PATH "
                                   "to directories that hold the meshes"))
        scale = g.mesh.scale
        if scale is None:
            sc = (1.0, 1.0, 1.0)
        elif hasattr(scale, "__len__"):
            sc = tuple(float(v) for v in scale)
        else:
            sc = (float(scale),) * 3
        return Shape("mesh", mesh=found, scale=sc)
    return None


def _joint(j, path: str) -> Joint:
    if j.type in ("floating", "planar"):
        raise SceneError(error("E563", f"{path}: joint `{j.name}` is {j.type}; tmpc models a "
                               "mobile base through the scene (`mobile_base`), not the URDF", None,
                               "make it fixed and set the base pose in the scene"))
    axis = tuple(float(v) for v in (j.axis if j.axis is not None else (1.0, 0.0, 0.0)))
    lo = hi = None
    if j.limit is not None and j.type in ("revolute", "prismatic"):
        lo = None if j.limit.lower is None else float(j.limit.lower)
        hi = None if j.limit.upper is None else float(j.limit.upper)
    mimic = Mimic(j.mimic.joint, float(j.mimic.multiplier if j.mimic.multiplier is not None else 1),
                  float(j.mimic.offset or 0.0)) if j.mimic is not None else None
    return Joint(j.name, j.type, j.parent, j.child, _matrix(j.origin), axis, lo, hi, mimic)


def _topological(links, joints, path) -> tuple[str, tuple[Joint, ...]]:
    names = {lk.name for lk in links}
    children: dict[str, list[Joint]] = {}
    has_parent = set()
    for j in joints:
        for end in (j.parent, j.child):
            if end not in names:
                raise SceneError(error("E561", f"{path}: joint `{j.name}` names unknown link "
                                       f"`{end}`", None))
        if j.child in has_parent:
            raise SceneError(error("E561", f"{path}: link `{j.child}` has two parent joints", None))
        has_parent.add(j.child)
        children.setdefault(j.parent, []).append(j)
    roots = [lk.name for lk in links if lk.name not in has_parent]
    if len(roots) != 1:
        raise SceneError(error("E561", f"{path}: a URDF needs exactly one root link, found "
                               f"{len(roots)} ({', '.join(roots[:5])})", None))
    order, todo = [], [roots[0]]
    while todo:
        parent = todo.pop()
        for j in children.get(parent, []):
            order.append(j)
            todo.append(j.child)
    if len(order) != len(joints):
        raise SceneError(error("E561", f"{path}: the joints do not form a tree", None))
    for j in order:
        if j.mimic is not None and j.mimic.joint not in {x.name for x in joints}:
            raise SceneError(error("E561", f"{path}: joint `{j.name}` mimics unknown joint "
                                   f"`{j.mimic.joint}`", None))
    return roots[0], tuple(order)


def find_srdf(urdf_path: str | Path) -> Path | None:
    """The SRDF of a URDF: ``<stem>.srdf`` beside it or in ``../srdf/`` (example-robot-data)."""
    p = Path(urdf_path)
    for cand in (p.with_suffix(".srdf"), p.parent.parent / "srdf" / (p.stem + ".srdf"),
                 p.parent / "srdf" / (p.stem + ".srdf")):
        if cand.is_file():
            return cand
    return None


# ---------------------------------------------------------------------------------------------
# a parsed tree as plain data (the compiler's cache keeps it, so a warm run parses no URDF)

TREE_FORMAT = "tmpc-tree/1"


def tree_to_data(tree: KinematicTree) -> dict:
    """``tree`` as JSON-ready data (:func:`tree_from_data` reverses it exactly)."""
    def shape(s: Shape) -> dict:
        return {"kind": s.kind, "size": list(s.size), "radius": s.radius, "length": s.length,
                "mesh": None if s.mesh is None else str(s.mesh), "scale": list(s.scale),
                "convex": s.convex}

    return {"format": TREE_FORMAT, "name": tree.name, "root": tree.root, "path": tree.path,
            "links": [{"name": lk.name,
                       "collision": [{"shape": shape(g.shape),
                                      "origin": [list(r) for r in g.origin]}
                                     for g in lk.collision]} for lk in tree.links],
            "joints": [{"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
                        "origin": [list(r) for r in j.origin], "axis": list(j.axis),
                        "lower": j.lower, "upper": j.upper,
                        "mimic": None if j.mimic is None else
                        [j.mimic.joint, j.mimic.multiplier, j.mimic.offset]}
                       for j in tree.joints]}


def tree_from_data(d: dict) -> KinematicTree:
    """The tree :func:`tree_to_data` wrote. Raises ``ValueError`` (or ``KeyError``,
    ``TypeError``) for data of another shape: a cache entry that is not ours is rebuilt."""
    if d.get("format") != TREE_FORMAT:
        raise ValueError("not a tmpc kinematic tree")

    def matrix(rows) -> Matrix4:
        m = tuple(tuple(float(v) for v in row) for row in rows)
        if len(m) != 4 or any(len(r) != 4 for r in m):
            raise ValueError("a transform is 4x4")
        return m

    def shape(s: dict) -> Shape:
        return Shape(str(s["kind"]), tuple(float(v) for v in s["size"]), float(s["radius"]),
                     float(s["length"]), None if s["mesh"] is None else Path(s["mesh"]),
                     tuple(float(v) for v in s["scale"]), bool(s["convex"]))

    def opt(v):
        return None if v is None else float(v)

    links = tuple(Link(str(lk["name"]), tuple(Geometry(shape(g["shape"]), matrix(g["origin"]))
                                              for g in lk["collision"]))
                  for lk in d["links"])
    joints = tuple(Joint(str(j["name"]), str(j["type"]), str(j["parent"]), str(j["child"]),
                         matrix(j["origin"]), tuple(float(v) for v in j["axis"]),
                         opt(j["lower"]), opt(j["upper"]),
                         None if j["mimic"] is None else
                         Mimic(str(j["mimic"][0]), float(j["mimic"][1]), float(j["mimic"][2])))
                   for j in d["joints"])
    return KinematicTree(str(d["name"]), str(d["root"]), links, joints, str(d["path"]))


def hand_chain(tree: KinematicTree, frame: str) -> tuple[str, ...]:
    """The movable, non-mimic joints from the root of ``tree`` to ``frame`` (a link or joint
    name), root first: the arm that moves a hand. Empty when ``frame`` is not in the tree."""
    joints = {j.child: j for j in tree.joints}
    named = tree.joint(frame)
    link = named.child if named is not None else frame
    if tree.link(link) is None:
        return ()
    out: list[str] = []
    while link in joints:
        j = joints[link]
        if j.movable and j.mimic is None:
            out.append(j.name)
        link = j.parent
    return tuple(reversed(out))
