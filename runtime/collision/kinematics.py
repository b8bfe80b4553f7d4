"""The collision checker's forward kinematics: a compiled loop over the robot model's program.

Every state the checker sees goes through forward kinematics first. The loop
(:func:`tmpc.runtime.collision.pass_kernel.kinematics`, built ahead of time with the first
pass's candidate search and loaded by :mod:`tmpc.runtime.collision.kernel`) runs the robot
model's program (:func:`tmpc.compiler.robot.fk_tables`) with the same arithmetic as the JAX
kinematics of the artifact (:func:`tmpc.compiler.robot.make_fk_frames`), for exactly the states
given: it needs no padding and no executable per batch size. The JAX kinematics stays in the
artifact, where the projectors and distances call it inside their own kernels (they need its
derivatives).
"""

from __future__ import annotations

import numpy as np

from tmpc.compiler.robot import RobotModel, fk_tables
from tmpc.runtime.collision.kernel import fall_back, pass_kernel


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
        except TypeError as exc:        # the built module refused (kernel.fall_back)
            fall_back(exc, "kinematics")(*args)
        return R, p
