"""The Lagriffoul et al. 2018 suite's elements of the planet XML: grasp sets, stable object poses,
attachments (initial stacks), the PR2's arm values and its model, and the support regions' forms.

Each reader takes the planet :class:`~tmpc.lang.world.xmlreader.XmlReader` and an element and
returns the scene model's value (docs/world.md, "planet scene XML"); every problem is a
diagnostic at the element (E505-E511, E521-E523; W500, W508-W510).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

from tmpc.lang.diagnostics import Related
from tmpc.lang.source import Span
from tmpc.lang.world.files import find_first, search_dirs
from tmpc.lang.world.reader import ROTATION_TOLERANCE, Reader, did_you_mean, fmt_num, join_hints
from tmpc.lang.world.robot import example_robot_data_dir
from tmpc.lang.world.rotations import orthonormality_error, quat_from_matrix
from tmpc.lang.world.scene import Box, GraspSet, StablePose, Vec3
from tmpc.lang.world.xmldoc import XmlNode
from tmpc.lang.world.xmlreader import XmlReader

#: the grasp types the suite's files use (`<gc type="side">`, `<gc type="top">`)
GRASP_KINDS = ("side", "top")

#: the PR2 arm joints, in the order of the suite's `<left_arm>`/`<right_arm>` values (with the
#: arm's prefix `l_` or `r_`)
PR2_ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "upper_arm_roll_joint",
                  "elbow_flex_joint", "forearm_roll_joint", "wrist_flex_joint", "wrist_roll_joint")

#: example-robot-data's PR2, relative to its `share/example-robot-data`
ERD_PR2 = Path("robots") / "pr2_description" / "urdf" / "pr2.urdf"


def axis(r: XmlReader, node: XmlNode) -> Vec3:
    """A direction: 3 finite numbers, not all 0 (E523); returned as a unit vector."""
    v = r.floats(node, (3,), "an axis")
    n = math.sqrt(sum(c * c for c in v))
    if n < 1e-9:
        r.fail("E523", r.text_span(node), f"{r.label(node)}: the axis is the zero vector",
               "an axis is a direction, e.g. 0 0 1 (z)")
    return (v[0] / n, v[1] / n, v[2] / n)


def grasps(r: XmlReader, node: XmlNode) -> tuple[GraspSet, ...]:
    """`<grasps>`: each `<gc type=..>` (a template and an axis) and `<gf type=..>` (a template,
    or the 12 numbers written inside)."""
    r.check_children(node, ("gc", "gf"))
    out: list[GraspSet] = []
    for g in node.children:
        if g.tag not in ("gc", "gf"):
            continue
        with r.part():
            kind = g.attrib.get("type", "").strip().lower()
            if kind not in GRASP_KINDS:
                r.warn("W509", r.start_tag(g), f"{r.label(node)}: <{g.tag}> of type "
                       f"\"{g.attrib.get('type', '')}\" (the suite's types are "
                       f"{', '.join(GRASP_KINDS)}); kept as written",
                       join_hints(did_you_mean(kind, GRASP_KINDS),
                                  'write <gc type="side"> or <gc type="top">'))
            if g.tag == "gc":
                r.check_children(g, ("template", "axis"))
                template = r.pose(r.need(g, "template"))
                out.append(GraspSet(kind, template, axis(r, r.need(g, "axis")),
                                    r.origin(r.start_tag(g), g.path)))
            else:
                r.check_children(g, ("template",))
                t = g.child("template")
                template = r.pose(t if t is not None or not g.text else g)
                out.append(GraspSet(kind, template, None, r.origin(r.start_tag(g), g.path)))
    return tuple(out)


def stable_pose(r: XmlReader, node: XmlNode) -> StablePose:
    """`<sop>`: a 3x3 rotation (9 numbers, row by row), an axis and a distance."""
    r.check_children(node, ("template", "axis", "distance"))
    t = r.need(node, "template")
    v = r.floats(t, (9,), "a stable pose's template (a 3x3 rotation, row by row)")
    rot = [v[0:3], v[3:6], v[6:9]]
    dev, det = orthonormality_error(rot)
    if dev > ROTATION_TOLERANCE or det <= 0:
        what = "is a reflection (determinant < 0)" if dev <= ROTATION_TOLERANCE \
            else f"is not a rotation: R Rᵀ differs from I by {fmt_num(dev)}"
        r.fail("E509", r.text_span(t), f"{r.label(t)}: the template {what} (tolerance "
               f"{ROTATION_TOLERANCE:g})", "the identity is 1 0 0 0 1 0 0 0 1")
    ax = axis(r, r.need(node, "axis"))
    d = node.child("distance")
    distance = r.floats(d, (1,), "<distance>")[0] if d is not None else 0.0
    return StablePose(quat_from_matrix(rot), ax, distance, r.origin(r.start_tag(node), node.path))


def attachment_names(r: XmlReader, node: XmlNode) -> list[tuple[str, Span]]:
    """`<attachments><name>a</name><name>b</name>...</attachments>`: the names and their spans."""
    r.check_children(node, ("name",))
    out = []
    for n in node.all("name"):
        with r.part():
            out.append((r.text(n), r.text_span(n)))
    return out


@dataclass
class Attached:
    """An object's `<attachments>` as written: the parent, its name's span, the children."""

    parent: str
    parent_span: Span | None
    children: list[tuple[str, Span]]


def check_attachments(r: Reader, written: list[Attached], names: dict[str, str]) -> None:
    """Each attached name is an object of the scene (E521), not the parent itself, attached to
    one parent only, and the attachments form no loop (E522). ``names``: lower -> as written.
    (Both the planet XML and the native JSON scene say attachments.)"""
    parent_of: dict[str, tuple[str, Span]] = {}
    for a in written:
        for child, span in a.children:
            key = child.lower()
            if key not in names:
                r.record("E521", span, f"\"{a.parent}\"'s attachments: \"{child}\" is no "
                         "object of the scene", join_hints(did_you_mean(child, names.values()),
                                                           "attachments name objects"))
            elif key == a.parent.lower():
                r.record("E522", span, f"\"{a.parent}\" is attached to itself")
            elif key in parent_of and parent_of[key][0].lower() != a.parent.lower():
                first, first_span = parent_of[key]
                r.record("E522", span, f"\"{child}\" is attached to two objects: \"{first}\" and "
                         f"\"{a.parent}\"", "an object rests on one parent",
                         [Related(first_span, f"attached to \"{first}\" here")])
            else:
                parent_of.setdefault(key, (a.parent, span))
    for start in list(parent_of):
        chain, cur = [names[start]], start
        while cur in parent_of:
            cur = parent_of[cur][0].lower()
            if cur == start:
                r.record("E522", parent_of[start][1], "attachments form a loop: "
                         + " on ".join(chain + [names[start]]), "one of them must rest on a "
                         "fixed object")
                for c in chain:
                    parent_of.pop(c.lower(), None)
                break
            if names.get(cur) in chain or len(chain) > len(names):
                break
            chain.append(names.get(cur, cur))


def support_form(box: Box) -> str:
    """A support region's form: a point, a segment, a rectangle or a box (the extents that are
    zero; the suite writes points on pegs and blocks, rectangles on tables)."""
    flat = sum(1 for lo, hi in zip(box.lower, box.upper) if hi - lo <= 1e-12)
    return {3: "point", 2: "segment", 1: "rectangle"}.get(flat, "box")


def arm_values(r: XmlReader, node: XmlNode, prefix: str) -> list[tuple[str, float]]:
    """`<left_arm>`/`<right_arm>`: the 7 initial values of the PR2 arm's joints, in the order
    of :data:`PR2_ARM_JOINTS`."""
    values = r.floats(node, (7,), f"<{node.tag}> (the 7 PR2 arm joints "
                      f"{prefix}shoulder_pan ... {prefix}wrist_roll)")
    return [(prefix + j, v) for j, v in zip(PR2_ARM_JOINTS, values)]


def fallback_urdf(r: XmlReader, raw: str, span: Span | None) -> str:
    """The URDF path to read for ``raw``: itself when it resolves; else, for a missing
    `pr2.urdf` (the suite's files write `models/pr2.urdf`), example-robot-data's PR2, with
    warning W508 naming the file used."""
    found, _ = find_first(raw, search_dirs(r.directory, r.legacy))
    if found is not None or Path(raw).name.lower() != "pr2.urdf":
        return raw
    erd = example_robot_data_dir()
    if erd is None or not (erd / ERD_PR2).is_file():
        return raw
    used = erd / ERD_PR2
    r.warn("W508", span, f"URDF \"{raw}\" not found; using example-robot-data's PR2 model "
           f"({used})", "put the suite's PR2 model there to use it instead")
    return str(used)


#: the PR2 finger joints that drive each gripper (the others mimic them)
PR2_GRIPPERS = ("l_gripper_l_finger_joint", "r_gripper_l_finger_joint")
#: the PR2 finger joint's upper limit: the gripper wide open
PR2_GRIPPER_OPEN = 0.548
#: how far (m) a base may stand from the scene's floor before it is put on it
FLOOR_SLACK = 0.05


def open_grippers(joints: list[tuple[str, float]], names) -> None:
    """The suite's robot block gives no gripper values and its problems grasp objects up to 8
    cm wide: a PR2's grippers start open (their upper limit), unless a value is given."""
    given = {n for n, _ in joints}
    for jn in PR2_GRIPPERS:
        if jn in given or jn not in names.joints:
            continue
        joints.append((jn, PR2_GRIPPER_OPEN))


def robot_on_floor(r: XmlReader, robot, objects, span: Span | None):
    """The suite's <basepose> heights disagree with its own scenes (the blocks world puts the
    PR2's base 0.70 m below its table's feet, the stick problems 0.67 m below the tables'); the
    floor of a scene is the height of its lowest fixed object's origin (the tables stand on it).
    A base farther than :data:`FLOOR_SLACK` from that floor is put on it, with warning W519."""
    fixed = [o.pose.translation[2] for o in objects if not o.movable]
    if robot is None or not fixed:
        return robot
    floor = min(fixed)
    x, y, z = robot.base_pose.translation
    if abs(z - floor) <= FLOOR_SLACK:
        return robot
    where = "below" if z < floor else "above"
    r.warn("W519", span, f"the robot's base is {abs(z - floor):.2f} m {where}"
           f" the scene's floor (z {floor:g}, the lowest fixed object's origin); it stands on the "
           "floor", "the suite's base heights disagree with its scenes; give a <basepose> z on "
           "the floor to silence this")
    return replace(robot, base_pose=replace(robot.base_pose, translation=(x, y, floor)))


#: how far (m) above its object's mesh a support region may float before it is lowered onto it
SUPPORT_FLOAT = 0.03


def _obj_vertices(path) -> list[tuple[float, float, float]]:
    """The vertices of an OBJ mesh (none: not an OBJ file, unreadable, or malformed)."""
    if path is None or Path(path).suffix.lower() != ".obj":
        return []
    out = []
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                parts = line.split()
                if len(parts) >= 4 and parts[0] == "v":
                    out.append((float(parts[1]), float(parts[2]), float(parts[3])))
    except (OSError, ValueError):
        return []
    return out


def _obj_top(path) -> float | None:
    """The highest vertex z of an OBJ mesh (None: no vertices)."""
    v = _obj_vertices(path)
    return max(p[2] for p in v) if v else None


def support_on_mesh(r: XmlReader, box: Box, mesh, span: Span | None, name: str) -> Box:
    """A flat support region (<sssp> zmin = zmax) up to :data:`SUPPORT_FLOAT` above the top of its
    object's mesh is lowered onto it, with warning W518: objects placed on it rest there instead
    of dropping (the suite's narrow table gives 0.78 over a top at 0.765)."""
    top = _obj_top(mesh)
    z = box.lower[2]
    if top is None or box.upper[2] != z or not 1e-4 < z - top <= SUPPORT_FLOAT:
        return box
    r.warn("W518", span, f"<obj> \"{name}\": the support region's height {z:g} is "
           f"{(z - top) * 1000:.0f} mm above the top of its mesh ({top:g}); it is lowered onto "
           "the mesh", "objects placed at the written height would drop; write the mesh's top")
    return Box((box.lower[0], box.lower[1], top), (box.upper[0], box.upper[1], top))


def _obj_radius(path) -> float:
    """Half the diagonal of an OBJ mesh's footprint (xy bounds); 0 without vertices."""
    v = _obj_vertices(path)
    if not v:
        return 0.0
    xs, ys = [p[0] for p in v], [p[1] for p in v]
    return math.hypot(max(xs) - min(xs), max(ys) - min(ys)) / 2


def separate_duplicates(r: XmlReader, objects: list, spans: list) -> list:
    """Movable objects written at the place of another (the suite's clutter.xml puts two pairs
    of sticks at one spot each): each later one moves sideways, by whole footprints, to the
    nearest place where its footprint meets no other movable object's, with warning W517. The
    footprint is the circle around the mesh's xy bounds; meshes are read only when a place is
    shared."""
    radii: dict[int, float] = {}

    def radius(i: int) -> float:
        if i not in radii:
            shape = objects[i].shape
            radii[i] = _obj_radius(shape.mesh if shape is not None else None)
        return radii[i]
    placed = [(i, o.pose.translation) for i, o in enumerate(objects) if o.movable]
    out = list(objects)
    for k, (i, p) in enumerate(placed):
        clash = [j for j, q in placed[:k] if math.dist(p[:2], q[:2]) < 1e-3 and
                 abs(p[2] - q[2]) < 0.05]
        if not clash:
            continue
        step = 2 * radius(i) + 0.01
        others = [(j, out[j].pose.translation) for j, _ in placed if j != i]
        for n in range(1, 6):
            cands = [(p[0] + dx * n * step, p[1] + dy * n * step, p[2])
                     for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))]
            free = [c for c in cands if all(math.dist(c[:2], q[:2]) >= radius(i) + radius(j)
                                             + 0.005 for j, q in others)]
            if free:
                new = free[0]
                break
        else:
            continue
        o = out[i]
        r.warn("W517", spans[i], f"<obj> \"{o.name}\" is written at the place of "
               f"\"{objects[clash[0]].name}\" ({fmt_num(p[0])}, {fmt_num(p[1])}); it is moved "
               f"to ({fmt_num(new[0])}, {fmt_num(new[1])}), the nearest free place",
               "give each object a place of its own")
        out[i] = replace(o, pose=replace(o.pose, translation=new))
        placed[k] = (i, new)
    return out
