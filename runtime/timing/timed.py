"""Timing a plan document for a world: its moving joints, their limits, toppra's timing."""

from __future__ import annotations

from tmpc.runtime.timing.limits import joint_limits, mimic_joints
from tmpc.runtime.timing.parameterize import DEFAULT_DT, moving_joints, time_plan


def time_world_plan(world, doc: dict, max_accel: float | None = None,
                    dt: float = DEFAULT_DT) -> dict:
    """Time ``doc`` (changed in place: ``t`` per state, a ``timing`` block, which it returns)
    under the limits of ``world``'s robot."""
    names = moving_joints(doc, skip=mimic_joints(world))
    return time_plan(doc, joint_limits(world, names, max_accel), names, dt)
