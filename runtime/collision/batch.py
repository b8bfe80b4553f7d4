"""Batch shapes shared by the collision checker and its first pass: states are padded to a few
fixed sizes so the jitted kinematics compile once per size."""

from __future__ import annotations

import numpy as np

#: states per forward-kinematics call in batch checks
CHUNK = 1024
#: batch shapes the jitted kinematics of the checks compile for
PAD_SIZES = (16, 128, CHUNK)


def pad_batch(Q: np.ndarray) -> np.ndarray:
    """Q padded (with copies of its last row) to 16, 128, 1024 or a multiple of :data:`CHUNK`
    rows, so that jitted functions compile for few batch shapes (each shape is a trace and a
    compile at start-up; forward kinematics of 1024 states costs milliseconds)."""
    n = len(Q)
    size = next((s for s in PAD_SIZES if n <= s), -(-n // CHUNK) * CHUNK)
    return Q if size == n else np.concatenate([Q, np.repeat(Q[-1:], size - n, 0)])
