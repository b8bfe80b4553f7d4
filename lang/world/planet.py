"""planet (Lagriffoul benchmark) scene XML (FACTS 4.1)."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Iterable

from tmpc.lang.diagnostics import Related
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world.files import UrdfNames
from tmpc.lang.world.files import resolve_mesh as resolve_mesh
from tmpc.lang.world.files import resolve_urdf as resolve_urdf
from tmpc.lang.world.names import Entry as Entry
from tmpc.lang.world.names import check_names as check_names
from tmpc.lang.world.names import known_joint as known_joint
from tmpc.lang.world.reader import (
    ROTATION_TOLERANCE,
    LoadReport,
    Reader,
    SceneOptions,
    did_you_mean,
    fmt_num,
)
from tmpc.lang.world.rotations import orthonormality_error, quat_from_matrix
from tmpc.lang.world.scene import Box, Pose, RobotSpec, Scene, SceneObject, Shape
from tmpc.lang.world.xmldoc import XmlNode, parse_xml

_PLANET_OBJ_KNOWN = ("name", "geom", "pose", "moveable", "sssp")
_PLANET_OBJ_IGNORED = ("sop", "gf", "gc", "grasps", "attachments")
_PLANET_ROBOT_KNOWN = ("name", "urdf", "basepose", "movebase", "torso", "controllable_joints")
#: planet's <torso> value is this PR2 joint's initial value
TORSO_JOINT = "torso_lift_joint"


class _XmlReader(Reader):
    def start_tag(self, node: XmlNode) -> Span:
        return Span(self.source.path, node.start, node.tag_end)

    def text_span(self, node: XmlNode) -> Span:
        if node.content is not None:
            return Span(self.source.path, *node.content)
        return self.start_tag(node)

    def label(self, node: XmlNode) -> str:
        """``<obj> "table1"`` where the element has a name, else its XML path."""
        owner = node if node.tag in ("obj", "robot") else node.parent
        if owner is not None and owner.tag in ("obj", "robot"):
            nm = owner.child("name")
            if nm is not None and nm.text:
                inner = "" if owner is node else f" <{node.tag}>"
                return f"<{owner.tag}> \"{nm.text}\"{inner}"
        return node.path

    def need(self, node: XmlNode, tag: str) -> XmlNode:
        c = node.child(tag)
        if c is None:
            self.fail("E505", self.start_tag(node), f"{self.label(node)} ({node.path}) has no "
                      f"<{tag}>", f"add <{tag}>...</{tag}> inside <{node.tag}>")
        return c

    def text(self, node: XmlNode) -> str:
        if not node.text:
            self.fail("E505", self.start_tag(node), f"{self.label(node)} is empty",
                      f"write a value between <{node.tag}> and </{node.tag}>")
        return node.text

    def floats(self, node: XmlNode, counts: tuple[int, ...], what: str) -> list[float]:
        parts = self.text(node).split()
        vals = []
        for p in parts:
            try:
                vals.append(float(p))
            except ValueError:
                self.fail("E506", self.text_span(node), f"{self.label(node)}: \"{p}\" is not a "
                          "number", f"{what} is {' or '.join(map(str, counts))} numbers "
                          "separated by spaces")
        if len(vals) not in counts:
            self.fail("E507", self.text_span(node), f"{self.label(node)}: {what} needs "
                      f"{' or '.join(map(str, counts))} numbers, found {len(vals)}")
        bad = [p for p, x in zip(parts, vals) if not math.isfinite(x)]
        if bad:
            self.fail("E507", self.text_span(node), f"{self.label(node)}: {what} needs finite "
                      f"numbers, found {bad[0]!r}")
        return vals

    def boolean(self, node: XmlNode) -> bool:
        t = self.text(node).lower()
        if t.startswith("true"):        # planet compares the first four characters
            return True
        if t.startswith("false"):
            return False
        self.fail("E506", self.text_span(node), f"{self.label(node)}: expected true or false, "
                  f"found \"{node.text}\"")

    def pose(self, node: XmlNode) -> Pose:
        """12 numbers: the rows of [R | t] (a 4th row 0 0 0 1 may follow)."""
        v = self.floats(node, (12, 16), "a pose (the 3x4 matrix [R | t], row by row)")
        if len(v) == 16 and any(abs(a - b) > 1e-9 for a, b in zip(v[12:], (0, 0, 0, 1))):
            self.fail("E509", self.text_span(node), f"{self.label(node)}: the last row of a 4x4 "
                      f"pose must be 0 0 0 1, found {' '.join(map(fmt_num, v[12:]))}")
        rot = [v[0:3], v[4:7], v[8:11]]
        dev, det = orthonormality_error(rot)
        if dev > ROTATION_TOLERANCE or det <= 0:
            what = "is a reflection (determinant < 0)" if det <= 0 and dev <= ROTATION_TOLERANCE \
                else f"is not a rotation: R Rᵀ differs from I by {fmt_num(dev)}"
            self.fail("E509", self.text_span(node), f"{self.label(node)}: the 3x3 part {what} "
                      f"(tolerance {ROTATION_TOLERANCE:g})", "the 12 numbers are r00 r01 r02 tx "
                      "r10 r11 r12 ty r20 r21 r22 tz; the identity pose at (x, y, z) is "
                      "1 0 0 x 0 1 0 y 0 0 1 z")
        return Pose((v[3], v[7], v[11]), quat_from_matrix(rot))

    def check_children(self, node: XmlNode, known: Iterable[str],
                       ignored: Iterable[str] = ()) -> None:
        known, ignored = tuple(known), tuple(ignored)
        for c in node.children:
            if c.tag not in known and c.tag not in ignored:
                self.warn("W500", self.start_tag(c), f"{self.label(node)}: unknown element "
                          f"<{c.tag}> (ignored)", did_you_mean(c.tag, known))


def load_planet_scene(source: SourceFile, opts: SceneOptions, report: LoadReport,
                      root: XmlNode | None = None) -> Scene:
    root = root or parse_xml(source, report)
    r = _XmlReader(source, report, legacy=True)
    scene = None
    with r.part():
        scene = _planet_scene(r, root, opts)
    r.finish()
    assert scene is not None
    return scene


def _planet_scene(r: _XmlReader, root: XmlNode, opts: SceneOptions) -> Scene:
    r.check_children(root, ("objects", "robots", "workspace_bounds"))
    objects = r.need(root, "objects")
    robots = r.need(root, "robots")
    r.check_children(objects, ("obj",))
    entries: list[Entry] = []
    mesh_bases = [opts.mesh_dir] if opts.mesh_dir else [r.directory]
    for node in objects.all("obj"):
        with r.part():
            entries.append(_planet_object(r, node, opts, mesh_bases))
    robot = urdf = None
    with r.part():
        robot, urdf = _planet_robot(r, robots)
    bounds = None
    with r.part():
        bounds = _planet_bounds(r, root, entries, robot)
    check_names(r, entries, robot, urdf)
    r.finish()
    return Scene(r.source.path, bounds, robot, tuple(e.obj for e in entries), (),  # type: ignore[arg-type]
                 "planet-xml")


def _planet_object(r: _XmlReader, node: XmlNode, opts: SceneOptions,
                   mesh_bases: list[Path]) -> Entry:
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
    obj = SceneObject(name, pose, movable, Shape("mesh", mesh=mesh, convex=False), support, None,
                      r.origin(r.start_tag(node), node.path))
    return Entry(obj, r.text_span(name_node))


def _planet_robot(r: _XmlReader, robots: XmlNode) -> tuple[RobotSpec, UrdfNames]:
    r.check_children(robots, ("robot",))
    all_robots = robots.all("robot")
    node = r.need(robots, "robot")
    if len(all_robots) > 1:
        r.warn("W506", r.start_tag(all_robots[1]), f"{robots.path}: more than one <robot>; only "
               "the first is used, as planet did")
    r.check_children(node, _PLANET_ROBOT_KNOWN)
    name_node = node.child("name")
    urdf_node = r.need(node, "urdf")
    path, names = resolve_urdf(r, r.text(urdf_node), r.text_span(urdf_node), r.label(urdf_node))
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
    controllable: tuple[str, ...] | None = None
    cj = node.child("controllable_joints")
    if cj is not None:
        controllable = _planet_joints(r, cj, names, joints)
    return RobotSpec(path, pose, mobile, tuple(joints), controllable, name,
                     r.origin(r.start_tag(node), node.path)), names


def _planet_joints(r: _XmlReader, cj: XmlNode, names: UrdfNames,
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


def _planet_bounds(r: _XmlReader, root: XmlNode, entries: list[Entry],
                   robot: RobotSpec | None) -> tuple[tuple[float, float], ...]:
    wb = root.child("workspace_bounds")
    if wb is None:
        pts = [e.obj.pose.translation for e in entries]
        pts += [robot.base_pose.translation] if robot else []
        pts = pts or [(0.0, 0.0, 0.0)]
        margin = 2.0
        b = tuple((min(p[i] for p in pts) - margin, max(p[i] for p in pts) + margin)
                  for i in range(2)) + ((0.0, max(p[2] for p in pts) + margin),)
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
