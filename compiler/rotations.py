"""Rotations with numpy: unit quaternions (x, y, z, w) <-> 3x3 matrices, 4x4 pose matrices and
roll/pitch/yaw. The one numpy copy for the compiler, the runtime, the plan reader and the
validator (whose *kinematics* stays its own: this is arithmetic, not forward kinematics).

Quaternion -> matrix is :func:`tmpc.lang.world.rotations.matrix_from_quat`'s formula in a numpy
array (the JAX kernels put the same formula in a ``jax.numpy`` array through ``xp``).
Matrix -> quaternion, :func:`quat_from_matrix`, has the same name and method (Shepperd's) as the
pure-Python :func:`tmpc.lang.world.rotations.quat_from_matrix` and differs from it in the last bit
only: it normalises with ``np.linalg.norm``, which the seeded plans' bytes depend on
(tests/compiler/test_rotations.py checks that the two agree). The kernels' gradient-safe
matrix -> quaternion and roll/pitch/yaw stay in :mod:`tmpc.compiler.kernels.emit`.
Importing this module costs numpy only (no JAX), so the validator may use it.
"""

from __future__ import annotations

import math

import numpy as np

from tmpc.lang.world import matrix_from_quat


def quat_matrix(q, xp=np):
    """3x3 rotation matrix of the unit quaternion ``q`` (x, y, z, w; not normalised here), as an
    ``xp`` array (numpy unless given: the JAX kernels pass ``jax.numpy``)."""
    return xp.array(matrix_from_quat(q))


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation matrix, an array with w >= 0 (Shepperd's
    method, normalised with ``np.linalg.norm``, then the sign made canonical). ``.tolist()``
    gives the Python floats that state JSON and the evaluator's ``Quat`` hold."""
    m = R
    t = m[0, 0] + m[1, 1] + m[2, 2]
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4, (m[1, 0] - m[0, 1]) / s]
    q = np.asarray(q) / np.linalg.norm(q)
    return -q if q[3] < 0 else q


def pose_matrix(pose_or_translation, rotation=None) -> np.ndarray:
    """4x4 matrix of a pose: ``pose_matrix(pose)`` for a :class:`tmpc.lang.world.Pose`, or
    ``pose_matrix(translation, rotation)`` for a translation (x, y, z) and a unit quaternion
    (x, y, z, w)."""
    if rotation is None:
        translation, rotation = pose_or_translation.translation, pose_or_translation.rotation
    else:
        translation = pose_or_translation
    T = np.eye(4)
    T[:3, :3] = quat_matrix(rotation)
    T[:3, 3] = translation
    return T


def rpy_of(R: np.ndarray) -> np.ndarray:
    """(roll, pitch, yaw) with R = Rz(yaw) Ry(pitch) Rx(roll)."""
    pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    return np.array([math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])])


__all__ = ["pose_matrix", "quat_from_matrix", "quat_matrix", "rpy_of"]
