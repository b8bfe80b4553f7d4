"""Batched and motion collision checks: the first pass's candidates confirmed by exact fcl, states in chunks.

States go through the forward kinematics in chunks of :data:`tmpc.runtime.collision.batch.CHUNK`;
the first pass (:mod:`tmpc.runtime.collision.first_pass`) leaves candidate geometry pairs, and
:meth:`BatchChecker.confirm` asks fcl about them, a state's likeliest pairs first (how often each
pair was found colliding so far in this world), stopping at a state's first collision; states
with a pair sure to collide need no query. Motions are checked at every interpolated state
(docs/collision.md, "Motions"); batched motions visit each motion's states in bisection order
and stop at any colliding one. Without the first pass every state is checked by exact fcl.
"""

from __future__ import annotations

import collections
import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from tmpc.lang.diagnostics import SceneError, error
from tmpc.runtime.collision.batch import CHUNK
from tmpc.runtime.collision.exact import CollisionReport, world_transforms

if TYPE_CHECKING:
    from tmpc.runtime.collision.world import CollisionWorld

#: answers of object pairs that stay put kept (:meth:`BatchChecker._fixed_pairs_collide`);
#: all dropped when full
FIXED_PAIRS_KEPT = 65536


@dataclass(frozen=True)
class MotionReport:
    """``t_first_collision`` in [0, 1] along the straight configuration-space motion (None when
    valid); ``report`` is the :class:`CollisionReport` of that first colliding state."""

    valid: bool
    t_first_collision: float | None
    report: CollisionReport | None
    steps: int = 0


@dataclass
class PassStats:
    """Counters of the first pass over all batch/motion calls (for benchmarks)."""

    states: int = 0
    coarse_pairs: int = 0
    cover_pairs: int = 0         # left after the covers, before the convex stage
    fine_pairs: int = 0
    settled: int = 0             # states with no candidate pair left: free without fcl
    colliding: int = 0
    queries: int = 0             # exact fcl pair queries made on the candidates
    sure: int = 0                # colliding states found with no fcl query (a vertex deep in a box)

    def add(self, n: int, cand, bad) -> None:
        self.states += n
        self.coarse_pairs += cand.coarse
        self.cover_pairs += cand.covers
        self.fine_pairs += len(cand.states)
        self.settled += n - len(np.unique(cand.states))
        self.colliding += len(bad)


class BatchChecker:
    """The batch, batched-motion and motion checks of a :class:`tmpc.runtime.collision.world.CollisionWorld`, with their
    counters and caches (exact queries per geometry pair, the fixed objects of recent modes)."""

    def __init__(self, world: "CollisionWorld"):
        self.world = world
        self.stats = PassStats()
        #: exact queries and collisions found per geometry pair (:meth:`confirm` asks a
        #: state's likeliest pairs first: a colliding state then costs about one query)
        self.pair_tries: np.ndarray | None = None
        self.pair_hits: np.ndarray | None = None
        #: per state key: the non-moving objects' frames and transforms, and whether two of them
        #: collide (a search alternates between a few modes: fcl answers each once)
        self._fixed_of: dict = {}
        self._fixed_pair: dict = {}       # (ga, gb, pose a, pose b) -> collide (a static: b"")

    def check_batch(self, Q, poses=None, attached=None) -> np.ndarray:
        """Validity (B,) bool of states Q (B, n) sharing the object poses and held objects."""
        w = self.world
        Q = w.as_states(Q)
        key, (place, allowed) = w.placed(poses, attached)
        out = np.ones(len(Q), bool)
        if not len(Q):
            return out
        for start, bad in self.invalid_states(Q, place, allowed, first_state_only=False,
                                               key=key):
            out[start + bad] = False
        return out

    def check_batches(self, groups) -> list[np.ndarray]:
        """:meth:`check_batch` of several groups ``(Q, poses, attached)`` (states of different
        modes): the kinematics of all their states in shared calls (one per :data:`CHUNK`
        states, not one per group at least), the object poses' stages per group."""
        return self.batches([(Q, poses, attached, None) for Q, poses, attached in groups])

    def check_segments(self, groups) -> list[np.ndarray]:
        """Validity of motions given by their states: groups ``(Q, poses, attached, lens)``,
        ``Q`` the states of ``len(lens)`` motions one after another (``lens[i]`` states each);
        returns (len(lens),) bool per group, True when every state of the motion is free.
        Batched as :meth:`tmpc.runtime.collision.CollisionWorld.check_batches`, but exact fcl stops confirming a motion at its first
        colliding state and visits each motion's states in bisection order (middle first:
        where a straight motion most likely collides), so an invalid motion costs a few exact
        queries, not one per state. The answers are :meth:`tmpc.runtime.collision.CollisionWorld.check_batches`' states, reduced."""
        return self.batches(groups)

    def batches(self, groups) -> list[np.ndarray]:
        w = self.world
        groups = [(w.as_states(Q) if len(Q) else np.zeros((0, w.model.dof)), poses, attached,
                   None if lens is None else np.asarray(lens, np.int64))
                  for Q, poses, attached, lens in groups]
        if w.first_pass() is None or len(groups) < 2:
            out = []
            for Q, poses, attached, lens in groups:
                ok = self.check_batch(Q, poses, attached) if lens is None else \
                    self._segments_ok(Q, poses, attached, lens, None)
                out.append(ok)
            return out
        allQ = np.concatenate([Q for Q, _, _, _ in groups])
        if not len(allQ):
            return [np.ones(0 if lens is None else len(lens), bool) for _, _, _, lens in groups]
        R, p = [], []
        for start in range(0, len(allQ), CHUNK):
            chunk = allQ[start:start + CHUNK]
            Rc, pc = w.kinematics(chunk)
            R.append(Rc)
            p.append(pc)
        R, p = np.concatenate(R, -1), np.concatenate(p, -1)
        out, at = [], 0
        for Q, poses, attached, lens in groups:
            frames = (R[..., at:at + len(Q)], p[..., at:at + len(Q)])
            if lens is not None:
                out.append(self._segments_ok(Q, poses, attached, lens, frames))
            else:
                ok = np.ones(len(Q), bool)
                if len(Q):
                    key, (place, allowed) = w.placed(poses, attached)
                    for start, bad in self.invalid_states(Q, place, allowed, False, key,
                                                           frames):
                        ok[start + bad] = False
                out.append(ok)
            at += len(Q)
        return out

    def _segments_ok(self, Q, poses, attached, lens, frames) -> np.ndarray:
        """Per motion (``lens`` states each, in Q in turn): no colliding state."""
        w = self.world
        if lens.sum() != len(Q):
            raise ValueError(f"motion lengths sum to {lens.sum()}, not {len(Q)} states")
        seg = np.repeat(np.arange(len(lens)), lens)
        if not len(Q):
            return np.ones(len(lens), bool)
        dead = np.zeros(len(lens), bool)
        key, (place, allowed) = w.placed(poses, attached)
        ranks = bisection_ranks(lens)
        probe = ranks < PROBE_STATES
        rounds = [None]
        if frames is None and len(Q) > PROBE_MIN and 2 * probe.sum() < len(Q):
            rounds = [probe, ~probe]
        for rows in rounds:
            if rows is None:
                Qr, sr, rr = Q, seg, ranks
            else:                            # the states left of the motions still alive
                rows = np.flatnonzero(rows & ~dead[seg])
                if not len(rows):
                    break
                Qr, sr, rr = Q[rows], seg[rows], ranks[rows]
            for start, bad in self.invalid_states(Qr, place, allowed, False, key, frames,
                                                   (sr, rr, dead)):
                dead[sr[start + bad]] = True
        return ~dead

    def check_motion(self, q0, q1, resolution: float = 0.02, poses=None,
                     attached=None, details: bool = True) -> MotionReport:
        """Check the straight motion q0 -> q1 (wrapping coordinates the short way round) at
        steps that move no coordinate more than ``resolution`` (rad or m); both ends included.
        ``details=False`` skips naming the colliding pairs (``report`` None): planners only need
        where the motion stops being valid."""
        w = self.world
        if not (resolution > 0 and math.isfinite(resolution)):
            raise SceneError(error("E575", f"motion resolution {resolution} must be a finite "
                                   "number > 0", None, "e.g. 0.02 (rad or m per step)"))
        Q = w.interpolate(q0, q1, resolution)
        key, (place, allowed) = w.placed(poses, attached)
        for start, bad in self.invalid_states(Q, place, allowed, first_state_only=True,
                                               key=key):
            if len(bad):
                i = start + int(bad[0])
                if not details:
                    return MotionReport(False, i / (len(Q) - 1), None, len(Q) - 1)
                fpos, local, R, p = w.frames(Q[i:i + 1], place)
                hits = w.exact.exact(world_transforms(R[0], p[0], fpos, local), allowed, first_only=False)
                return MotionReport(False, i / (len(Q) - 1), w.exact.report(hits), len(Q) - 1)
        return MotionReport(True, None, None, len(Q) - 1)

    def invalid_states(self, Q, place, allowed, first_state_only: bool, key=None,
                        frames=None, motions=None):
        """Yield (chunk start, sorted indices of colliding states in the chunk); with
        ``first_state_only``, stop after the first colliding state. ``key``: the state's
        :meth:`tmpc.runtime.collision.CollisionWorld.placed` key (its batch plan and fixed objects are then reused). ``frames``:
        the kinematics of Q, batch-last ``(R (F, 3, 3, B), p (F, 3, B))``, when known (the
        first pass only). ``motions``: ``(segment of each state, its bisection rank, dead
        segments)`` (:meth:`tmpc.runtime.collision.CollisionWorld.check_segments`): a state of a dead segment is not confirmed, and
        ``dead`` is updated as colliding states are found; the indices yielded are then only
        some of the colliding states, at least one per segment that has one."""
        w = self.world
        fp = w.first_pass()
        if fp is None:
            for start in range(0, len(Q), CHUNK):
                fpos, local, R, p = w.frames(Q[start:start + CHUNK], place)
                bad = []
                for i in range(len(R)):
                    if motions is not None and motions[2][motions[0][start + i]]:
                        continue
                    if w.exact.exact(world_transforms(R[i], p[i], fpos, local), allowed, first_only=True):
                        bad.append(i)
                        if motions is not None:
                            motions[2][motions[0][start + i]] = True
                        if first_state_only:
                            break
                yield start, np.array(bad, np.int64)
                if bad and first_state_only:
                    return
            return
        plan = fp.plan(place, allowed, key)
        if self.constant_collision(plan, place, key):
            yield 0, np.arange(1 if first_state_only else len(Q))
            return
        for start in range(0, len(Q), CHUNK):
            cut = None if frames is None else \
                tuple(f[..., start:start + CHUNK] for f in frames)
            cand = fp.candidates(Q[start:start + CHUNK], plan, cut)
            part = None if motions is None else \
                tuple(m[start:start + CHUNK] for m in motions[:2]) + (motions[2],)
            bad = self.confirm(cand, plan, first_state_only, part)
            self.stats.add(len(cand.R[0, 0, 0]), cand, bad)
            yield start, bad
            if len(bad) and first_state_only:
                return

    def constant_collision(self, plan, place, key=None) -> bool:
        """Set the world poses of objects that stay put in the batch; True if two of them
        collide (then every state of the batch is invalid). Nothing to do when they are set
        for this state already (``key``, :meth:`tmpc.runtime.collision.CollisionWorld.placed`)."""
        w = self.world
        if key is not None and w.exact.fixed is not None and w.exact.fixed[0] == key:
            return w.exact.fixed[1]
        known = self._fixed_of.get(key) if key is not None else None
        frames, local = w.geom_frames(place) if known is None else known[:2]
        for k, g in enumerate(w.dynamic):
            if frames[k] < 0:
                w.exact.set_pose(g, local[k])
        if known is not None:
            hit = known[2]
        else:
            hit = self._fixed_pairs_collide(plan.ff, local)
            if key is not None:
                if len(self._fixed_of) >= 256:
                    self._fixed_of.pop(next(iter(self._fixed_of)))
                self._fixed_of[key] = (frames, local, hit)
        w.exact.fixed = None if key is None else (key, hit)
        return hit

    def _fixed_pairs_collide(self, pairs: np.ndarray, local: np.ndarray) -> bool:
        """Do two of the objects that stay put collide (their fcl transforms set; ``local``:
        :meth:`tmpc.runtime.collision.CollisionWorld.geom_frames`' transforms, the world's for
        these)? Each pair's answer is kept by the two poses: a new placement of the objects
        moves one or two of them, and the rest rest where they did (Blocks World I spent 7% of
        its search in EPA depths of blocks resting on one another, asked again in each mode)."""
        w = self.world
        pos = w.dynamic_position
        for ga, gb in pairs.tolist():
            key = (ga, gb, local[pos[ga]].tobytes() if pos[ga] >= 0 else b"",
                   local[pos[gb]].tobytes() if pos[gb] >= 0 else b"")
            hit = self._fixed_pair.get(key)
            if hit is None:
                if len(self._fixed_pair) >= FIXED_PAIRS_KEPT:
                    self._fixed_pair.clear()
                hit = self._fixed_pair[key] = w.exact.counts(w.exact.depth(ga, gb))
            if hit:
                return True
        return False

    def confirm(self, cand, plan, first_state_only: bool, motions=None) -> np.ndarray:
        """Exact fcl on the candidate pairs of the first pass; the sorted colliding states.

        The world transforms of every (moving geometry, state) the candidates name are computed
        at once in numpy; the loop only hands them to fcl, for the pairs it reaches (a state's
        remaining pairs are skipped after its first collision; a state's pairs are asked in
        the order of how often each pair was found colliding so far). ``motions``: the chunk's
        ``(segment, bisection rank)`` per state and the dead segments (:meth:`invalid_states`):
        states are visited by rank, and a dead segment's are skipped.

        States with a pair the pass marked sure to collide (a mesh with a convex hull, one of
        whose hull vertices lies deeper than ``tolerance`` +
        :data:`~tmpc.runtime.collision.first_pass.SURE_DEPTH` inside a box primitive) are
        colliding with no query. That is fcl's
        answer: qhull's hull vertices are vertices of the mesh, so a triangle of the mesh
        reaches into the solid box and fcl's mesh-box test touches; and any translation that
        separates the hull from the box moves that vertex out of it, so their penetration
        depth, the one :meth:`tmpc.runtime.collision.exact.ExactChecker.depth` compares, is at least the vertex's depth. Box against box
        is left to fcl (its box test reports a contact point's depth, not the pair's)."""
        w = self.world
        n = len(cand.states)
        if not n:
            return np.zeros(0, np.int64)
        G = len(w.geoms)
        if self.pair_tries is None:
            self.pair_tries = np.zeros((G, G), np.int64)
            self.pair_hits = np.zeros((G, G), np.int64)
        bad: list[int] = []
        if motions is not None:
            seg, rank, dead = motions
        # states certain to collide need no fcl call (nor do the rest of their segments); with
        # ``first_state_only`` the states before the first of them are still asked
        sure = np.unique(cand.states[cand.sure]) if cand.sure is not None else cand.states[:0]
        if len(sure):
            self.stats.sure += len(sure)
            if first_state_only:
                sure = sure[:1]
                keep = cand.states < sure[0]
            else:
                bad = sure.tolist()
                keep = ~np.isin(cand.states, sure)
                if motions is not None:
                    dead[seg[sure]] = True
            cand = cand.take(np.nonzero(keep)[0])
        if motions is not None:
            cand = cand.take(np.nonzero(~dead[seg[cand.states]])[0])
        likely = (self.pair_hits[cand.ga, cand.gb] + 1.0) / \
            (self.pair_tries[cand.ga, cand.gb] + 2.0)
        if motions is not None:
            order = np.lexsort((-likely, cand.states, rank[cand.states]))
        else:
            order = np.lexsort((-likely, cand.states))
        cand = cand.take(order)
        states = cand.states
        Rw, tw, slot = self._moving_poses(cand, plan)
        asked, hit = [], []
        cur, done, placed = -1, False, set()
        dead_of = None if motions is None else seg.tolist()
        for row, (st, a, b) in enumerate(zip(states.tolist(), cand.ga.tolist(),
                                             cand.gb.tolist())):
            if st != cur:
                cur, done, placed = st, False, set()
                if dead_of is not None and dead[dead_of[st]]:
                    done = True
            if done:
                continue
            for g, k in ((a, slot[row, 0]), (b, slot[row, 1])):
                if k >= 0 and g not in placed:
                    w.exact.place(g, Rw[k], tw[k])
                    placed.add(g)
            asked.append(row)
            if w.exact.counts(w.exact.depth(a, b)):
                hit.append(row)
                bad.append(st)
                done = True
                if dead_of is not None:
                    dead[dead_of[st]] = True
                if first_state_only:
                    break
        if first_state_only and not bad and len(sure):
            bad = [int(sure[0])]
        self.stats.queries += len(asked)
        np.add.at(self.pair_tries, (cand.ga[asked], cand.gb[asked]), 1)
        np.add.at(self.pair_hits, (cand.ga[hit], cand.gb[hit]), 1)
        return np.unique(np.array(bad, np.int64))

    def _moving_poses(self, cand, plan):
        """World rotations and translations (Rw (k, 3, 3), tw (k, 3)) of the moving geometries
        of candidate rows, and per row and side the position there (``slot`` (n, 2), -1: the
        geometry does not move in the batch)."""
        w = self.world
        mpos = np.full(len(w.geoms), -1, np.int64)
        mpos[plan.mv] = np.arange(len(plan.mv))
        pos = np.stack([mpos[cand.ga], mpos[cand.gb]], 1)                  # (n, 2), -1: fixed
        moving = pos >= 0
        i, s = pos[moving], np.broadcast_to(cand.states[:, None], pos.shape)[moving]
        f = plan.fpos[i]
        Rf = cand.R[f, :, :, s]                                          # (k, 3, 3)
        loc = plan.local[i]
        Rw = Rf @ loc[:, :3, :3]
        tw = (Rf @ loc[:, :3, 3, None])[..., 0] + cand.p[f, :, s]
        slot = np.full(pos.shape, -1, np.int64)
        slot[moving] = np.arange(len(i))
        return Rw, tw, slot


#: a batch of motions is checked first at the first PROBE_STATES states of each in bisection
#: order (the middle, then the middles of the halves), then the rest of the motions that held
#: there (:meth:`BatchChecker.check_segments`), when that is under half the states and the
#: batch has more than PROBE_MIN states: most motions a planner asks about collide, and the
#: first pass had visited every state of each before exact fcl stopped at its first collision.
#: Not in a call of several modes (the optimal planner's edges), whose kinematics is computed
#: for every state at once: there the subsets' copies cost what the probe saved
PROBE_STATES = 3
PROBE_MIN = 32


def bisection_ranks(lens: np.ndarray) -> np.ndarray:
    """For motions of ``lens`` states each (one after another): each state's place in its
    motion's bisection order (0: the middle state, then the middles of the two halves, ...)."""
    return np.concatenate([bisection_order(int(n)) for n in lens]) if len(lens) else \
        np.zeros(0, np.int64)


@functools.lru_cache(maxsize=1024)
def bisection_order(n: int) -> np.ndarray:
    rank = np.empty(n, np.int64)
    queue, k = collections.deque([(0, n)]), 0
    while queue:
        lo, hi = queue.popleft()
        if lo >= hi:
            continue
        mid = (lo + hi) // 2
        rank[mid], k = k, k + 1
        queue.append((lo, mid))
        queue.append((mid + 1, hi))
    rank.flags.writeable = False
    return rank
