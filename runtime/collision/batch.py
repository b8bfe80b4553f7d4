"""Batch shapes shared by the collision checker and its first pass: states are padded to a few
fixed sizes so the jitted kinematics compile once per size."""

from __future__ import annotations

import numpy as np

#: states per forward-kinematics call in batch checks: the PR2's kinematics (82 frames) costs
#: the least per state at 128 states; at 1024 its intermediates leave the cache and each state
#: costs 2-3x more (tests/bench/test_bench_collision.py prints the curve)
CHUNK = 128
#: batch shapes the jitted kinematics of the checks compile for
PAD_SIZES = (16, CHUNK)


def pad_batch(Q: np.ndarray) -> np.ndarray:
    """Q padded (with copies of its last row) to 16 or 128 rows, or a multiple of
    :data:`CHUNK`, so that jitted functions compile for few batch shapes (each shape is an
    executable to load at start-up)."""
    n = len(Q)
    size = next((s for s in PAD_SIZES if n <= s), -(-n // CHUNK) * CHUNK)
    return Q if size == n else np.concatenate([Q, np.repeat(Q[-1:], size - n, 0)])
