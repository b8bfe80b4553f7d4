"""Joint velocity and acceleration limits for timing a plan: the URDF's ``<limit velocity>``
(and a ``<limit acceleration>`` where a URDF gives one), else documented defaults
(docs/robot-export.md)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.world import find_file

#: rad/s² (m/s² for prismatic joints) where the URDF gives no acceleration and no --max-accel
DEFAULT_ACCELERATION = 2.0
#: rad/s (m/s) where the URDF gives no velocity limit (or 0, which URDF files use for "unset")
DEFAULT_VELOCITY = 1.0
#: the mobile base's virtual joints (x, y in m, yaw in rad): velocity, acceleration
BASE_LIMITS = {"base_x": (0.5, 1.0), "base_y": (0.5, 1.0), "base_yaw": (1.0, 2.0)}
BASE_JOINTS = tuple(BASE_LIMITS)


@dataclass(frozen=True)
class JointLimit:
    """One joint's limits; ``wraps``: a continuous joint (or the base's yaw), moved the short way
    around; ``source``: where the numbers came from (``urdf``, ``default``, ``--max-accel``)."""

    velocity: float
    acceleration: float
    wraps: bool = False
    velocity_source: str = "urdf"
    acceleration_source: str = "urdf"

    def as_json(self) -> dict:
        return {"velocity": self.velocity, "acceleration": self.acceleration,
                "continuous": self.wraps,
                "source": {"velocity": self.velocity_source,
                           "acceleration": self.acceleration_source}}


def urdf_path(world) -> Path:
    scene = world.scene
    if scene.robot is None:
        raise InputError(error("E832", f"{scene.path} has no robot: there is nothing to time",
                               None))
    path = find_file(str(scene.robot.urdf), Path(scene.path).parent)
    if path is None:
        raise InputError(error("E832", f"cannot find the robot's URDF {scene.robot.urdf}", None))
    return path


def joint_limits(world, joints, max_accel: float | None = None,
                 speed: float = 1.0) -> dict[str, JointLimit]:
    """Limits of ``joints`` (names; the base's virtual joints :data:`BASE_JOINTS` included)
    from the world's URDF. ``max_accel`` replaces the default acceleration where the URDF gives
    none; ``speed`` (0-1] scales every velocity and acceleration limit."""
    root = ET.parse(urdf_path(world)).getroot()
    found = {j.get("name"): j for j in root.iter("joint")}
    out = {}
    default_a = DEFAULT_ACCELERATION if max_accel is None else float(max_accel)
    a_source = "default" if max_accel is None else "--max-accel"
    for name in joints:
        if name in BASE_LIMITS:
            v, a = BASE_LIMITS[name]
            out[name] = JointLimit(v * speed, a * speed, name == "base_yaw", "default", "default")
            continue
        j = found.get(name)
        lim = j.find("limit") if j is not None else None
        v = _positive(lim.get("velocity") if lim is not None else None)
        a = _positive(lim.get("acceleration") if lim is not None else None)
        out[name] = JointLimit((v or DEFAULT_VELOCITY) * speed, (a or default_a) * speed,
                               j is not None and j.get("type") == "continuous",
                               "urdf" if v else "default", "urdf" if a else a_source)
    return out


def _positive(text) -> float | None:
    try:
        v = float(text)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and v > 0 else None


def mimic_joints(world) -> set[str]:
    """The URDF's mimic joints (they follow their master; controllers do not command them)."""
    root = ET.parse(urdf_path(world)).getroot()
    return {j.get("name") for j in root.iter("joint") if j.find("mimic") is not None}
