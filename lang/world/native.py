"""The native tmpc scene JSON (``"format": "tmpc-scene/1"``, docs/world.md)."""

from __future__ import annotations

from typing import Any

from tmpc.lang.diagnostics import Related
from tmpc.lang.jsonpos import JsonDoc, pointer
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world.files import UrdfNames, find_file, tried_text
from tmpc.lang.world.files import resolve_mesh as resolve_mesh
from tmpc.lang.world.files import resolve_urdf as resolve_urdf
from tmpc.lang.world.names import Entry as Entry
from tmpc.lang.world.names import check_names as check_names
from tmpc.lang.world.names import check_pairs as check_pairs
from tmpc.lang.world.names import frame_names as frame_names
from tmpc.lang.world.names import known_joint as known_joint
from tmpc.lang.world.pairs import load_allowed_pairs
from tmpc.lang.world.reader import (
    JsonReader,
    LoadReport,
    SceneOptions,
    did_you_mean,
    fmt_num,
    join_hints,
    read_json_scene,
)
from tmpc.lang.world.scene import (
    Box,
    GraspSet,
    Pose,
    RobotSpec,
    Scene,
    SceneObject,
    Shape,
    StablePose,
    Vec3,
)
from tmpc.lang.world.suite import Attached, check_attachments

NATIVE_SCENE_FORMAT = "tmpc-scene/1"


def load_native_scene(source: SourceFile, opts: SceneOptions, report: LoadReport,
                      doc: JsonDoc | None = None) -> Scene:
    return read_json_scene(source, doc, report, False, lambda r: _native_scene(r, opts))


def _native_scene(r: JsonReader, opts: SceneOptions) -> Scene:
    top = r.obj("", r.doc.value, ("format", "bounds"), ("robot", "objects", "allowed_collisions"),
                what='a scene: {"format": "tmpc-scene/1", ...}')
    fmt = r.string("/format", top["format"])
    if fmt != NATIVE_SCENE_FORMAT:
        r.fail("E519", r.span("/format"), f"/format: unknown scene format \"{fmt}\"",
               f"this version of tmpc reads \"{NATIVE_SCENE_FORMAT}\"")
    bounds = robot = urdf = None
    with r.part():
        bounds = r.bounds("/bounds", top["bounds"])
    if top.get("robot") is not None:
        with r.part():
            robot, urdf = _native_robot(r, "/robot", top["robot"])
    entries: list[Entry] = []
    attached: list[Attached] = []
    with r.part():
        for i, o in enumerate(r.array("/objects", top.get("objects", []))):
            with r.part():
                entries.append(_native_object(r, f"/objects/{i}", o, opts, attached))
    check_names(r, entries, robot, urdf)
    check_attachments(r, attached, {e.obj.name.lower(): e.obj.name for e in entries})
    pairs: tuple[tuple[str, str], ...] = ()
    if "allowed_collisions" in top:
        with r.part():
            pairs = _native_pairs(r, top["allowed_collisions"], frame_names(entries, robot, urdf))
    r.finish()
    return Scene(r.source.path, bounds, robot, tuple(e.obj for e in entries), pairs,  # type: ignore[arg-type]
                 "tmpc-json")


def _native_robot(r: JsonReader, ptr: str, value: Any) -> tuple[RobotSpec, UrdfNames]:
    v = r.obj(ptr, value, ("urdf",), ("name", "base_pose", "mobile_base", "joints",
                                     "controllable"))
    raw = r.string(f"{ptr}/urdf", v["urdf"])
    path, names = resolve_urdf(r, raw, r.span(f"{ptr}/urdf"), f"{ptr}/urdf")
    name = r.pddl_name(f"{ptr}/name", v["name"]) if "name" in v else names.robot
    pose = r.pose(f"{ptr}/base_pose", v["base_pose"], False) if "base_pose" in v else Pose()
    mobile = r.boolean(f"{ptr}/mobile_base", v.get("mobile_base", False))
    joints: list[tuple[str, float]] = []
    jv = r.mapping(f"{ptr}/joints", v.get("joints", {}), "an object {joint name: value}")
    for jn, x in jv.items():
        jp = f"{ptr}/joints" + pointer(jn)
        with r.part():
            known_joint(r, jn, names, r.doc.key_span(jp), f"{ptr}/joints")
            joints.append((jn, r.number(jp, x)))
    controllable = None
    if v.get("controllable") is not None:
        controllable = _native_controllable(r, f"{ptr}/controllable", v["controllable"], names)
    return RobotSpec(path, pose, mobile, tuple(joints), controllable, name,
                     r.origin(r.span(ptr), ptr)), names


def _native_controllable(r: JsonReader, ptr: str, value: Any, names: UrdfNames) -> tuple[str, ...]:
    out: list[str] = []
    for i, jn in enumerate(r.array(ptr, value, "an array of joint names")):
        with r.part():
            jn = r.string(f"{ptr}/{i}", jn)
            if jn in out:
                r.fail("E510", r.span(f"{ptr}/{i}"), f"{ptr}/{i}: joint \"{jn}\" listed twice")
            known_joint(r, jn, names, r.span(f"{ptr}/{i}"), ptr, movable=True)
            out.append(jn)
    return tuple(out)


_SHAPE_KEYS = {"box": (("half_extents",), ()), "sphere": (("radius",), ()),
               "cylinder": (("radius", "length"), ()), "mesh": (("file",), ("scale", "convex"))}


def _native_object(r: JsonReader, ptr: str, value: Any, opts: SceneOptions,
                   attached: list[Attached]) -> Entry:
    v = r.obj(ptr, value, ("name", "pose"), ("movable", "shape", "support", "parent", "grasps",
                                             "stable_poses", "attachments"))
    name = r.pddl_name(f"{ptr}/name", v["name"])
    pose = r.pose(f"{ptr}/pose", v["pose"], False)
    movable = r.boolean(f"{ptr}/movable", v.get("movable", False))
    shape = _native_shape(r, f"{ptr}/shape", v["shape"], opts) \
        if v.get("shape") is not None else None
    support = None
    if v.get("support") is not None:
        sp = r.obj(f"{ptr}/support", v["support"], ("lower", "upper"))
        lo = r.numbers(f"{ptr}/support/lower", sp["lower"], 3, "a support region's lower corner")
        hi = r.numbers(f"{ptr}/support/upper", sp["upper"], 3, "a support region's upper corner")
        for i in range(3):
            if lo[i] > hi[i]:
                r.fail("E511", r.span(f"{ptr}/support/upper/{i}"), f"{ptr}/support: upper "
                       f"{'xyz'[i]} {fmt_num(hi[i])} is below lower {fmt_num(lo[i])}",
                       "the support region is the box from lower to upper, in the object's frame",
                       [Related(r.span(f"{ptr}/support/lower/{i}"), "lower bound")])
        support = Box((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2]))
    parent = r.pddl_name(f"{ptr}/parent", v["parent"]) if v.get("parent") is not None else None
    grasps = tuple(_native_grasp(r, f"{ptr}/grasps/{i}", g)
                   for i, g in enumerate(r.array(f"{ptr}/grasps", v.get("grasps", []))))
    sops = tuple(_native_stable_pose(r, f"{ptr}/stable_poses/{i}", sp)
                 for i, sp in enumerate(r.array(f"{ptr}/stable_poses",
                                                v.get("stable_poses", []))))
    children = [(r.pddl_name(f"{ptr}/attachments/{i}", c), r.span(f"{ptr}/attachments/{i}"))
                for i, c in enumerate(r.array(f"{ptr}/attachments", v.get("attachments", [])))]
    if children:
        attached.append(Attached(name, r.span(f"{ptr}/name"), children))
    obj = SceneObject(name, pose, movable, shape, support, parent, r.origin(r.span(ptr), ptr),
                      grasps, sops, tuple(c for c, _ in children))
    return Entry(obj, r.span(f"{ptr}/name"), r.span(f"{ptr}/parent") if parent else None)


def _axis(r: JsonReader, ptr: str, value: Any) -> Vec3:
    a = r.numbers(ptr, value, 3, "an axis")
    n = sum(c * c for c in a) ** 0.5
    if n < 1e-9:
        r.fail("E523", r.span(ptr), f"{ptr}: the axis is the zero vector",
               "an axis is a direction, e.g. [0, 0, 1] (z)")
    return (a[0] / n, a[1] / n, a[2] / n)


def _native_grasp(r: JsonReader, ptr: str, value: Any) -> GraspSet:
    """``{"kind": "side", "template": POSE, "axis": [x, y, z] | null}``: a grasp set
    (:class:`~tmpc.lang.world.scene.GraspSet`; without an axis, one discrete frame)."""
    v = r.obj(ptr, value, ("template",), ("kind", "axis"))
    kind = r.string(f"{ptr}/kind", v["kind"], nonempty=False) if "kind" in v else ""
    template = r.pose(f"{ptr}/template", v["template"], False)
    axis = _axis(r, f"{ptr}/axis", v["axis"]) if v.get("axis") is not None else None
    return GraspSet(kind, template, axis, r.origin(r.span(ptr), ptr))


def _native_stable_pose(r: JsonReader, ptr: str, value: Any) -> StablePose:
    """``{"rotation": [x, y, z, w], "axis": [x, y, z], "distance": d}``
    (:class:`~tmpc.lang.world.scene.StablePose`)."""
    v = r.obj(ptr, value, ("rotation", "axis"), ("distance",))
    rotation = r.quaternion(f"{ptr}/rotation", v["rotation"])
    distance = r.number(f"{ptr}/distance", v["distance"]) if "distance" in v else 0.0
    return StablePose(rotation, _axis(r, f"{ptr}/axis", v["axis"]), distance,
                      r.origin(r.span(ptr), ptr))


def extras_json(obj: SceneObject) -> dict[str, Any]:
    """The native JSON keys of an object's grasp sets, stable poses and attachments (none when it
    has none): what a normalized native scene needs to carry a planet scene's `<grasps>`,
    `<sop>` and `<attachments>` over."""
    out: dict[str, Any] = {}
    if obj.grasps:
        out["grasps"] = [{"kind": g.kind, "template": {
            "translation": list(g.template.translation), "rotation": list(g.template.rotation)},
            "axis": list(g.axis) if g.axis is not None else None} for g in obj.grasps]
    if obj.stable_poses:
        out["stable_poses"] = [{"rotation": list(sp.template), "axis": list(sp.axis),
                                "distance": sp.distance} for sp in obj.stable_poses]
    if obj.attachments:
        out["attachments"] = list(obj.attachments)
    return out


def _native_shape(r: JsonReader, ptr: str, value: Any, opts: SceneOptions) -> Shape:
    if not isinstance(value, dict):
        r.type_error(ptr, value, 'a shape {"type": "box" | "sphere" | "cylinder" | "mesh", ...}')
    if "type" not in value:
        r.fail("E505", r.head(ptr), f"{ptr}: missing \"type\"",
               'add "type": "box" (or "sphere", "cylinder", "mesh")')
    t = r.string(f"{ptr}/type", value["type"])
    if t not in _SHAPE_KEYS:
        r.fail("E517", r.span(f"{ptr}/type"), f"{ptr}/type: unknown shape type \"{t}\"",
               join_hints(did_you_mean(t, _SHAPE_KEYS), "the types are box, sphere, cylinder "
                           "and mesh"))
    req, opt = _SHAPE_KEYS[t]
    v = r.obj(ptr, value, ("type", *req), opt)
    num = lambda k, what: r.positive(f"{ptr}/{k}", r.number(f"{ptr}/{k}", v[k]), what)  # noqa: E731
    if t == "box":
        he = r.numbers(f"{ptr}/half_extents", v["half_extents"], 3, "half-extents")
        for i, x in enumerate(he):
            r.positive(f"{ptr}/half_extents/{i}", x, "a half-extent", allow_zero=True)
        return Shape("box", size=(he[0], he[1], he[2]))
    if t == "sphere":
        return Shape("sphere", radius=num("radius", "a radius"))
    if t == "cylinder":
        return Shape("cylinder", radius=num("radius", "a radius"), length=num("length", "a length"))
    raw = r.string(f"{ptr}/file", v["file"])
    bases = [r.directory] + ([opts.mesh_dir] if opts.mesh_dir else [])
    mesh = resolve_mesh(r, opts, raw, r.span(f"{ptr}/file"), f"{ptr}/file", bases)
    scale: tuple[float, ...] = (1.0, 1.0, 1.0)
    if "scale" in v:
        sv = v["scale"]
        scale = (r.number(f"{ptr}/scale", sv),) * 3 if not isinstance(sv, list) \
            else r.numbers(f"{ptr}/scale", sv, 3, "a scale")
        for i, x in enumerate(scale):
            r.positive(f"{ptr}/scale" + (f"/{i}" if isinstance(sv, list) else ""), x, "a scale")
    convex = r.boolean(f"{ptr}/convex", v.get("convex", False))
    return Shape("mesh", mesh=mesh, scale=(scale[0], scale[1], scale[2]), convex=convex)


def _native_pairs(r: JsonReader, value: Any, frames: dict[str, str]) -> tuple[tuple[str, str], ...]:
    ptr = "/allowed_collisions"
    if isinstance(value, str):
        found, tried = find_file(value, [r.directory])
        if found is None:
            r.fail("E515", r.span(ptr), f"{ptr}: allowed-collision file \"{value}\" not found",
                   tried_text(tried))
        return load_allowed_pairs(found, r.report)
    pairs: list[tuple[str, str, Span | None]] = []
    for i, p in enumerate(r.array(ptr, value, 'an array of name pairs [["a", "b"], ...] or a '
                                              'CSV file name')):
        with r.part():
            if not isinstance(p, list) or len(p) != 2:
                r.fail("E507", r.span(f"{ptr}/{i}"), f"{ptr}/{i}: expected a pair of names "
                       "[\"a\", \"b\"]", 'write ["link_or_object", "other"]')
            pairs.append((r.string(f"{ptr}/{i}/0", p[0]), r.string(f"{ptr}/{i}/1", p[1]),
                          r.span(f"{ptr}/{i}")))
    return check_pairs(r, pairs, frames)
