"""Room around a placement: how far an object put down stands from the objects beside it.

A meaning such as `placed-on` allows a placement some slack (a Hanoi peg: 5 mm a side; a
table: its whole top). Where in it an object is put decides whether a later grasp or placement
beside it has room: on the suite's Towers of Hanoi a disc at the back peg is reached between
the two front pegs' discs only when all three stand a few millimetres away from each other
(docs/benchmarks.md, "Hanoi's geometry"). With ``spread_placements`` (a manifest's) the
decoupled planner tries a release's configurations the roomiest first (:meth:`Room.order`)
and adds configurations projected from starts aimed the way the room grows
(:meth:`Room.around`).

The room of an object is a soft minimum of the sideways distances from its position to the
positions of the objects beside it (whose boxes overlap its height), cheap and blind to a
tilt the slack allows. Objects it touches at every candidate (what it stands on, a peg through
it) are left out: they are where it is put, not what it should keep away from.
"""

from __future__ import annotations

import numpy as np

from tmpc.compiler.robot import homogeneous
from tmpc.runtime.collision import aabbs

#: objects closer than this at every candidate touch it (its support): left out (m)
TOUCH = 1e-3
#: farther than this, an object beside it counts as far (m)
FAR = 1.0
#: the soft minimum's scale: the nearest objects count, a far one barely (m)
SCALE = 0.01
#: projections :meth:`Room.around` adds to a release's valid configurations
AROUND = 16
#: how much further an aimed start puts the object (m), and the room gradient's step (m)
AIM = 0.03
STEP = 1e-3
#: rooms this close rank alike (m); the nearest configuration first among them
GRAIN = 1e-3


class Room:
    """The room of released objects at candidate configurations (see the module docstring)."""

    def __init__(self, problem):
        self.p = problem
        self._boxes: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def boxes(self, name: str):
        """(local transforms (G, 4, 4), box centres (G, 3), half extents (G, 3)) of an object's
        geometries in its frame."""
        if name not in self._boxes:
            b = self.p.collision.object_body(name)
            gs = [g for g in self.p.collision.parts.geoms if g.body == b]
            self._boxes[name] = (np.array([g.T_body_geom for g in gs]).reshape(-1, 4, 4),
                                 np.array([g.aabb_center for g in gs]).reshape(-1, 3),
                                 np.array([g.aabb_half for g in gs]).reshape(-1, 3))
        return self._boxes[name]

    def world_boxes(self, name: str, T: np.ndarray):
        """World boxes (centres (..., G, 3), half extents (..., G, 3)) of ``name`` at poses T
        (..., 4, 4)."""
        local, c, h = self.boxes(name)
        return aabbs(T[..., None, :, :] @ local, c, h)

    def released(self, mode, action) -> list[str]:
        """The objects ``action`` releases in ``mode`` (its unconditional unlinks of held ones)."""
        return [e.child for e in action.kinematic if e.op != "link" and e.child in mode.held]

    def poses(self, mode, obj: str, Q: np.ndarray) -> np.ndarray:
        """World poses (k, 4, 4) of ``obj``, held in ``mode``, at configurations Q (k, n)."""
        frame, T_frame_obj = mode.held[obj]
        f = self.p.model.frame(frame)
        frames = self.p.frames_of(np.asarray(Q, float))
        return np.array([homogeneous(fr)[f] @ T_frame_obj for fr in frames]).reshape(-1, 4, 4)

    def room_at(self, mode, obj: str, T: np.ndarray) -> np.ndarray | None:
        """The room (k,) of ``obj`` at poses T (k, 4, 4) among ``mode``'s placed objects: a
        soft minimum (scale :data:`SCALE`) of the sideways distances from its position to
        theirs, of the objects beside it (their boxes overlap its height at some pose; at
        the others they count :data:`FAR`), those whose boxes it touches at every pose left
        out; None if nothing is beside it."""
        c, h = self.world_boxes(obj, T)                               # (k, G, 3)
        dists = []
        for other, T_o in mode.poses.items():
            if other == obj:
                continue
            co, ho = self.world_boxes(other, np.asarray(T_o, float))     # (Go, 3)
            gap = np.abs(c[:, :, None, :] - co[None, None]) - (h[:, :, None, :] + ho[None, None])
            touch = np.linalg.norm(np.maximum(gap[..., :2], 0.0), axis=-1)
            beside = (gap[..., 2] < 0).any(axis=(1, 2))
            if (touch.min(axis=(1, 2)) < TOUCH).all() or not beside.any():
                continue
            side = np.linalg.norm(T[:, None, :2, 3] - co[None, :, :2], axis=-1).min(axis=1)
            dists.append(np.where(beside, np.minimum(side, FAR), FAR))
        if not dists:
            return None
        return -SCALE * np.log(np.exp(-np.array(dists) / SCALE).sum(axis=0))

    def rooms(self, mode, action, Q: np.ndarray) -> np.ndarray | None:
        """The room (k,) of what ``action`` releases at configurations Q (k, n) in ``mode``
        (:meth:`room_at`, summed over what it releases); None if it releases nothing or nothing
        is beside it."""
        rooms = [self.room_at(mode, obj, self.poses(mode, obj, Q))
                 for obj in self.released(mode, action)] if len(Q) else []
        rooms = [r for r in rooms if r is not None]
        return np.sum(rooms, axis=0) if rooms else None

    def aimed(self, mode, action, Q: np.ndarray) -> np.ndarray:
        """Projection starts (k, n) from configurations Q (k, n) of ``action``'s release: each
        moved so the (first) released object goes :data:`AIM` further the way its room grows
        (the room's gradient, sideways; the joints' step through the object position's
        Jacobian, by finite differences). A projection stops on the edge of the slack
        nearest its start, so from these it stops toward the roomy side."""
        objs = self.released(mode, action)
        if not objs or not len(Q):
            return Q[:0]
        obj, p = objs[0], self.p
        T = self.poses(mode, obj, Q)
        grad = np.zeros((len(Q), 3))
        for axis in (0, 1):
            hi, lo = T.copy(), T.copy()
            hi[:, axis, 3] += STEP
            lo[:, axis, 3] -= STEP
            r_hi, r_lo = self.room_at(mode, obj, hi), self.room_at(mode, obj, lo)
            if r_hi is None or r_lo is None:
                return Q[:0]
            grad[:, axis] = r_hi - r_lo
        norm = np.linalg.norm(grad, axis=1, keepdims=True)
        keep = norm[:, 0] > 0
        Q, T, grad, norm = Q[keep], T[keep], grad[keep], norm[keep]
        if not len(Q):
            return Q
        n = Q.shape[1]
        eps = 1e-4
        Qj = np.repeat(Q[:, None, :], n, 1) + eps * np.eye(n)[None]
        Tj = self.poses(mode, obj, Qj.reshape(-1, n)).reshape(len(Q), n, 4, 4)
        J = (Tj[:, :, :3, 3] - T[:, None, :3, 3]).transpose(0, 2, 1) / eps   # (k, 3, n)
        step = AIM * grad / norm
        dq = (np.linalg.pinv(J) @ step[..., None])[..., 0]
        return p.wrap(Q + dq)

    def around(self, mode, action, Q: np.ndarray) -> list[np.ndarray]:
        """Valid configurations of ``action``'s release in ``mode`` projected from
        :meth:`aimed` starts about the configurations Q where its precondition held."""
        p = self.p
        starts = self.aimed(mode, action, Q[:AROUND])
        if not len(starts):
            return []
        Qp, holds, _ = p.project_raw(mode, action, starts)
        ok = holds.copy()
        if ok.any():
            ok[ok] = p.valid_batch(mode, Qp[ok])
        return [p.wrap(x) for x in Qp[ok]]

    def order(self, mode, action, Q: np.ndarray, cost: np.ndarray) -> np.ndarray:
        """Indices of Q, the roomiest first (rooms within :data:`GRAIN` alike), then by
        ``cost``."""
        room = self.rooms(mode, action, Q)
        if room is None:
            return np.argsort(cost, kind="stable")
        return np.lexsort((cost, -np.floor(room / GRAIN)))
