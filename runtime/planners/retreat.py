"""Straight hand motions out of a grasp or a release: the way a robot retreats.

A grasp or a release leaves the fingers a few millimetres from the object and its neighbours
(a Hanoi disc's sleeve between them, a block between two others, a glass in a shelf): random
joint motions out of such a configuration mostly collide, a straight motion of the hand up or
back along its approach axis does not. :func:`retreat_chains` makes those motions for many
configurations at once: for every grasping frame (:func:`hand_frames`: the parents of the
ground actions' ``link`` effects) and each of three directions (world up, back along the
frame's x axis, both at once), a chain of steps of ``step`` metres. A step is the joint motion
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
#: finite-difference step of the Jacobian (radians or metres)
EPS = 1e-4
#: damping of the least-squares step
DAMPING = 1e-3


def hand_frames(problem: PlanningProblem) -> list[int]:
    """The robot frames that grasp (the parents of the ground actions' ``link`` effects), as
    indices of the model's frames."""
    names = set()
    for a in problem.ground.actions:
        effects = list(a.kinematic) + [e for ce in a.conditional for e in ce.kinematic]
        names |= {e.parent for e in effects if e.op == "link"}
    found = (problem.model.frame(n) for n in sorted(names))
    return [f for f in found if f is not None]


def cartesian_step(problem: PlanningProblem, q: np.ndarray, hand: int, direction: int,
                   step: float) -> np.ndarray:
    """``q`` after one straight step of frame ``hand`` (``direction``: an index of
    :data:`DIRECTIONS`) of ``step`` metres, joint limits respected."""
    Q = np.repeat(np.asarray(q, float)[None], len(q) + 1, 0)
    Q[1:] += np.eye(len(q)) * EPS
    frames = problem.frames_of(Q)

    def points(f):
        R, o = f.R[hand], f.p[hand]
        return np.concatenate([o, o + 0.1 * R[:, 0], o + 0.1 * R[:, 1]])

    x0 = points(frames[0])
    J = np.stack([(points(f) - x0) / EPS for f in frames[1:]], 1)        # (9, n)
    up, back = np.array([0.0, 0.0, 1.0]), -frames[0].R[hand][:, 0]
    d = (up, back, (up + back) / np.sqrt(2.0))[direction] * step
    dq = J.T @ np.linalg.solve(J @ J.T + DAMPING * np.eye(9), np.tile(d, 3))
    q1 = q + dq
    return problem.wrap(np.where(problem.wraps, q1, np.clip(q1, problem.lower, problem.upper)))


def retreat_chains(problem: PlanningProblem, items: list[tuple[Mode, np.ndarray]],
                   hands: list[int], steps: int = 4, step: float = 0.025,
                   resolution: float = 0.05) -> list[list[list[np.ndarray]]]:
    """For each ``(mode, q)`` of ``items``, its chains (one per hand and direction, in that
    order; each the free configurations after ``q``, possibly none), built step by step with
    one batched motion check per step."""
    out = [[[] for _ in range(len(hands) * len(DIRECTIONS))] for _ in items]
    live = [(i, k, h, d, np.asarray(q, float)) for i, (_, q) in enumerate(items)
            for k, (h, d) in enumerate((h, d) for h in hands for d in range(len(DIRECTIONS)))]
    for _ in range(steps):
        if not live:
            break
        nxt = [cartesian_step(problem, q, h, d, step) for _, _, h, d, q in live]
        oks = problem.motions_valid_many(
            [(items[i][0], q[None], q1[None]) for (i, _, _, _, q), q1 in zip(live, nxt)],
            resolution, ends=True)
        alive = []
        for (i, k, h, d, q), q1, ok in zip(live, nxt, oks):
            # a step the joint limits cut to nothing ends its chain (no duplicate vertices)
            moved = np.abs(problem.difference(q1, q)).max() > 1e-6
            if moved and bool(np.asarray(ok).reshape(-1)[0]) and np.isfinite(q1).all() \
                    and not any(np.allclose(q1, c[-1], atol=1e-9) for c in out[i] if c):
                out[i][k].append(q1)
                alive.append((i, k, h, d, q1))
        live = alive
    return out


def best_retreat(chains: list[list[np.ndarray]]) -> list[np.ndarray]:
    """The longest of a configuration's chains (the first of equal length), or none."""
    return max(chains, key=len, default=[]) if chains else []
