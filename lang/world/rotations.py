"""Rotations in pure Python (``lang`` imports no numpy): unit quaternions **xyzw** and 3x3 rotation
matrices as nested lists.

:func:`matrix_from_quat` is the one quaternion -> matrix formula of the code base: the numpy
backend (:mod:`tmpc.compiler.rotations`) and the JAX kernels wrap its nested lists in their own
arrays. Matrix -> quaternion is written once per backend, because the backends normalise
differently (here ``math.sqrt`` of a Python sum; numpy's ``np.linalg.norm`` rounds differently
in the last bit for about one matrix in ten; the kernels' version is branch-free for gradients).
"""

from __future__ import annotations

import math
import sys
from typing import Sequence

from tmpc.lang.world.scene import Box, Quat, Vec3


def quat_from_matrix(r: Sequence[Sequence[float]]) -> Quat:
    """Unit quaternion (xyzw) of a rotation matrix (Shepperd's method; the sign made canonical,
    w >= 0, then normalised)."""
    tr = r[0][0] + r[1][1] + r[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = ((r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, s / 4)
    elif r[0][0] > r[1][1] and r[0][0] > r[2][2]:
        s = math.sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]) * 2
        q = (s / 4, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s, (r[2][1] - r[1][2]) / s)
    elif r[1][1] > r[2][2]:
        s = math.sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]) * 2
        q = ((r[0][1] + r[1][0]) / s, s / 4, (r[1][2] + r[2][1]) / s, (r[0][2] - r[2][0]) / s)
    else:
        s = math.sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]) * 2
        q = ((r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, s / 4, (r[1][0] - r[0][1]) / s)
    if q[3] < 0:          # a canonical sign: w >= 0
        q = (-q[0], -q[1], -q[2], -q[3])
    return unit_quat(q)


#: |q·q - 1| within which a quaternion counts as unit already (:func:`unit_quat`)
UNIT_SLACK = 4 * sys.float_info.epsilon


def unit_quat(q: Sequence[float]) -> Quat:
    """``q`` / |q|, or ``q`` itself when it is unit to within rounding (q·q within
    :data:`UNIT_SLACK` of 1). Dividing a unit quaternion by its norm again can change its last
    bits; kept as it is, a quaternion normalised once, written into an artifact and read back
    is the same quaternion, so a problem planned from its artifact (``tmpc bench``'s workers)
    and from its sources (``tmpc run``) is the same problem to the bit, and a seed gives the
    same plan through either (the projector amplifies a last bit into another plan)."""
    q = tuple(float(c) for c in q)
    s = sum(c * c for c in q)
    if abs(s - 1.0) <= UNIT_SLACK:
        return q
    n = math.sqrt(s)
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def matrix_from_quat(q) -> list[list]:
    """Rotation matrix (nested lists, rows) of a unit quaternion (x, y, z, w); not normalised
    here. Any scalars work (floats, numpy scalars, JAX tracers): the result holds the values
    the arithmetic gives, which the numpy and JAX backends turn into their arrays."""
    x, y, z, w = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def orthonormality_error(r: Sequence[Sequence[float]]) -> tuple[float, float]:
    """(max |R Rᵀ - I|, det R)."""
    dev = max(abs(sum(r[i][k] * r[j][k] for k in range(3)) - (i == j))
              for i in range(3) for j in range(3))
    det = (r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
           - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
           + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]))
    return dev, det


__all__ = ["matrix_from_quat", "orthonormality_error", "quat_from_matrix", "unit_quat"]


def box_to_object_frame(q: Quat, lower: Vec3, upper: Vec3) -> tuple[Box, bool]:
    """A box given in world-aligned axes at an object's origin, expressed in the object's frame
    (Rᵀ applied). Exact (returns True) when R maps axes to axes; otherwise the axis-aligned
    bounding box of the rotated box (returns False)."""
    rt = [list(row) for row in zip(*matrix_from_quat(q))]     # Rᵀ
    perm = all(min(abs(v), abs(abs(v) - 1)) < 1e-6 for row in rt for v in row)
    lo, hi = [0.0] * 3, [0.0] * 3
    for i in range(3):
        if perm:
            j = max(range(3), key=lambda k: abs(rt[i][k]))
            a, b = (lower[j], upper[j]) if rt[i][j] > 0 else (-upper[j], -lower[j])
            lo[i], hi[i] = a + 0.0, b + 0.0
        else:
            lo[i] = sum(min(rt[i][k] * lower[k], rt[i][k] * upper[k]) for k in range(3))
            hi[i] = sum(max(rt[i][k] * lower[k], rt[i][k] * upper[k]) for k in range(3))
    return Box((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])), perm
