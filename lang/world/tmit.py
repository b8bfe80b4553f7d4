"""tmit-star scene JSON (FACTS 4.2)."""

from __future__ import annotations

from typing import Any

from tmpc.lang.jsonpos import JsonDoc, pointer
from tmpc.lang.source import SourceFile
from tmpc.lang.world.files import UrdfNames, search_dirs
from tmpc.lang.world.files import resolve_mesh as resolve_mesh
from tmpc.lang.world.files import resolve_urdf as resolve_urdf
from tmpc.lang.world.names import Entry as Entry
from tmpc.lang.world.names import check_names as check_names
from tmpc.lang.world.names import known_joint as known_joint
from tmpc.lang.world.reader import JsonReader, LoadReport, SceneOptions, read_json_scene
from tmpc.lang.world.rotations import box_to_object_frame
from tmpc.lang.world.scene import Pose, RobotSpec, Scene, SceneObject, Shape

_TMIT_IGNORED = ("color", "specular", "hide_name")


def load_tmit_scene(source: SourceFile, opts: SceneOptions, report: LoadReport,
                    doc: JsonDoc | None = None) -> Scene:
    return read_json_scene(source, doc, report, True, lambda r: _tmit_scene(r, opts))


def _tmit_scene(r: JsonReader, opts: SceneOptions) -> Scene:
    top = r.obj("", r.doc.value, ("bounds", "robot"), ("objects",))
    bounds = robot = urdf = None
    with r.part():
        bounds = r.bounds("/bounds", top["bounds"])
    with r.part():
        robot, urdf = _tmit_robot(r, "/robot", top["robot"])
    entries: list[Entry] = []
    with r.part():
        for i, o in enumerate(r.array("/objects", top.get("objects", []))):
            with r.part():
                entries.append(_tmit_object(r, f"/objects/{i}", o, opts))
    check_names(r, entries, robot, urdf)
    r.finish()
    return Scene(r.source.path, bounds, robot, tuple(e.obj for e in entries), (),  # type: ignore[arg-type]
                 "tmit-star-json")


def _tmit_robot(r: JsonReader, ptr: str, value: Any) -> tuple[RobotSpec, UrdfNames]:
    v = r.obj(ptr, value, ("urdf", "base_pose"), ("joint_poses",))
    raw = r.string(f"{ptr}/urdf", v["urdf"])
    path, names = resolve_urdf(r, raw, r.span(f"{ptr}/urdf"), f"{ptr}/urdf")
    bp = r.obj(f"{ptr}/base_pose", v["base_pose"], ("translation", "rotation"))
    x, y = r.numbers(f"{ptr}/base_pose/translation", bp["translation"], 2,
                     "a tmit-star base translation [x, y]")
    yaw = r.number(f"{ptr}/base_pose/rotation", bp["rotation"])
    joints: list[tuple[str, float]] = []
    jv = r.mapping(f"{ptr}/joint_poses", v.get("joint_poses", {}), "an object {joint: value}")
    for jn, val in jv.items():
        jp = f"{ptr}/joint_poses" + pointer(jn)
        with r.part():
            x_j = r.number(jp, val)
            if known_joint(r, jn, names, r.doc.key_span(jp), f"{ptr}/joint_poses", warn=True):
                joints.append((jn, x_j))
    # tmit-star's base always moves in x, y, yaw; it plans every joint of the URDF
    return RobotSpec(path, Pose.from_xyz_yaw(x, y, 0.0, yaw), True, tuple(joints), None,
                     names.robot, r.origin(r.span(ptr), ptr)), names


def _tmit_object(r: JsonReader, ptr: str, value: Any, opts: SceneOptions) -> Entry:
    v = r.obj(ptr, value, ("name", "pose"), ("is_static", "parent_name", "surface_bounds",
                                             "obj_file", "scale", "is_concave", "shape"),
              ignored=_TMIT_IGNORED)
    name = r.pddl_name(f"{ptr}/name", v["name"])
    pose = r.pose(f"{ptr}/pose", v["pose"], True)
    movable = not r.boolean(f"{ptr}/is_static", v.get("is_static", True))
    parent = r.pddl_name(f"{ptr}/parent_name", v["parent_name"]) if "parent_name" in v else None
    shape = _tmit_shape(r, ptr, v, opts)
    support = None
    if "surface_bounds" in v:
        sp = f"{ptr}/surface_bounds"
        sb = r.obj(sp, v["surface_bounds"], ("x", "y", "z"))
        (xl, xh), (yl, yh), (zl, zh) = (r.interval(f"{sp}/{a}", sb[a], f"the {a} range")
                                        for a in "xyz")
        # tmit-star adds these to the object's position without rotating them: they are in
        # world-aligned axes at the object's origin. The model keeps the object's frame.
        support, exact = box_to_object_frame(pose.rotation, (xl, yl, zl), (xh, yh, zh))
        if not exact:
            r.warn("W504", r.span(sp), f"{sp}: the object's rotation does not map axes to axes; "
                   "its support region is approximated by a larger box in the object's frame",
                   "tmit-star bounds are world-aligned; give the region in the object's frame "
                   "in a native scene to be exact")
    obj = SceneObject(name, pose, movable, shape, support, parent, r.origin(r.span(ptr), ptr))
    return Entry(obj, r.span(f"{ptr}/name"),
                  r.span(f"{ptr}/parent_name") if parent else None)


def _tmit_shape(r: JsonReader, ptr: str, v: dict, opts: SceneOptions) -> Shape:
    if "obj_file" in v:
        if "shape" in v:
            r.warn("W503", r.doc.key_span(f"{ptr}/shape"), f"{ptr}: both \"obj_file\" and "
                   "\"shape\" given; \"obj_file\" is used, as tmit-star did", "remove one")
        raw = r.string(f"{ptr}/obj_file", v["obj_file"])
        bases = search_dirs(r.directory, True) + ([opts.mesh_dir] if opts.mesh_dir else [])
        mesh = resolve_mesh(r, opts, raw, r.span(f"{ptr}/obj_file"), f"{ptr}/obj_file", bases)
        scale = (1.0, 1.0, 1.0)
        if "scale" in v:
            scale = r.numbers(f"{ptr}/scale", v["scale"], 3, "a scale [x, y, z]")
            for i, x in enumerate(scale):
                r.positive(f"{ptr}/scale/{i}", x, "a scale")
        concave = r.boolean(f"{ptr}/is_concave", v.get("is_concave", False))
        return Shape("mesh", mesh=mesh, scale=(scale[0], scale[1], scale[2]), convex=not concave)
    if "shape" in v:
        sp = f"{ptr}/shape"
        s = r.obj(sp, v["shape"], ("type", "extents"))
        t = r.string(f"{sp}/type", s["type"])
        if t != "box":
            r.fail("E517", r.span(f"{sp}/type"), f"{sp}/type: tmit-star shapes are boxes; found "
                   f"\"{t}\"", "use a native tmpc scene for spheres and cylinders, or obj_file")
        he = r.numbers(f"{sp}/extents", s["extents"], 3, "box extents (half-extents)")
        for i, x in enumerate(he):
            r.positive(f"{sp}/extents/{i}", x, "a half-extent", allow_zero=True)
        return Shape("box", size=(he[0], he[1], he[2]))
    r.fail("E505", r.head(ptr), f"{ptr}: object \"{v['name']}\" has no geometry",
           'give "obj_file": "mesh.obj" or "shape": {"type": "box", "extents": [x, y, z]}')
