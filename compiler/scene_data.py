"""The static per-object vectors the DSL reads from a scene's grasp sets and stable poses
(``grasp-point``, ``grasp-axis``, ``grasp-hand-axis``, ``stable-up``; docs/language.md): one
definition for the kernels' tables and the numpy interpreter."""

from __future__ import annotations

import numpy as np

from tmpc.compiler.rotations import quat_matrix

#: the static per-object vectors the DSL reads (``grasp-point`` ...): IR op names
SCENE_VECTORS = ("grasp_point", "grasp_axis", "grasp_hand_axis", "stable_up")


def scene_vectors(obj) -> dict[str, np.ndarray]:
    """An object's static vectors from the suite's XML data (object frame; absent: NaN):
    ``grasp_point`` the first grasp set's template origin, ``grasp_axis`` its rotation axis (a
    discrete grasp: the template's own z), ``grasp_hand_axis`` that axis seen from the hand
    (the template's rotation transposed times the axis: a hand pose in the set sees the axis
    the same way), ``stable_up`` the object-frame direction its first stable pose stands along
    the pose's axis (the template transposed times the axis)."""
    nan = np.full(3, np.nan)
    out = {k: nan for k in SCENE_VECTORS}
    grasps = getattr(obj, "grasps", ())
    if grasps:
        g = grasps[0]
        R = quat_matrix(g.template.rotation)
        axis = np.asarray(g.axis if g.axis is not None else R[:, 2], float)
        axis = axis / (np.linalg.norm(axis) or 1.0)
        out["grasp_point"] = np.asarray(g.template.translation, float)
        out["grasp_axis"] = axis
        out["grasp_hand_axis"] = R.T @ axis
    stable = getattr(obj, "stable_poses", ())
    if stable:
        s = stable[0]
        a = np.asarray(s.axis, float)
        out["stable_up"] = quat_matrix(s.template).T @ (a / (np.linalg.norm(a) or 1.0))
    return out
