"""A plan state as the validator resolves it against the world, the tolerances it compares with,
and the small pose and text helpers its checks share (:mod:`tmpc.runtime.validate.core`,
:mod:`tmpc.runtime.validate.checks`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tmpc.runtime.validate.logic import Facts
from tmpc.runtime.validate.report import Violation

#: positions (m) and angles (rad) closer than this are the same
POSE_TOL = 1e-4
#: a released object rests on a support when its lowest point is at most this far above the
#: support's top (or the support region's floor) and this far into it (m), and its nearest axis
#: is within SUPPORT_TILT of vertical (rad)
SUPPORT_GAP, SUPPORT_SINK, SUPPORT_TILT = 0.01, 0.005, math.radians(5.0)
#: a support region thinner than twice this (a point or a segment: the benchmark suite's pegs,
#: blocks and targets) is met within it sideways (stdlib `placed-on` places within 5 mm)
SUPPORT_SLACK = 0.008
#: every support region is met within this sideways (m): the language's truth tolerance
#: (tmpc's `inside` holds within 1 mm), where a projection lands on a region's edge (Blocks
#: World's `putdown a red-tray`: the block's origin 0.09 mm past the tray region's corner)
SUPPORT_EDGE = 0.001
#: slack on joint limits and on values that must not change (rad or m)
JOINT_TOL = 1e-6

@dataclass
class ResolvedState:
    """A plan state resolved against the world."""

    index: int
    values: dict[str, float]          # independent movable joints
    T_root: np.ndarray
    link_T: np.ndarray                # (L, 4, 4)
    objects: dict[str, np.ndarray]    # scene name -> world pose
    facts: Facts
    held: dict[str, str]              # object (scene name) -> parent (frame or object name)
    action: tuple | None = None
    geo_cache: dict = field(default_factory=dict)   # (predicate, args) -> (truth, distance)


def pose_gap(A: np.ndarray, B: np.ndarray) -> float:
    """max(translation distance, rotation angle) between two poses."""
    dt = float(np.linalg.norm(A[:3, 3] - B[:3, 3]))
    fro = float(np.linalg.norm(A[:3, :3] - B[:3, :3]))
    return max(dt, 2 * math.asin(min(1.0, fro / (2 * math.sqrt(2)))))


def pose_text(A: np.ndarray, B: np.ndarray) -> str:
    dt = float(np.linalg.norm(A[:3, 3] - B[:3, 3]))
    fro = float(np.linalg.norm(A[:3, :3] - B[:3, :3]))
    ang = 2 * math.asin(min(1.0, fro / (2 * math.sqrt(2))))
    return f"{dt:.4g} m" + (f", {math.degrees(ang):.3g} deg" if ang > POSE_TOL else "")


def held_order(held: dict[str, str]) -> list[str]:
    """Held objects, parents before the objects linked to them."""
    out: list[str] = []

    def visit(o, depth=0):
        if o in out or depth > len(held):
            return
        if held.get(o) in held:
            visit(held[o], depth + 1)
        out.append(o)
    for o in held:
        visit(o)
    return out


def report_order(v: Violation) -> tuple:
    """Report order: plan-wide first, then by state (a motion after its first state's own
    violations), the goal last; stable otherwise."""
    if v.state is None:
        return (0, 0, 0)
    if v.kind == "goal":
        return (2, 0, 0)
    return (1, v.state, 0 if v.to is None else 1)


def norm_action(a):
    return None if a is None else (a[0].lower(), tuple(x.lower() for x in a[1]))


def num_text(v) -> str:
    return "-inf" if v is None else f"{v:.6g}"


def action_text(action) -> str:
    return "(" + " ".join((action[0],) + tuple(action[1])) + ")"


def dict_text(d: dict) -> str:
    return "{" + ", ".join(f"{k}: {v}" for k, v in sorted(d.items())) + "}"


__all__ = ["JOINT_TOL", "POSE_TOL", "SUPPORT_EDGE", "SUPPORT_GAP", "SUPPORT_SINK", "SUPPORT_TILT",
           "ResolvedState", "action_text", "dict_text", "held_order", "norm_action", "num_text",
           "pose_gap", "pose_text", "report_order"]
