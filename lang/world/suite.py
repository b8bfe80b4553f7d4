"""The Lagriffoul et al. 2018 suite's elements of the planet XML: grasp sets, stable object poses,
attachments (initial stacks), the PR2's arm values and its model, and the support regions' forms.

Each reader takes the planet :class:`~tmpc.lang.world.xmlreader.XmlReader` and an element and
returns the scene model's value (docs/world.md, "planet scene XML"); every problem is a
diagnostic at the element (E505-E511, E521-E523; W500, W508-W510).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
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
