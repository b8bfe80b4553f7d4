"""Matrix -> quaternion has one function per layer, all named ``quat_from_matrix``: pure Python in
``lang`` (which imports no numpy) and numpy in the compiler. They must agree."""

import numpy as np
import pytest

from tmpc.compiler.rotations import pose_matrix, quat_from_matrix, quat_matrix
from tmpc.lang.world import Pose
from tmpc.lang.world import quat_from_matrix as lang_quat_from_matrix


def _rotations(n=400, seed=0):
    rng = np.random.default_rng(seed)
    qs = rng.normal(size=(n, 4))
    qs /= np.linalg.norm(qs, axis=1, keepdims=True)
    # every branch of Shepperd's method: trace > 0, and each diagonal entry the largest
    extra = [(1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1), (0.7, 0.1, 0.1, 0.1)]
    for q in list(qs) + [np.array(e) / np.linalg.norm(e) for e in extra]:
        yield quat_matrix(q)


def test_numpy_and_pure_python_quat_from_matrix_agree():
    for R in _rotations():
        a = quat_from_matrix(R)
        b = np.array(lang_quat_from_matrix(R.tolist()))
        assert a[3] >= 0 and b[3] >= 0
        np.testing.assert_allclose(a, b, rtol=0, atol=4e-16)


def test_quat_from_matrix_inverts_quat_matrix():
    for R in _rotations(50, seed=1):
        np.testing.assert_allclose(quat_matrix(quat_from_matrix(R)), R, atol=1e-12)


@pytest.mark.parametrize("t, q", [((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0)),
                                  ((0.5, -1.0, 0.0), (0.0, 0.0, 0.7071067811865476,
                                                      0.7071067811865476))])
def test_pose_matrix_of_a_pose_or_of_its_parts(t, q):
    assert np.array_equal(pose_matrix(Pose(t, q)), pose_matrix(t, q))
    assert np.array_equal(pose_matrix(t, q)[:3, 3], t)
