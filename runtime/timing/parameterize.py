"""Time-optimal timing of a plan's motions with toppra: every state gets a time ``t`` and every
motion sampled positions, velocities and accelerations (docs/plan-format.md, "Timed plans").

A plan's motion is the straight line in joint space between consecutive states (what the
validator checked); a timing that rounded a corner would leave the checked path, so each segment
is timed on its own, at rest at both ends: toppra gives the time-optimal profile along the
straight line under every joint's velocity and acceleration limit.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.timing.limits import BASE_JOINTS, JointLimit

#: seconds between samples inside a segment (its ends are always samples)
DEFAULT_DT = 0.05
#: toppra's grid: intervals per segment (the profile is exact at its points, constant
#: acceleration between them)
GRID = 20
#: joint-space distance below which two states have the same configuration
SAME = 1e-9


def base_yaw(rotation) -> float:
    """The yaw of a planar base's quaternion [x, y, z, w]."""
    x, y, z, w = rotation
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def moving_joints(doc: dict, skip=()) -> list[str]:
    """The joints whose value changes along the plan (in the first state's order), then the
    base's virtual joints (:data:`~tmpc.runtime.timing.limits.BASE_JOINTS`) if the base moves.
    ``skip``: joints never timed (mimic joints follow their master)."""
    states = doc["states"]
    names = [n for n in states[0].get("joints", {}) if n not in skip and
             any(abs(s["joints"].get(n, 0.0) - states[0]["joints"][n]) > SAME for s in states)]
    bases = np.array([_base(s) for s in states])
    if len(bases) and np.ptp(bases, axis=0).max() > SAME:
        names += list(BASE_JOINTS)
    return names


def base_pose_values(state) -> tuple[float, float, float]:
    """A state's base pose as the base's virtual joints (x, y, yaw)."""
    return _base(state)


def _base(state) -> tuple[float, float, float]:
    b = state.get("base_pose") or {}
    t = b.get("translation", [0.0, 0.0, 0.0])
    return (float(t[0]), float(t[1]), base_yaw(b.get("rotation", [0.0, 0.0, 0.0, 1.0])))


def configurations(doc: dict, names: list[str], limits: dict[str, JointLimit]) -> np.ndarray:
    """(states, joints): each state's values, continuous joints and the base's yaw unwrapped
    along the plan (the short way around, as the plan's motions move them)."""
    rows = []
    for s in doc["states"]:
        b = _base(s)
        base = dict(zip(BASE_JOINTS, b))
        rows.append([base[n] if n in base else float(s["joints"].get(n, 0.0)) for n in names])
    q = np.array(rows, float).reshape(len(rows), len(names))
    for j, n in enumerate(names):
        if limits[n].wraps:
            d = np.diff(q[:, j])
            d = (d + math.pi) % (2 * math.pi) - math.pi
            q[1:, j] = q[0, j] + np.cumsum(d)
    return q


def time_segment(qa: np.ndarray, qb: np.ndarray, vmax: np.ndarray, amax: np.ndarray):
    """toppra's time-optimal rest-to-rest profile from ``qa`` to ``qb`` along the straight line:
    its duration and a callable ``(t, order) -> values``. Raises ValueError when toppra fails."""
    import toppra
    import toppra.algorithm as algo
    import toppra.constraint as co
    logging.getLogger("toppra").setLevel(logging.ERROR)
    path = toppra.SplineInterpolator([0.0, 1.0], np.stack([qa, qb]))
    problem = algo.TOPPRA([co.JointVelocityConstraint(np.stack([-vmax, vmax], 1)),
                           co.JointAccelerationConstraint(np.stack([-amax, amax], 1))],
                          path, gridpoints=np.linspace(0.0, 1.0, GRID + 1),
                          parametrizer="ParametrizeConstAccel")
    traj = problem.compute_trajectory(0.0, 0.0)
    if traj is None:
        raise ValueError("toppra found no feasible profile")
    return float(traj.duration), traj


def time_plan(doc: dict, limits: dict[str, JointLimit], names: list[str],
              dt: float = DEFAULT_DT) -> dict:
    """Give ``doc`` (a ``tmpc-plan/1`` object, changed in place) a time per state and a
    ``timing`` block; returns the block. An action takes no time (the next state has the same
    configuration and time)."""
    if not dt > 0:
        raise ValueError("dt must be > 0")
    import toppra  # noqa: F401  (loaded before the clock starts: per-motion times are toppra's)
    states = doc["states"]
    q = configurations(doc, names, limits)
    vmax = np.array([limits[n].velocity for n in names], float)
    amax = np.array([limits[n].acceleration for n in names], float)
    t_state = [0.0] * len(states)
    motions, current, per_motion = [], None, []
    clock = time.perf_counter()
    started = clock
    for k in range(len(states) - 1):
        if states[k].get("action") is not None:
            t_state[k + 1] = t_state[k]
            if current is not None:
                motions.append(current)
                per_motion.append(time.perf_counter() - clock)
                current = None
            continue
        if current is None:
            clock = time.perf_counter()
            current = {"states": [k, k], "start": t_state[k], "t": [t_state[k]],
                       "positions": [q[k].tolist()], "velocities": [[0.0] * len(names)],
                       "accelerations": [[0.0] * len(names)]}
        current["states"][1] = k + 1
        if np.abs(q[k + 1] - q[k]).max(initial=0.0) <= SAME:
            t_state[k + 1] = t_state[k]
            continue
        try:
            duration, traj = time_segment(q[k], q[k + 1], vmax, amax)
        except ValueError as exc:
            raise InputError(error("E832", f"the motion from state {k} to state {k + 1} could "
                                   f"not be timed: {exc}", None)) from None
        n = max(1, math.ceil(duration / dt - 1e-9))
        taus = np.linspace(0.0, duration, n + 1)[1:]
        pos, vel, acc = traj(taus), traj(taus, 1), traj(taus, 2)
        pos[-1], vel[-1] = q[k + 1], 0.0
        current["accelerations"][-1] = traj(np.array([0.0]), 2)[0].round(9).tolist()
        for tau, p, v, a in zip(taus, pos, vel, acc):
            current["t"].append(round(t_state[k] + float(tau), 9))
            current["positions"].append(p.round(12).tolist())
            current["velocities"].append(v.round(9).tolist())
            current["accelerations"].append(a.round(9).tolist())
        current["positions"][-1] = q[k + 1].tolist()
        current["accelerations"][-1] = [0.0] * len(names)
        t_state[k + 1] = t_state[k] + duration
        current["t"][-1] = t_state[k + 1]
    if current is not None:
        motions.append(current)
        per_motion.append(time.perf_counter() - clock)
    for s, t in zip(states, t_state):
        s["t"] = t
    for m in motions:
        m["duration"] = m["t"][-1] - m["start"]
    block = {"method": "toppra", "joint_names": list(names),
             "limits": {n: limits[n].as_json() for n in names}, "dt": dt,
             "duration": t_state[-1], "motions": motions,
             "seconds": round(time.perf_counter() - started, 6),
             "ms_per_motion": [round(1e3 * s, 3) for s in per_motion]}
    doc["timing"] = block
    return block
