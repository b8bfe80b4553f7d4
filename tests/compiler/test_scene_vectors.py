"""The scene data the DSL reads (grasp-point, grasp-axis, grasp-hand-axis, stable-up) from the
native scene format, checked against values worked out by hand."""

import json
import math

import numpy as np

from tmpc.compiler.scene_data import scene_vectors
from tmpc.lang.world import LoadReport, load_scene


def test_native_grasps_and_stable_poses_read_and_reduce_to_the_dsl_vectors(tmp_path):
    s = math.sqrt(0.5)
    scene = {"format": "tmpc-scene/1", "bounds": [[-1, 1], [-1, 1], [0, 2]], "objects": [
        {"name": "block", "pose": {"translation": [0.5, 0, 0.4]}, "movable": True,
         "shape": {"type": "box", "half_extents": [0.04, 0.04, 0.04]},
         # the suite's top grasp: the hand's x axis points down, 6 cm above the origin
         "grasps": [{"kind": "top", "template": {"translation": [0, 0, 0.06],
                                                 "rotation": [-s, 0, s, 0]}, "axis": [0, 0, 2]}],
         "stable_poses": [{"rotation": [0, 0, 0, 1], "axis": [0, 0, 1], "distance": 0}],
         "attachments": ["cap"]},
        {"name": "cap", "pose": {"translation": [0.5, 0, 0.48]}, "movable": True}]}
    path = tmp_path / "s.json"
    path.write_text(json.dumps(scene))
    loaded = load_scene(path, report=LoadReport())
    block = loaded.object("block")
    assert block.grasps[0].kind == "top" and block.grasps[0].axis == (0.0, 0.0, 1.0)
    assert block.attachments == ("cap",)
    v = scene_vectors(block)
    assert np.allclose(v["grasp_point"], [0, 0, 0.06])
    assert np.allclose(v["grasp_axis"], [0, 0, 1])
    # the template's rotation maps hand x to -z: the object's axis (+z) is -x seen from the hand
    assert np.allclose(v["grasp_hand_axis"], [-1, 0, 0], atol=1e-9)
    assert np.allclose(v["stable_up"], [0, 0, 1])
    assert all(np.isnan(x).all() for x in scene_vectors(loaded.object("cap")).values())
