"""Reading planet (Lagriffoul benchmark) XML elements with positions: text, numbers, booleans,
poses, required and unknown children, each problem a diagnostic at the element."""

from __future__ import annotations

import math
from typing import Iterable

from tmpc.lang.source import Span
from tmpc.lang.world.reader import ROTATION_TOLERANCE, Reader, did_you_mean, fmt_num
from tmpc.lang.world.rotations import orthonormality_error, quat_from_matrix
from tmpc.lang.world.scene import Pose
from tmpc.lang.world.xmldoc import XmlNode


class XmlReader(Reader):
    """The planet XML reader's checks: an element's spans and label, required children, numbers,
    booleans, poses (the 3x4 matrix) and unknown children (W500)."""

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
