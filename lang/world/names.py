"""Checks across a whole scene: object names unique and not robot frames, parents known and
acyclic, collision pairs naming known frames, joints the URDF has."""

from __future__ import annotations

from dataclasses import dataclass

from tmpc.lang.diagnostics import Related
from tmpc.lang.source import Span
from tmpc.lang.world.files import UrdfNames
from tmpc.lang.world.reader import Reader, did_you_mean, join_hints
from tmpc.lang.world.scene import RobotSpec, SceneObject


@dataclass
class Entry:
    """An object as loaded plus where its name and parent were written."""

    obj: SceneObject
    name_span: Span | None
    parent_span: Span | None = None


def check_names(r: Reader, entries: list[Entry], robot: RobotSpec | None,
                 urdf: UrdfNames | None) -> None:
    first: dict[str, Entry] = {}
    for e in entries:
        key = e.obj.name.lower()
        if key in first:
            r.record("E510", e.name_span, f"object name \"{e.obj.name}\" used twice",
                     "names are compared without case (PDDL is case-insensitive); rename one",
                     [Related(first[key].name_span, "first used here")]
                     if first[key].name_span else [])
        else:
            first[key] = e
    frames = frame_names(entries, robot, urdf)
    for e in entries:
        p = e.obj.parent
        if p is None:
            continue
        if p.lower() == e.obj.name.lower():
            r.record("E513", e.parent_span, f"object \"{e.obj.name}\" is its own parent")
        elif p.lower() not in frames:
            r.record("E513", e.parent_span, f"object \"{e.obj.name}\": unknown parent \"{p}\"",
                     join_hints(did_you_mean(p, frames.values()), "a parent is another object, "
                                 "the robot, or one of the robot's links or joints"))
    check_cycles(r, entries, first)


def frame_names(entries: list[Entry], robot: RobotSpec | None,
                 urdf: UrdfNames | None) -> dict[str, str]:
    """Every name a pose can be relative to or a collision pair can mention (lower -> as written)."""
    names = [e.obj.name for e in entries]
    if robot is not None:
        names.append(robot.name)
    if urdf is not None:
        names += [*urdf.links, *urdf.joints, urdf.robot]
    return {n.lower(): n for n in names}


def check_cycles(r: Reader, entries: list[Entry], by_name: dict[str, Entry]) -> None:
    reported: set[str] = set()
    for e in entries:
        chain, cur = [e.obj.name], e
        while cur.obj.parent and cur.obj.parent.lower() in by_name:
            nxt = by_name[cur.obj.parent.lower()]
            if nxt.obj.name.lower() == e.obj.name.lower():
                if not reported & {c.lower() for c in chain}:
                    r.record("E513", e.parent_span, "parents form a loop: "
                             + " -> ".join(chain + [e.obj.name]), "one of them must be placed in "
                             "the world or on the robot")
                reported.add(e.obj.name.lower())
                break
            if nxt.obj.name in chain or len(chain) > len(entries):
                break
            chain.append(nxt.obj.name)
            cur = nxt


def check_pairs(r: Reader, pairs: list[tuple[str, str, Span | None]],
                 frames: dict[str, str]) -> tuple[tuple[str, str], ...]:
    out: list[tuple[str, str]] = []
    for a, b, span in pairs:
        for n in (a, b):
            if n.lower() not in frames:
                r.record("E513", span, f"allowed collision names \"{n}\", which is no object, "
                         "robot link or joint", join_hints(did_you_mean(n, frames.values())))
        if (a, b) not in out and (b, a) not in out:
            out.append((a, b))
    return tuple(out)


def known_joint(r: Reader, joint: str, names: UrdfNames, span: Span | None, where: str,
                 warn: bool = False, movable: bool = False) -> bool:
    """Is ``joint`` a joint of the URDF (``movable``: one a planner can move)? Else E564 (or,
    for legacy joint values, warning W502 and the value is dropped)."""
    if joint in (names.movable if movable else names.joints):
        return True
    what = "has no joint" if joint not in names.joints else "has as a fixed or mimic joint"
    msg = f"{where}: the URDF ({names.robot}) {what} \"{joint}\""
    hint = did_you_mean(joint, names.movable if movable else names.joints)
    if warn:
        r.warn("W502", span, msg + " (ignored)", hint)
        return False
    r.fail("E564", span, msg, hint)
