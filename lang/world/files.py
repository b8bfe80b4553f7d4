"""The files a scene refers to: search directories (legacy files resolve against their ancestors),
URDF and mesh references, and the URDF's link and joint names (cached)."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.source import Span
from tmpc.lang.world.reader import LoadReport, Reader, SceneOptions, Stop, join_hints, read_source
from tmpc.lang.world.robot import find_file as find_urdf_file
from tmpc.lang.world.robot import resolve_uri
from tmpc.lang.world.xmldoc import parse_xml


def search_dirs(start: Path, ancestors: bool) -> list[Path]:
    """``start`` and, for legacy files, each of its ancestors (nearest first)."""
    return [start, *start.parents] if ancestors else [start]


def find_file(raw: str, bases: Iterable[Path], by_name: Iterable[Path] = (),
              want_dir: bool = False) -> tuple[Path | None, list[Path]]:
    """Resolve ``raw`` (``~`` expanded): absolute as is; relative against each base in turn,
    then by file name in ``by_name``. Returns (the first that exists, every place tried)."""
    p = Path(os.path.expanduser(raw))
    candidates = [p] if p.is_absolute() else [b / p for b in bases]
    candidates += [d / p.name for d in by_name]
    tried: list[Path] = []
    for c in candidates:
        c = Path(os.path.normpath(c))
        if c in tried:
            continue
        tried.append(c)
        if (c.is_dir() if want_dir else c.is_file()):
            return c, tried
    return None, tried


def tried_text(tried: list[Path], limit: int = 6) -> str:
    shown = [str(t) for t in tried[:limit]]
    more = f" and {len(tried) - limit} more" if len(tried) > limit else ""
    return "looked for " + ", ".join(shown) + more


@dataclass(frozen=True)
class UrdfNames:
    robot: str
    links: frozenset[str]
    joints: frozenset[str]
    #: joints a planner can move: revolute, continuous or prismatic, and not mimics
    movable: frozenset[str] = frozenset()
    #: (link, mesh filename, start and end offsets of the `<mesh>` tag) of each collision mesh
    collision_meshes: tuple[tuple[str, str, int, int], ...] = ()


_URDF_CACHE: dict[tuple[str, int, int], UrdfNames] = {}


def urdf_names(path: Path, report: LoadReport | None = None) -> UrdfNames:
    """The robot, link and joint names of a URDF (a fast expat scan, cached per file version).
    A file that is not well-formed XML is SceneError E561 (the URDF's own code)."""
    st = path.stat()
    key = (str(path), st.st_mtime_ns, st.st_size)
    hit = _URDF_CACHE.get(key)
    if hit is not None:
        return hit
    source = read_source(path, "URDF")
    root = parse_xml(source, report or LoadReport(), code="E561")
    links = frozenset(c.attrib["name"] for c in root.children
                      if c.tag == "link" and "name" in c.attrib)
    joint_nodes = [c for c in root.children if c.tag == "joint" and "name" in c.attrib]
    movable = frozenset(j.attrib["name"] for j in joint_nodes
                        if j.attrib.get("type") in ("revolute", "continuous", "prismatic")
                        and j.child("mimic") is None)
    meshes = tuple((lk.attrib["name"], m.attrib["filename"], m.start, m.tag_end)
                   for lk in root.children if lk.tag == "link" and "name" in lk.attrib
                   for col in lk.all("collision") for geo in col.all("geometry")
                   for m in geo.all("mesh") if "filename" in m.attrib)
    names = UrdfNames(root.attrib.get("name", "robot"), links,
                      frozenset(j.attrib["name"] for j in joint_nodes), movable, meshes)
    if len(_URDF_CACHE) > 32:
        _URDF_CACHE.clear()
    _URDF_CACHE[key] = names
    return names


def uri_candidates(raw: str, bases: list[Path]) -> list[Path] | None:
    """Candidates for a ``package://`` or ``file://`` reference (None for a plain path)."""
    if not raw.startswith(("package://", "file://")):
        return None
    return resolve_uri(raw, bases[0])


def find_first(raw: str, bases: list[Path], by_name: Iterable[Path] = ()) -> tuple[Path | None,
                                                                             list[Path]]:
    uri = uri_candidates(raw, bases)
    if uri is None:
        return find_file(raw, bases, by_name)
    tried = [Path(os.path.normpath(c)) for c in uri]
    return next((c for c in tried if c.is_file()), None), tried


def resolve_urdf(r: Reader, raw: str, span: Span | None, where: str) -> tuple[Path, UrdfNames]:
    found, tried = find_first(raw, search_dirs(r.directory, r.legacy))
    if found is None:
        r.fail("E560", span, f"{where}: URDF file \"{raw}\" not found",
               join_hints(tried_text(tried), "relative paths are relative to the scene file's "
                          "directory" + (" or one of its parents" if r.legacy else "")))
    try:
        return found, urdf_names(found, r.report)
    except SceneError as exc:       # a malformed URDF: its own file and position
        r.errors.extend(exc.diagnostics)
        r.report.files.update(exc.files)
        raise Stop from None


def resolve_mesh(r: Reader, opts: SceneOptions, raw: str, span: Span | None, where: str,
                  bases: list[Path]) -> Path:
    fallbacks = list(opts.mesh_fallback_dirs)
    found, tried = find_first(raw, bases + fallbacks, by_name=fallbacks)
    if found is not None:
        defect = mesh_defect(found) if opts.check_meshes else None
        if defect is not None:
            r.fail("E565", span, f"{where}: mesh file \"{raw}\" ({found}) cannot be loaded "
                   f"({defect})", "use an STL, OBJ or PLY file with triangles")
        return found
    looked = tried_text(tried)
    if opts.strict_meshes:
        r.fail("E514", span, f"{where}: mesh file \"{raw}\" not found",
               join_hints(looked, _MESH_WHERE))
    guess = next((t for t in tried if t.parent.is_dir()), tried[0])
    r.warn("W501", span, f"{where}: mesh file \"{raw}\" not found; kept as {guess}",
           join_hints(looked, _MESH_WHERE))
    return guess


def robot_mesh_problems(urdf: Path, report: LoadReport) -> list:
    """What loading the robot for collision checking would refuse, found without loading it:
    E562 for each link collision mesh that is not found where a run looks (the URDF's
    directory, ``package://`` roots, ``TMPC_MESH_PATH``), E565 for one that cannot be loaded
    (:func:`mesh_defect`). Each at its `<mesh>` tag in the URDF."""
    out, source = [], None
    for link, uri, start, end in urdf_names(urdf, report).collision_meshes:
        found = find_urdf_file(uri, urdf.parent)
        defect = None if found is None else mesh_defect(found)
        if found is not None and defect is None:
            continue
        if source is None:
            source = read_source(urdf, "URDF")
            report.files[source.path] = source
        span = Span(source.path, start, end)
        if found is None:
            looked = ", ".join(str(c) for c in resolve_uri(uri, urdf.parent)[:6])
            out.append(error("E562", f"{urdf}: mesh `{uri}` of link `{link}` not found", span,
                             f"looked in: {looked}; set TMPC_MESH_PATH to directories that "
                             "hold the meshes"))
        else:
            out.append(error("E565", f"{urdf}: collision mesh `{uri}` of link `{link}` "
                             f"({found}) cannot be loaded ({defect})", span,
                             "use an STL, OBJ or PLY file with triangles"))
    return out


#: how to make a missing mesh found (the hint of E514 and W501)
_MESH_WHERE = ("collision checks need the mesh: put it there, or set TMPC_MESH_PATH to "
               "directories that hold it (searched by relative path and by file name)")
_PLY_FACES = re.compile(rb"^element\s+face\s+(\d+)", re.MULTILINE)


#: mesh_defect's answers by (path, size, modification time): the language server checks a
#: run configuration on every edit, and a scene's meshes are read again only when they change
_DEFECTS: dict[tuple, str | None] = {}


def mesh_defect(path: Path) -> str | None:
    """Why the mesh file ``path`` cannot be loaded, from a cheap look at it (no mesh library):
    unreadable, empty, or an STL/OBJ/PLY file without triangles. None: it looks loadable (other
    formats are not looked into)."""
    try:
        st = path.stat()
    except OSError as exc:
        return str(exc.strerror or exc)
    key = (str(path), st.st_size, st.st_mtime_ns)
    if key not in _DEFECTS:
        if len(_DEFECTS) >= 256:
            _DEFECTS.clear()
        _DEFECTS[key] = _look_at_mesh(path)
    return _DEFECTS[key]


def _look_at_mesh(path: Path) -> str | None:
    try:
        data = path.read_bytes()
    except OSError as exc:
        return str(exc.strerror or exc)
    if not data.strip():
        return "empty file"
    kind = path.suffix.lower()
    if kind == ".obj":
        ok = re.search(rb"^\s*f\s", data, re.MULTILINE) is not None
        return None if ok else "no faces: an OBJ file needs `f` lines"
    if kind == ".stl":
        if data[:5].lower() == b"solid" and b"facet" in data:
            return None                                   # ASCII STL with facets
        n = int.from_bytes(data[80:84], "little") if len(data) >= 84 else 0
        return None if n > 0 and len(data) >= 84 + 50 * n else "not an STL file with triangles"
    if kind == ".ply":
        m = _PLY_FACES.search(data[:4096])
        return None if data[:3] == b"ply" and m and int(m.group(1)) > 0 else \
            "not a PLY file with faces"
    return None
