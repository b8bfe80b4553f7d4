"""World state JSON round trips and the numpy expression interpreter (against hand computations)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmpc.lang.diagnostics import DiagnosticSink, InputError
from tmpc.lang.reader import Reader
from tmpc.lang.sexpr import parse_sexpr
from tmpc.lang.source import SourceFile
from tmpc.lang.world import load_urdf
from tmpc.lang.world.scene import Box, Pose, RobotSpec, Scene, SceneObject, Shape

PANDA = "package://example-robot-data/robots/panda_description/urdf/panda.urdf"


@pytest.fixture(scope="module")
def world():
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.robot import build_robot_model, make_fk
    jax = configured()
    tree = load_urdf(PANDA)
    spec = RobotSpec(urdf=tree.path, joint_values=(("panda_joint4", -1.5), ("panda_joint6", 1.5)))
    scene = Scene("mem", ((-1, 1), (-1, 1), (0, 2)), spec, (
        SceneObject("table", Pose((0.5, 0.0, 0.2), (0.0, 0.0, math.sin(math.pi / 4),
                                                     math.cos(math.pi / 4))),
                    shape=Shape("box", size=(0.3, 0.5, 0.2)),
                    support=Box((-0.3, -0.5, 0.2), (0.3, 0.5, 0.25))),
        SceneObject("cube", Pose((0.5, 0.1, 0.47)), movable=True,
                    shape=Shape("box", size=(0.02, 0.02, 0.02))),
    ))
    model = build_robot_model(tree, spec)
    return scene, model, jax.jit(make_fk(model))


def expr(text: str):
    doc = parse_sexpr(SourceFile("e", text))
    return Reader(DiagnosticSink()).expr(doc.items[0])


def evaluate(world, text, q=None, held=None):
    """Evaluate at configuration ``q``; ``held=(frame, obj)`` grasps obj at the default
    configuration first, so moving to ``q`` carries it along."""
    from tmpc.compiler.state import grasp, initial_state, world_poses
    from tmpc.runtime.evaluate import Evaluator
    scene, model, fk = world
    st = initial_state(scene, model)
    if held:
        st = grasp(st, model, held[0], held[1], fk(st.q))
    if q is not None:
        st = type(st)(q, st.poses, st.held, st.atoms)
    frames = fk(st.q)
    ev = Evaluator(scene, model, st.q, frames, world_poses(st, model, frames))
    return ev.value(expr(text))


def test_accessors_against_hand_computation(world):
    scene, model, fk = world
    frames = fk(model.default_q)
    hand = model.frame("panda_hand")
    assert np.allclose(evaluate(world, "(position panda_hand)"), frames.p[hand])
    assert np.allclose(evaluate(world, "(z-axis panda_hand)"), frames.R[hand][:, 2])
    assert evaluate(world, "(joint panda_joint4)") == pytest.approx(-1.5)
    # the table is turned 90 degrees: its support region's x/y extents swap in the world
    box = evaluate(world, "(support-region table)")
    assert np.allclose(box.lower, (0.0, -0.3, 0.4)) and np.allclose(box.upper, (1.0, 0.3, 0.45))
    assert evaluate(world, "(inside (position cube) (grow (support-region table) 0 0 0.1))")
    assert not evaluate(world, "(inside (position cube) (support-region table))")
    assert evaluate(world, "(yaw table)") == pytest.approx(math.pi / 2)
    assert np.allclose(evaluate(world, "(extent cube)"), (0.02, 0.02, 0.02))
    rel = evaluate(world, "(relative cube table)")
    assert np.allclose(rel, (0.1, 0.0, 0.27))
    assert evaluate(world, "(let ((?d (distance (position cube) (position table)))) "
                           "(and (> ?d 0.2) (< ?d 0.3)))")


def test_held_object_follows_the_gripper(world):
    scene, model, fk = world
    q = model.default_q.copy()
    before = evaluate(world, "(relative cube panda_hand)", q, held=("panda_hand", "cube"))
    q2 = q.copy()
    q2[0] += 0.7
    after = evaluate(world, "(relative cube panda_hand)", q2, held=("panda_hand", "cube"))
    assert np.allclose(before, after)            # rigidly attached
    moved = evaluate(world, "(position cube)", q2, held=("panda_hand", "cube"))
    assert not np.allclose(moved, (0.5, 0.1, 0.47))


def test_state_json_round_trip(world):
    from tmpc.compiler.state import initial_state, state_from_json, state_to_json
    scene, model, fk = world
    st = initial_state(scene, model)
    data = state_to_json(st, model)
    assert set(data["joints"]) >= set(model.q_names)
    assert data["object_poses"]["table"]["rotation"] == pytest.approx(
        [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    data["joints"]["panda_joint1"] = 0.3
    data["object_poses"]["cube"]["translation"] = [0.1, 0.2, 0.3]
    back = state_from_json(data, scene, model, st)
    assert back.q[model.q_names.index("panda_joint1")] == pytest.approx(0.3)
    assert np.allclose(back.poses["cube"][:3, 3], (0.1, 0.2, 0.3))
    assert state_to_json(back, model)["joints"]["panda_joint1"] == pytest.approx(0.3)


@pytest.mark.parametrize("data, fragment", [
    ({"joints": {"panda_joint99": 1.0}}, "unknown joint"),
    ({"joints": {"panda_joint1": "a"}}, "must be a number"),
    ({"object_poses": {"cube": {"rotation": [0, 0, 0, 2]}}}, "norm"),
    ({"object_poses": {"ghost": {}}}, "unknown object"),
    ({"frobs": 1}, "unknown field"),
    ({"mode": {"held": {"cube": "no_such_frame"}}}, "unknown robot frame"),
])
def test_bad_state_json(world, data, fragment):
    from tmpc.compiler.state import initial_state, state_from_json
    scene, model, _ = world
    with pytest.raises(InputError, match=fragment) as info:
        state_from_json(data, scene, model, initial_state(scene, model), "s.json")
    assert info.value.diagnostics[0].code == "E580"


def test_eval_errors_are_diagnostics(world):
    from tmpc.runtime.evaluate import EvalError
    with pytest.raises(EvalError, match="ghost"):
        evaluate(world, "(position ghost)")
    with pytest.raises(EvalError, match="support region"):
        evaluate(world, "(support-region cube)")
