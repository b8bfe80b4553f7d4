"""Straight hand motions out of a grasp or a release: the way a robot retreats.

A grasp or a release leaves the fingers a few millimetres from the object and its neighbours
(a Hanoi disc's sleeve between them, a block between two others, a glass in a shelf): random
joint motions out of such a configuration mostly collide, a straight motion of the hand up or
back along its approach axis does not. :func:`retreat_chains` makes those motions for many
configurations at once: for every grasping frame (:func:`hand_frames`: the parents of the
ground actions' ``link`` effects) and each of three directions (world up, back along the
frame's x axis, both at once; and, on request, :data:`SIDEWAYS`: along the frame's y or z axis,
either way), a chain of steps of ``step`` metres. A step is the joint motion
of the damped least-squares Jacobian (finite differences) that moves the frame's origin and
two points on its axes alike, so the hand keeps its orientation; every step is checked at the
motion resolution, ends included, and a chain stops at its first collision.

The optimal planner's escape stubs (:mod:`tmpc.runtime.planners.optimal.escapes`) add the
chains to its graph; the decoupled planner plans its motions between the chains' ends.
"""

from __future__ import annotations

import numpy as np

from tmpc.runtime.problem import Mode, PlanningProblem

#: the directions of a chain: world up, back along the hand's x axis, both
DIRECTIONS = ("up", "back", "up-back")
#: more directions: along the hand's y axis or its z axis, either way. A released PR2 gripper
#: whose forearm touches the ceiling over Blocks World's table can move neither up nor back;
#: it slides out along its z axis, parallel to the finger pads (7-11 steps of 2.5 cm in the
#: three such cases captured), and the other axis serves hands whose approach axis is z
SIDEWAYS = ("+y", "-y", "+z", "-z")
#: finite-difference step of the Jacobian (radians or metres)
EPS = 1e-4
#: damping of the least-squares step
DAMPING = 1e-3


def hand_frames(problem: PlanningProblem, action=None) -> list[int]:
    """The robot frames that grasp (the parents of the ground actions' ``link`` effects), as
    indices of the model's frames; with ``action``, the frames that action grasps or releases
    with (its ``link`` and ``unlink`` effects' parents)."""
    names = set()
    for a in problem.ground.actions if action is None else [action]:
        effects = list(a.kinematic) + [e for ce in a.conditional for e in ce.kinematic]
        names |= {e.parent for e in effects if e.op == "link" or action is not None}
    found = (problem.model.frame(n) for n in sorted(names))
    return [f for f in found if f is not None]


def cartesian_steps(problem: PlanningProblem, Q: np.ndarray, hands: np.ndarray,
                    directions: np.ndarray, step: float) -> np.ndarray:
    """Each row of ``Q`` (B, n) after one straight step of its frame ``hands[b]`` (direction
    ``directions[b]``, an index of :data:`DIRECTIONS` + :data:`SIDEWAYS`) of ``step``
    metres, joint limits respected: one batched forward kinematics for every row's finite
    differences."""
    B, n = Q.shape
    X = np.repeat(Q[:, None], n + 1, 1)                          # (B, n+1, n)
    X[:, 1:] += np.eye(n)[None] * EPS
    frames = problem.frames_of(X.reshape(-1, n))
    R = np.stack([f.R for f in frames]).reshape(B, n + 1, -1, 3, 3)
    o = np.stack([f.p for f in frames]).reshape(B, n + 1, -1, 3)
    rows = np.arange(B)
    Rh = R[rows, :, hands]                                       # (B, n+1, 3, 3)
    oh = o[rows, :, hands]                                       # (B, n+1, 3)
    pts = np.concatenate([oh, oh + 0.1 * Rh[..., 0], oh + 0.1 * Rh[..., 1]], -1)  # (B, n+1, 9)
    J = np.swapaxes((pts[:, 1:] - pts[:, :1]) / EPS, 1, 2)       # (B, 9, n)
    up = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (B, 3))
    back = -Rh[:, 0, :, 0]
    axes = np.concatenate([Rh[:, 0, :, 1:], -Rh[:, 0, :, 1:]], -1)   # (B, 3, 4): +y +z -y -z
    ways = np.stack([up, back, (up + back) / np.sqrt(2.0), axes[..., 0], axes[..., 2],
                     axes[..., 1], axes[..., 3]], 1)             # (B, 7, 3)
    d = ways[np.arange(B), directions] * step
    dx = np.tile(d, 3)                                           # (B, 9)
    A = J @ np.swapaxes(J, 1, 2) + DAMPING * np.eye(9)
    dq = (np.swapaxes(J, 1, 2) @ np.linalg.solve(A, dx[..., None]))[..., 0]
    Q1 = Q + dq
    return problem.wrap(np.where(problem.wraps, Q1, np.clip(Q1, problem.lower, problem.upper)))


def retreat_chains(problem: PlanningProblem, items: list[tuple[Mode, np.ndarray]],
                   hands: list, steps: int = 4, step: float = 0.025,
                   resolution: float = 0.05, sideways: bool = False,
                   ) -> list[list[list[np.ndarray]]]:
    """For each ``(mode, q)`` of ``items``, its chains (one per hand and direction, in that
    order: :data:`DIRECTIONS`, then :data:`SIDEWAYS` with ``sideways``; each the free
    configurations after ``q``, possibly none), built step by step with one batched motion
    check per step. ``hands``: the frames of every item, or a list of them per item."""
    ways = len(DIRECTIONS) + (len(SIDEWAYS) if sideways else 0)
    per = list(hands) if hands and isinstance(hands[0], list) else [hands] * len(items)
    out = [[[] for _ in range(len(per[i]) * ways)] for i in range(len(items))]
    live = [(i, k, h, d, np.asarray(q, float)) for i, (_, q) in enumerate(items)
            for k, (h, d) in enumerate((h, d) for h in per[i] for d in range(ways))]
    seen: set = set()
    for _ in range(steps):
        if not live:
            break
        nxt = cartesian_steps(problem, np.stack([c[4] for c in live]),
                              np.array([c[2] for c in live]), np.array([c[3] for c in live]),
                              step)
        Q0 = np.stack([c[4] for c in live])
        groups: dict[int, list[int]] = {}           # one batched check per mode
        for r, c in enumerate(live):
            groups.setdefault(id(items[c[0]][0]), []).append(r)
        idx = list(groups.values())
        got = problem.motions_valid_many([(items[live[rs[0]][0]][0], Q0[rs], nxt[rs])
                                          for rs in idx], resolution, ends=True)
        oks = np.zeros(len(live), bool)
        for rs, ok in zip(idx, got):
            oks[rs] = np.asarray(ok).reshape(-1)
        alive = []
        moved = np.abs(problem.difference(nxt, Q0)).max(1) > 1e-6
        for (i, k, h, d, q), q1, ok, m in zip(live, nxt, oks, moved):
            # a step the joint limits cut to nothing ends its chain; so does one that lands
            # where another chain of the same configuration is (no duplicate vertices)
            key = (i, np.round(q1, 9).tobytes())
            if m and ok and np.isfinite(q1).all() \
                    and key not in seen:
                seen.add(key)
                out[i][k].append(q1)
                alive.append((i, k, h, d, q1))
        live = alive
    return out


def best_retreat(chains: list[list[np.ndarray]]) -> list[np.ndarray]:
    """The longest of a configuration's chains (the first of equal length), or none."""
    return max(chains, key=len, default=[])
