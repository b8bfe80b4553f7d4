"""Scene loaders: native tmpc JSON, tmit-star JSON and planet (Lagriffoul) XML -> :class:`Scene`.

:data:`SCENE_LOADERS` maps a format name to its loader; :func:`load_scene` reads a file, detects
its format (or takes ``fmt``) and returns the checked :class:`~tmpc.lang.world.scene.Scene`. Every
problem a user can cause is a :class:`~tmpc.lang.diagnostics.SceneError` whose diagnostics name
the file and the JSON pointer or XML element and carry a span; independent problems (one per
object) are reported together. Warnings (legacy keys tmpc ignores, meshes not found with
``strict_meshes=False``) go to an optional :class:`LoadReport`.

Conventions (docs/world.md): metres, radians, quaternions **xyzw**, box half-extents, support
regions in the object's own frame. Relative paths in the native format are relative to the scene
file's directory; in the legacy formats, to the scene file's directory or any of its ancestors
(planet and tmit-star ran from their repository roots), the first that exists winning.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Iterable

from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.jsonpos import JsonDoc, parse_json
from tmpc.lang.source import SourceFile, Span

# `X as X`: the scene machinery's public names, re-exported for lang.world.configs, the tests and
# docs/world.md
from tmpc.lang.world.files import UrdfNames as UrdfNames
from tmpc.lang.world.files import find_file as find_file
from tmpc.lang.world.files import robot_mesh_problems
from tmpc.lang.world.files import search_dirs as search_dirs
from tmpc.lang.world.files import tried_text as tried_text
from tmpc.lang.world.files import urdf_names as urdf_names
from tmpc.lang.world.native import NATIVE_SCENE_FORMAT as NATIVE_SCENE_FORMAT
from tmpc.lang.world.native import load_native_scene
from tmpc.lang.world.pairs import load_allowed_pairs as load_allowed_pairs
from tmpc.lang.world.planet import TORSO_JOINT as TORSO_JOINT
from tmpc.lang.world.planet import load_planet_scene
from tmpc.lang.world.reader import ROTATION_TOLERANCE as ROTATION_TOLERANCE
from tmpc.lang.world.reader import JsonReader as JsonReader
from tmpc.lang.world.reader import LoadReport as LoadReport
from tmpc.lang.world.reader import Reader as Reader
from tmpc.lang.world.reader import SceneOptions as SceneOptions
from tmpc.lang.world.reader import did_you_mean as did_you_mean
from tmpc.lang.world.reader import display_name as display_name
from tmpc.lang.world.reader import fmt_num as fmt_num
from tmpc.lang.world.reader import join_hints as join_hints
from tmpc.lang.world.reader import kind as kind
from tmpc.lang.world.reader import read_source as read_source
from tmpc.lang.world.rotations import box_to_object_frame as box_to_object_frame
from tmpc.lang.world.rotations import matrix_from_quat as matrix_from_quat
from tmpc.lang.world.rotations import orthonormality_error as orthonormality_error
from tmpc.lang.world.rotations import quat_from_matrix as quat_from_matrix
from tmpc.lang.world.scene import Scene
from tmpc.lang.world.tmit import load_tmit_scene
from tmpc.lang.world.xmldoc import XmlNode as XmlNode
from tmpc.lang.world.xmldoc import parse_xml as parse_xml

__all__ = ["SCENE_LOADERS", "NATIVE_SCENE_FORMAT", "LoadReport", "SceneOptions",
           "detect_scene_format", "load_scene", "load_allowed_pairs", "urdf_names"]


# ============================================================================================
# Registry and entry point

SceneLoader = Callable[..., Scene]

#: format name -> loader(source, options, report, parsed=None). Names match ``Scene.format``.
SCENE_LOADERS: dict[str, SceneLoader] = {
    "tmpc-json": load_native_scene,
    "tmit-star-json": load_tmit_scene,
    "planet-xml": load_planet_scene,
}


def detect_scene_format(source: SourceFile, report: LoadReport | None = None
                        ) -> tuple[str, JsonDoc | XmlNode]:
    """Which loader reads ``source`` (and the parsed document, so it is parsed once)."""
    report = report or LoadReport()
    report.files[source.path] = source
    head = source.text.lstrip()
    if head.startswith("<") or source.path.lower().endswith(".xml"):
        return "planet-xml", parse_xml(source, report)
    doc = parse_json(source)
    v = doc.value
    name = display_name(source.path)
    if isinstance(v, dict) and "format" in v:
        f = v["format"]
        if isinstance(f, str) and f.startswith("tmpc-scene/") and f != NATIVE_SCENE_FORMAT:
            raise SceneError(error("E519", f"{name}: unknown scene format \"{f}\"",
                                   doc.span("/format"), f"this version of tmpc reads "
                                   f"\"{NATIVE_SCENE_FORMAT}\""), report.files)
        return "tmpc-json", doc
    if isinstance(v, dict) and _looks_tmit(v):
        return "tmit-star-json", doc
    raise SceneError(error(
        "E503", f"{name}: cannot tell which scene format this is", Span(source.path, doc.span("").start, doc.span("").start + 1),
        f"a native scene starts with \"format\": \"{NATIVE_SCENE_FORMAT}\" (docs/world.md); a "
        "tmit-star scene has robot.base_pose.rotation as a number or objects with is_static, "
        "obj_file or surface_bounds"), report.files)


def _looks_tmit(v: dict) -> bool:
    robot = v.get("robot")
    if isinstance(robot, dict):
        bp = robot.get("base_pose")
        if "joint_poses" in robot or (isinstance(bp, dict) and
                                      isinstance(bp.get("rotation"), (int, float))):
            return True
    objs = v.get("objects")
    return isinstance(objs, list) and any(
        isinstance(o, dict) and ({"is_static", "obj_file", "surface_bounds", "parent_name"} & set(o)
                                 or (isinstance(o.get("shape"), dict) and "extents" in o["shape"]))
        for o in objs)


def load_scene(path: str | Path, fmt: str | None = None, mesh_dir: str | Path | None = None, *,
               strict_meshes: bool = True, mesh_fallback_dirs: Iterable[str | Path] = (),
               report: LoadReport | None = None, check_meshes: bool = False) -> Scene:
    """Read, check and convert a scene file. ``fmt``: a key of :data:`SCENE_LOADERS` (detected
    when None). ``mesh_dir``: planet's ``objdir``. ``check_meshes``: read the meshes found too
    (:class:`SceneOptions`). Raises SceneError for any problem in the file or the files it
    names; warnings go to ``report``."""
    report = report if report is not None else LoadReport()
    opts = SceneOptions(Path(os.path.abspath(mesh_dir)) if mesh_dir else None, strict_meshes,
                        tuple(Path(os.path.abspath(d)) for d in mesh_fallback_dirs), check_meshes)
    source = read_source(path, "scene")
    report.files[source.path] = source
    if fmt is None:
        fmt, parsed = detect_scene_format(source, report)
        scene = SCENE_LOADERS[fmt](source, opts, report, parsed)
    elif fmt not in SCENE_LOADERS:
        raise SceneError(error("E503", f"unknown scene format \"{fmt}\"", None, join_hints(
            did_you_mean(fmt, SCENE_LOADERS), "the formats are " + ", ".join(SCENE_LOADERS))))
    else:
        scene = SCENE_LOADERS[fmt](source, opts, report)
    if check_meshes and scene.robot is not None:
        # the robot's link meshes too: a run loads every one for collision checking (E562)
        problems = robot_mesh_problems(Path(scene.robot.urdf), report)
        if problems:
            raise SceneError(problems, report.files)
    return _within_reach(scene, report)


#: metres from the origin beyond which a position is a typo, not a scene (E520)
FARTHEST = 1e4


def _within_reach(scene: Scene, report: LoadReport) -> Scene:
    """Every object and the robot's base within :data:`FARTHEST` of the origin: an object at
    x = 1e308 was once accepted, and the planner wandered until its time limit."""
    placed = [(f"object `{o.name}`", o.pose, o.origin) for o in scene.objects]
    if scene.robot is not None:
        placed.append(("the robot's base", scene.robot.base_pose, None))
    for what, pose, origin in placed:
        far = max(abs(v) for v in pose.translation)
        if far > FARTHEST:
            src = report.files.get(origin.path) if origin is not None else None
            span = src.span(src.offset(origin.line, origin.column or 1),
                            src.offset(origin.line, origin.column or 1) + 1) \
                if src is not None and origin.line else None
            raise SceneError(error("E520", f"{origin or scene.path}: {what} is {far:g} m from "
                                   f"the origin (more than {FARTHEST:g} m)", span,
                                   "positions are in metres; check for a typo or a unit mix-up"),
                             report.files)
    for (lo, hi), axis in zip(scene.bounds, "xyz"):
        if max(abs(lo), abs(hi)) > FARTHEST:
            raise SceneError(error("E520", f"{scene.path}: the workspace bounds reach {axis} = "
                                   f"{max(abs(lo), abs(hi)):g} m (more than {FARTHEST:g} m)",
                                   None, "bounds are in metres"), report.files)
    return scene
