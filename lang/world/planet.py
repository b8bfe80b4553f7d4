"""planet (Lagriffoul benchmark) scene XML (FACTS 4.1)."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

from tmpc.lang.diagnostics import Related
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world.files import UrdfNames
from tmpc.lang.world.files import resolve_mesh as resolve_mesh
from tmpc.lang.world.files import resolve_urdf as resolve_urdf
from tmpc.lang.world.names import Entry as Entry
from tmpc.lang.world.names import check_names as check_names
from tmpc.lang.world.names import known_joint as known_joint
from tmpc.lang.world.reader import LoadReport, SceneOptions, fmt_num
from tmpc.lang.world.scene import Box, Pose, RobotSpec, Scene, SceneObject, Shape
from tmpc.lang.world.suite import (
    Attached,
    arm_values,
    attachment_names,
    check_attachments,
    fallback_urdf,
    grasps,
    open_grippers,
    robot_on_floor,
    separate_duplicates,
    support_on_mesh,
    stable_pose,
)
from tmpc.lang.world.xmldoc import XmlNode, parse_xml
from tmpc.lang.world.xmlreader import XmlReader

_PLANET_OBJ_KNOWN = ("name", "geom", "pose", "moveable", "sssp", "grasps", "sop", "attachments")
#: grasp frames written directly in the <obj> (no file of the suite does): ignored, as planet did
_PLANET_OBJ_IGNORED = ("gf", "gc")
_PLANET_ROBOT_KNOWN = ("name", "urdf", "basepose", "movebase", "torso", "left_arm", "right_arm",
                       "controllable_joints")
#: planet's <torso> value is this PR2 joint's initial value
TORSO_JOINT = "torso_lift_joint"


def load_planet_scene(source: SourceFile, opts: SceneOptions, report: LoadReport,
                      root: XmlNode | None = None) -> Scene:
    root = root or parse_xml(source, report)
    r = XmlReader(source, report, legacy=True)
    scene = None
    with r.part():
        scene = _planet_scene(r, root, opts)
    r.finish()
    assert scene is not None
    return scene


def _planet_scene(r: XmlReader, root: XmlNode, opts: SceneOptions) -> Scene:
    r.check_children(root, ("objects", "robots", "workspace_bounds"))
    objects = r.need(root, "objects")
    robots = r.need(root, "robots")
    r.check_children(objects, ("obj",))
    entries: list[Entry] = []
    attached: list[Attached] = []
    mesh_bases = [opts.mesh_dir] if opts.mesh_dir else [r.directory, *_mesh_folders(r.directory)]
    for node in objects.all("obj"):
        with r.part():
            entries.append(_planet_object(r, node, opts, mesh_bases, attached))
    check_attachments(r, attached, {e.obj.name.lower(): e.obj.name for e in entries})
    robot = urdf = None
    with r.part():
        robot, urdf = _planet_robot(r, robots)
    moved = separate_duplicates(r, [e.obj for e in entries], [e.name_span for e in entries])
    entries = [replace(e, obj=o) if o is not e.obj else e for e, o in zip(entries, moved)]
    robot = robot_on_floor(r, robot, [e.obj for e in entries],
                           r.start_tag(robots.child("robot")) if robots.child("robot") else None)
    bounds = None
    with r.part():
        bounds = _planet_bounds(r, root, entries, robot)
    check_names(r, entries, robot, urdf)
    r.finish()
    return Scene(r.source.path, bounds, robot, tuple(e.obj for e in entries), (),  # type: ignore[arg-type]
                 "planet-xml")


def _mesh_folders(directory: Path) -> list[Path]:
    """The `*_meshes` folders beside a scene and beside its folder (the suite keeps
    `problem1/hanoi_xml/hanoi3.xml` beside `problem1/hanoi_meshes/`), where a scene read
    without a mesh directory also finds its meshes."""
    out: list[Path] = []
    for d in (directory, directory.parent):
        try:
            out += sorted(p for p in d.iterdir() if p.is_dir() and p.name.endswith("_meshes"))
        except OSError:
            pass
    return out


def _planet_object(r: XmlReader, node: XmlNode, opts: SceneOptions,
                   mesh_bases: list[Path], attached: list[Attached]) -> Entry:
    r.check_children(node, _PLANET_OBJ_KNOWN + ("pssp",), _PLANET_OBJ_IGNORED)
    name_node = r.need(node, "name")
    name = r.text(name_node)
    if re.search(r"[\s()\";]", name):
        r.fail("E518", r.text_span(name_node), f"<obj> \"{name}\" cannot be used as a name in "
               "PDDL", "names have no spaces, brackets, quotes or `;`")
    geom = r.need(node, "geom")
    mesh = resolve_mesh(r, opts, r.text(geom), r.text_span(geom), r.label(geom), mesh_bases)
    pose = r.pose(r.need(node, "pose"))
    mv = node.child("moveable")
    movable = r.boolean(mv) if mv is not None else False
    support = None
    if node.child("pssp") is not None:
        r.warn("W500", r.start_tag(node.child("pssp")), f"{r.label(node)}: <pssp> is not "
               "supported (ignored)", "give the support region as <sssp> xmin..zmax")
    sssp = node.child("sssp")
    if sssp is not None:
        v = {}
        for key in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax"):
            v[key] = r.floats(r.need(sssp, key), (1,), f"<{key}>")[0]
        for a in "xyz":
            if v[a + "min"] > v[a + "max"]:
                r.fail("E511", r.text_span(sssp.child(a + "max")), f"{r.label(sssp)}: "
                       f"{a}max {fmt_num(v[a + 'max'])} is below {a}min {fmt_num(v[a + 'min'])}",
                       related=[Related(r.text_span(sssp.child(a + "min")), f"{a}min")])
        # Read in the object's frame: the table mesh spans x in [-0.8, 0.7], y in [-0.35, 0.35]
        # and the clutter files give xmin..xmax = -0.75..0.75 for rotated and unrotated tables.
        support = Box((v["xmin"], v["ymin"], v["zmin"]), (v["xmax"], v["ymax"], v["zmax"]))
        support = support_on_mesh(r, support, mesh, r.text_span(sssp.child("zmin")), name)
    grasp_sets, sops, children = (), [], []
    with r.part():
        for g in node.all("grasps"):
            grasp_sets += grasps(r, g)
    for sop in node.all("sop"):
        with r.part():
            sops.append(stable_pose(r, sop))
    for att in node.all("attachments"):
        with r.part():
            children += attachment_names(r, att)
    if children:
        attached.append(Attached(name, r.text_span(name_node), children))
    obj = SceneObject(name, pose, movable, Shape("mesh", mesh=mesh, convex=False), support, None,
                      r.origin(r.start_tag(node), node.path), tuple(grasp_sets), tuple(sops),
                      tuple(c for c, _ in children))
    return Entry(obj, r.text_span(name_node))


def _planet_robot(r: XmlReader, robots: XmlNode) -> tuple[RobotSpec, UrdfNames]:
    r.check_children(robots, ("robot",))
    all_robots = robots.all("robot")
    node = r.need(robots, "robot")
    if len(all_robots) > 1:
        r.warn("W506", r.start_tag(all_robots[1]), f"{robots.path}: more than one <robot>; only "
               "the first is used, as planet did")
    r.check_children(node, _PLANET_ROBOT_KNOWN)
    name_node = node.child("name")
    urdf_node = r.need(node, "urdf")
    raw = fallback_urdf(r, r.text(urdf_node), r.text_span(urdf_node))
    path, names = resolve_urdf(r, raw, r.text_span(urdf_node), r.label(urdf_node))
    name = r.text(name_node) if name_node is not None else names.robot
    bp = node.child("basepose")
    pose = r.pose(bp) if bp is not None else Pose()
    mb = node.child("movebase")
    mobile = r.boolean(mb) if mb is not None else False
    joints: list[tuple[str, float]] = []
    torso = node.child("torso")
    if torso is not None:
        value = r.floats(torso, (1,), "<torso>")[0]
        if known_joint(r, TORSO_JOINT, names, r.start_tag(torso), r.label(torso), warn=True):
            joints.append((TORSO_JOINT, value))
    for tag, prefix in (("left_arm", "l_"), ("right_arm", "r_")):
        arm = node.child(tag)
        if arm is not None:
            with r.part():
                for jn, value in arm_values(r, arm, prefix):
                    if known_joint(r, jn, names, r.text_span(arm), r.label(arm), warn=True):
                        joints.append((jn, value))
    open_grippers(joints, names)
    controllable: tuple[str, ...] | None = None
    cj = node.child("controllable_joints")
    if cj is not None:
        controllable = _planet_joints(r, cj, names, joints)
    return RobotSpec(path, pose, mobile, tuple(joints), controllable, name,
                     r.origin(r.start_tag(node), node.path)), names


def _planet_joints(r: XmlReader, cj: XmlNode, names: UrdfNames,
                   joints: list[tuple[str, float]]) -> tuple[str, ...]:
    r.check_children(cj, ("joint",))
    order: list[str] = []
    for j in cj.all("joint"):
        with r.part():
            jn = j.attrib.get("name")
            if not jn:
                r.fail("E505", r.start_tag(j), f"{j.path}: <joint> without a name attribute",
                       'write <joint name="...">initial value</joint>')
            if jn in order:
                r.fail("E510", r.start_tag(j), f"{j.path}: joint \"{jn}\" listed twice")
            known_joint(r, jn, names, r.start_tag(j), r.label(cj), movable=True)
            value = r.floats(j, (1,), f"joint \"{jn}\"'s initial value")[0]
            order.append(jn)
            joints[:] = [(n, x) for n, x in joints if n != jn] + [(jn, value)]
    return tuple(order)


def _planet_bounds(r: XmlReader, root: XmlNode, entries: list[Entry],
                   robot: RobotSpec | None) -> tuple[tuple[float, float], ...]:
    wb = root.child("workspace_bounds")
    if wb is None:
        pts = [e.obj.pose.translation for e in entries]
        pts += [robot.base_pose.translation] if robot else []
        pts = pts or [(0.0, 0.0, 0.0)]
        margin = 2.0
        b = tuple((min(p[i] for p in pts) - margin, max(p[i] for p in pts) + margin)
                  for i in range(2)) + ((min(0.0, min(p[2] for p in pts)),
                                               max(p[2] for p in pts) + margin),)
        r.warn("W505", Span(r.source.path, root.start, root.tag_end), "no <workspace_bounds>: "
               "using the objects' and robot's extent plus 2 m (" + ", ".join(
                   f"{a} {fmt_num(lo)}..{fmt_num(hi)}" for a, (lo, hi) in zip("xyz", b)) + ")",
               "add <workspace_bounds><x><low>..</low><high>..</high></x>...</workspace_bounds>")
        return b
    r.check_children(wb, ("x", "y", "z"))
    out = []
    for a in "xyz":
        axis = r.need(wb, a)
        lo_node, hi_node = r.need(axis, "low"), r.need(axis, "high")
        lo = r.floats(lo_node, (1,), "<low>")[0]
        hi = r.floats(hi_node, (1,), "<high>")[0]
        if lo > hi:
            r.fail("E511", r.text_span(hi_node), f"{axis.path}: high {fmt_num(hi)} is below low "
                   f"{fmt_num(lo)}", related=[Related(r.text_span(lo_node), "low")])
        out.append((lo, hi))
    return tuple(out)
