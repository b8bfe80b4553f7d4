"""Batch shapes of the collision checker: states per kinematics call, and padding for a kinematics that compiles per shape.

The checker's own kinematics (:class:`tmpc.runtime.collision.kinematics.Kinematics`) takes any
number of states and is never padded. A kinematics given to the world that compiles once per
batch shape (the artifact's JAX kernel, ``pads`` not False) gets its states padded to a few
fixed sizes (:func:`pad_batch`), so it compiles for few shapes.
"""

from __future__ import annotations

import numpy as np

#: states per forward-kinematics call in batch checks: the PR2's kinematics (82 frames) costs
#: the least per state around here, and larger batches' intermediates leave the cache
#: (tests/bench/test_bench_collision.py prints the curve)
CHUNK = 128
#: batch shapes a kinematics that compiles per shape is padded to
PAD_SIZES = (16, CHUNK)


def pad_batch(Q: np.ndarray) -> np.ndarray:
    """Q padded (with copies of its last row) to 16 or 128 rows, or a multiple of
    :data:`CHUNK`, so that jitted functions compile for few batch shapes (each shape is an
    executable to load at start-up)."""
    n = len(Q)
    size = next((s for s in PAD_SIZES if n <= s), -(-n // CHUNK) * CHUNK)
    return Q if size == n else np.concatenate([Q, np.repeat(Q[-1:], size - n, 0)])
