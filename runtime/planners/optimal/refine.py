"""Transition refinement: a solution's configurations moved to shorten it, every transition
keeping its effect (tmpc's addition to the optimal planner's anytime phase,
:meth:`tmpc.runtime.planners.optimal.improve.Improver.refine_transitions`).

A solution found in the graph is nearly straight between its transitions once shortcut, and its
cost is then fixed by where the transitions happen: the configuration at which a gripper takes
or releases an object was one projection of a random sample. Its kinematic effect fixes only
the pose of the gripper's frame (the object's pose in the world and in the hand): the base, the
torso and the other arm are free along the manifold of configurations with that frame pose
(the PR2: 20 coordinates, one 6-dof frame). Moving a transition along that manifold keeps every
mode of the plan as it is (same poses, same grasps), so the rest of the plan stays valid.

**The method.** The path's vertices are grouped in *clusters*: runs of equal configurations
joined by transitions (a transition vertex and its bridge, or a chain of actions at one
configuration), each with the frames its actions link or release (its constraint) and a
one-vertex cluster for every other vertex (no constraint). The first vertex (the start) never
moves. A sweep moves every other cluster (even ones, then odd ones: neighbours of a cluster stay
put while it moves), each by projected subgradient descent on the composite length of its two
motions: the subgradient of ``cost(prev, q) + cost(q, next)`` projected on the null space of the
constraint's Jacobian (finite differences of the collision checker's forward kinematics), a step
of 1, 0.3, 0.1, 0.03 or 0.01 times it (the first that is accepted), then Gauss-Newton back onto
the constraint to 1e-11 (position and rotation residuals). A move is accepted when it lowers the
two motions' cost, stays within the joint limits, the configuration is collision-free in every
mode of the cluster, both motions are collision-free at the resolution (ends included), every
action's precondition still holds there (and the goal's geometric literals, for the last
vertex), and every action leads to the same mode (poses within the planner's 1e-3). After the
moves, a vertex without constraint whose neighbours see each other (a straight motion at the
resolution) is dropped. Sweeps go on until one gains less than ``tolerance`` of the cost or the
deadline passes.

Nothing here is random.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from tmpc.runtime.problem import Mode, PlanningProblem

STEPS = (1.0, 0.3, 0.1, 0.03, 0.01)     # subgradient step lengths tried, longest first
EPS = 1e-6                              # finite-difference step of the Jacobian
CONVERGED = 1e-11                       # the constraint's residual Gauss-Newton stops at
ACCEPTED = 1e-9                         # ... and the largest one a move may keep


@dataclass
class Refined:
    Q: np.ndarray            # the configurations of the vertices kept
    keep: list[int]          # which of the path's vertices those are
    moved: set[int]          # ... and which of them moved (indices into the path)
    cost: float
    sweeps: int


class _Cluster:
    __slots__ = ("first", "frames", "last", "targets")

    def __init__(self, first: int, last: int, frames: list[int], targets: list):
        self.first, self.last, self.frames, self.targets = first, last, frames, targets


def refine_path(p: PlanningProblem, Q: np.ndarray, modes: list[Mode], actions: list,
                same_mode, resolution: float, deadline: float, tolerance: float = 1e-4,
                max_sweeps: int = 200) -> Refined:
    """Refine the path ``Q`` (n, d) whose vertex k lies in ``modes[k]``; ``actions[k]``: the
    action that takes vertex k to vertex k + 1 at the same configuration (None: a motion).
    ``same_mode(mode, new)``: does ``new`` (:meth:`PlanningProblem.successor_mode`'s result)
    equal the known successor ``mode``? Every motion of ``Q`` must be collision-free at
    ``resolution``: the motions of the result are, by construction."""
    return _Refiner(p, Q, modes, actions, same_mode, resolution).run(deadline, tolerance,
                                                                     max_sweeps)


class _Refiner:
    def __init__(self, p: PlanningProblem, Q, modes, actions, same_mode, resolution):
        self.p, self.modes, self.actions = p, list(modes), list(actions)
        self.same_mode, self.resolution = same_mode, resolution
        self.Q = np.array(Q, float)
        self.idx = list(range(len(self.Q)))          # the original index of each vertex kept
        self.moved: set[int] = set()
        self.goal = p.goal_formula() is not None
        self.clusters: list[_Cluster] = []
        k, n = 0, len(self.Q)
        while k < n:
            j = k
            while j + 1 < n and self.actions[j] is not None:
                j += 1
            self.clusters.append(self._cluster(k, j))
            k = j + 1

    def _cluster(self, first: int, last: int) -> _Cluster:
        """The cluster of vertices first..last and its constraint: the frames its actions
        link objects to or release them from, at their poses now."""
        frames = set()
        for k in range(first, last):
            mode = self.modes[k]
            for eff in self.p.ground.kinematic_effects(mode.sym, self.actions[k],
                                                       self._geo(mode, k)):
                if eff.op == "link":
                    frames.add(eff.parent)
                elif eff.child in mode.held:          # a release of what is not held: no-op
                    frames.add(mode.held[eff.child][0])
        ids = sorted(self.p.model.frame(f) for f in frames)
        if not ids:
            return _Cluster(first, last, [], [])
        R, t = self.p.collision.kinematics(self.Q[first][None])
        return _Cluster(first, last, ids, [(R[f, :, :, 0].copy(), t[f, :, 0].copy())
                                           for f in ids])

    def _geo(self, mode: Mode, k: int):
        action = self.actions[k]
        if action is None or not action.conditional:
            return None
        return self.p.geo_oracle(mode, self.Q[k])

    # ---- the constraint ------------------------------------------------------------------
    def _residual(self, c: _Cluster, Q: np.ndarray) -> np.ndarray:
        """(B, 6 per frame) position and rotation residuals of ``c``'s frames at states Q."""
        R, t = self.p.collision.kinematics(Q)
        out = []
        for f, (Rt, pt) in zip(c.frames, c.targets):
            D = np.einsum("ji,jkb->bik", Rt, R[f])           # Rt^T R, per state
            out += [t[f].T - pt, 0.5 * np.stack([D[:, 2, 1] - D[:, 1, 2],
                                                 D[:, 0, 2] - D[:, 2, 0],
                                                 D[:, 1, 0] - D[:, 0, 1]], 1)]
        return np.concatenate(out, 1)

    def _jacobian(self, c: _Cluster, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        X = np.repeat(q[None], len(q) + 1, 0)
        X[1:] += np.eye(len(q)) * EPS
        r = self._residual(c, X)
        return r[0], (r[1:] - r[0]).T / EPS

    def _onto(self, c: _Cluster, q: np.ndarray) -> np.ndarray | None:
        """Gauss-Newton from ``q`` back onto ``c``'s constraint; None if it does not get there
        (or a joint limit stops it)."""
        for _ in range(20):
            r, J = self._jacobian(c, q)
            if np.abs(r).max() < CONVERGED:
                break
            q = q - np.linalg.lstsq(J, r, rcond=None)[0]
        q = self.p.wrap(q)
        return q if np.abs(self._residual(c, q[None])[0]).max() < ACCEPTED else None

    # ---- moves ---------------------------------------------------------------------------
    def _cost(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(self.p.cost(b[None], a)[0])

    def _move(self, c: _Cluster) -> bool:
        """One subgradient step of cluster ``c`` (its neighbours fixed); True if it moved."""
        i, j, n = c.first, c.last, len(self.Q)
        q, prev = self.Q[i], self.Q[i - 1]
        nxt = self.Q[j + 1] if j + 1 < n else None
        old = self._cost(prev, q) + (self._cost(q, nxt) if nxt is not None else 0.0)
        g = self.p.cost_subgradient(q, prev)
        if nxt is not None:
            g = g + self.p.cost_subgradient(q, nxt)
        if c.frames:
            _, J = self._jacobian(c, q)
            g = g - np.linalg.pinv(J) @ (J @ g)
        if np.linalg.norm(g) < 1e-9:
            return False
        for step in STEPS:
            q2 = self.p.wrap(q - step * g)
            if c.frames:
                q2 = self._onto(c, q2)
                if q2 is None:
                    continue
            new = self._cost(prev, q2) + (self._cost(q2, nxt) if nxt is not None else 0.0)
            if new < old - 1e-9 and self._acceptable(c, q2, prev, nxt):
                self.Q[i:j + 1] = q2
                self.moved.update(self.idx[i:j + 1])
                return True
        return False

    def _acceptable(self, c: _Cluster, q: np.ndarray, prev, nxt) -> bool:
        """Is ``q`` a valid place for cluster ``c``: collision-free in its modes, its motions
        free, its actions' preconditions holding and leading to the same modes?"""
        p, i, j = self.p, c.first, c.last
        modes = self.modes[i:j + 1]
        if not all(p.valid_batch(m, q[None])[0] for m in {id(m): m for m in modes}.values()):
            return False
        items = [(modes[0], prev[None], q[None])]
        if nxt is not None:
            items.append((modes[-1], q[None], nxt[None]))
        if not all(ok[0] for ok in p.motions_valid_many(items, self.resolution, ends=True)):
            return False
        for k in range(i, j):
            action, mode = self.actions[k], self.modes[k]
            if p.has_geometry(action) and not p.holds(mode, action, q):
                return False
            if not self.same_mode(self.modes[k + 1], p.successor_mode(mode, action, q, -1)):
                return False
        return j < len(self.Q) - 1 or not self.goal or p.holds(modes[-1], None, q)

    def _drop(self, parity: int) -> int:
        """Drop the unconstrained one-vertex clusters of this parity whose neighbours see each
        other; how many."""
        cs = self.clusters
        cand = [k for k in range(1, len(cs) - 1) if k % 2 == parity and not cs[k].frames
                and cs[k].first == cs[k].last]
        if not cand:
            return 0
        oks = self.p.motions_valid_many(
            [(self.modes[cs[k].first], self.Q[cs[k].first - 1][None],
              self.Q[cs[k].first + 1][None]) for k in cand], self.resolution, ends=True)
        drop = {cs[k].first for k, ok in zip(cand, oks) if ok[0]}
        if not drop:
            return 0
        keep = [k for k in range(len(self.Q)) if k not in drop]
        shift = np.cumsum([k in drop for k in range(len(self.Q))])
        self.Q = self.Q[keep]
        self.modes = [self.modes[k] for k in keep]
        self.actions = [self.actions[k] for k in keep]
        self.idx = [self.idx[k] for k in keep]
        self.clusters = [c for c in cs if c.first not in drop]
        for c in self.clusters:
            c.first, c.last = c.first - int(shift[c.first]), c.last - int(shift[c.last])
        return len(drop)

    def total(self) -> float:
        return float(self.p.cost(self.Q[1:], self.Q[:-1]).sum()) if len(self.Q) > 1 else 0.0

    def run(self, deadline: float, tolerance: float, max_sweeps: int) -> Refined:
        cost, sweeps = self.total(), 0
        while sweeps < max_sweeps and time.perf_counter() < deadline:
            sweeps += 1
            for parity in (0, 1):
                for k, c in enumerate(self.clusters):
                    if time.perf_counter() >= deadline:
                        break
                    if k % 2 == parity and c.first > 0:
                        self._move(c)
            for parity in (0, 1):
                self._drop(parity)
            now = self.total()
            if cost - now < tolerance * cost:
                cost = now
                break
            cost = now
        return Refined(self.Q, self.idx, self.moved, cost, sweeps)
