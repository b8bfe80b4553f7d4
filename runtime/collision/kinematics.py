"""The collision checker's forward kinematics: a compiled loop over the robot model's program.

Every state the checker sees goes through forward kinematics first. The JAX kernel of the
artifact (:func:`tmpc.compiler.robot.make_fk_frames`) did this at ~0.2 ms per call plus ~8 us
per state on the PR2, and a run loaded one XLA executable per padded batch size (0.2-0.3 s
each, measured 2026-12-03: more than a third of a warm run's setup). The loop here
(:func:`tmpc.runtime.collision.pass_kernel.kinematics`, built ahead of time with the first
pass's candidate search) runs the same program (:func:`tmpc.compiler.robot.fk_tables`) with
the same arithmetic at 3 us per call plus ~1.6 us per state, needs no padding and loads with
the pass. The JAX kinematics stays in the artifact, where the projectors and distances call
it inside their own kernels (they need its derivatives).
"""

from __future__ import annotations

import numpy as np

from tmpc.compiler.robot import RobotModel, fk_tables
from tmpc.runtime.collision.spheres import _fall_back, pass_kernel


class Kinematics:
    """``kinematics(Q (B, n)) -> (R (F, 3, 3, B), p (F, 3, B))``, numpy, batch-last, for
    exactly B states (no padding: :attr:`pads` is False); the frames of ``model.frames``."""

    pads = False

    def __init__(self, model: RobotModel):
        self.tables = fk_tables(model)
        self.dof, self.n_frames = len(model.q_names), len(model.frames)

    def __call__(self, Q) -> tuple[np.ndarray, np.ndarray]:
        Q = np.ascontiguousarray(np.asarray(Q, float).reshape(-1, self.dof))
        F, B = self.n_frames, len(Q)
        R, p = np.empty((F, 3, 3, B)), np.empty((F, 3, B))
        args = (Q, *self.tables, R, p)
        try:
            pass_kernel("kinematics")(*args)
        except TypeError as exc:        # the built module refused (see spheres._fall_back)
            _fall_back(exc, "kinematics")(*args)
        return R, p
