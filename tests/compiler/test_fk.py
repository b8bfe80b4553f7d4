"""Forward kinematics against an independent implementation (pinocchio) and finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from tmpc.lang.world import Pose, RobotSpec, load_urdf

pin = pytest.importorskip("pinocchio")

ROBOTS = {
    "pr2": "package://example-robot-data/robots/pr2_description/urdf/pr2.urdf",
    "panda": "package://example-robot-data/robots/panda_description/urdf/panda.urdf",
}


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def robot(request):
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.robot import build_robot_model, make_fk
    jax = configured()
    tree = load_urdf(ROBOTS[request.param])
    model = build_robot_model(tree, RobotSpec(urdf=tree.path))
    return tree, model, jax.jit(make_fk(model))


def _pin_q(pmodel, tree, model, q):
    """Our configuration as pinocchio's q (continuous joints are (cos, sin) there)."""
    values = dict(zip(model.q_names, q))
    values.update(model.fixed)
    for j in tree.joints:
        if j.mimic is not None:
            values[j.name] = j.mimic.multiplier * values[j.mimic.joint] + j.mimic.offset
    pq = pin.neutral(pmodel)
    for jid in range(1, pmodel.njoints):
        name, jm = pmodel.names[jid], pmodel.joints[jid]
        v = values[name]
        if jm.nq == 2:
            pq[jm.idx_q:jm.idx_q + 2] = (np.cos(v), np.sin(v))
        else:
            pq[jm.idx_q] = v
    return pq


def test_fk_matches_pinocchio_on_random_configurations(robot):
    tree, model, fk = robot
    pmodel = pin.buildModelFromUrdf(tree.path)
    pdata = pmodel.createData()
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(100):
        q = rng.uniform(model.lower, model.upper)
        frames = fk(q)
        pin.forwardKinematics(pmodel, pdata, _pin_q(pmodel, tree, model, q))
        pin.updateFramePlacements(pmodel, pdata)
        for link in tree.links:
            fid = pmodel.getFrameId(link.name, pin.BODY)
            M = pdata.oMf[fid]
            i = model.frame(link.name)
            worst = max(worst, np.abs(np.asarray(frames.p[i]) - M.translation).max(),
                        np.abs(np.asarray(frames.R[i]) - M.rotation).max())
    assert worst < 1e-9, worst


def test_batched_equals_single_and_gradients_match_finite_differences(robot):
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.robot import make_fk
    jax = configured()
    tree, model, fk = robot
    rng = np.random.default_rng(3)
    Q = rng.uniform(model.lower, model.upper, (16, model.dof))
    batch = fk(Q)
    for k in (0, 7, 15):
        single = fk(Q[k])
        assert np.allclose(batch.p[k], single.p, atol=1e-12)
    tip = model.frame(tree.links[-1].name)
    f = make_fk(model)

    def tip_x(q):
        return f(q).p[tip].sum() + f(q).R[tip, 0, 0]

    g = jax.jit(jax.grad(tip_x))
    tip_x = jax.jit(tip_x)
    for q in (np.zeros(model.dof), Q[0], Q[1]):
        grad = np.asarray(g(q))
        assert np.isfinite(grad).all()
        h, fd = 1e-6, np.zeros(model.dof)
        for i in range(model.dof):
            e = np.zeros(model.dof)
            e[i] = h
            fd[i] = (float(tip_x(q + e)) - float(tip_x(q - e))) / (2 * h)
        assert np.allclose(grad, fd, atol=1e-7), np.abs(grad - fd).max()


def test_mobile_base_and_joint_aliases():
    from tmpc.compiler.robot import build_robot_model, make_fk
    tree = load_urdf(ROBOTS["pr2"])
    spec = RobotSpec(urdf=tree.path, mobile_base=True, base_pose=Pose((0.0, 0.0, 0.1)),
                     joint_values=(("torso_lift_joint", 0.2),))
    model = build_robot_model(tree, spec)
    assert model.q_names[:3] == ("base_x", "base_y", "base_yaw")
    assert model.default_q[model.q_names.index("torso_lift_joint")] == pytest.approx(0.2)
    fk = make_fk(model)
    assert np.allclose(model.default_q[:3], 0.0)     # the scene's base pose: origin, no yaw
    q = model.default_q.copy()
    q[:3] = (1.0, 2.0, np.pi / 2)
    frames = fk(q)
    base = model.frame("base_footprint")
    assert np.allclose(frames.p[base], (1.0, 2.0, 0.1))
    assert np.allclose(frames.R[base] @ np.array([1.0, 0, 0]), (0.0, 1.0, 0.0), atol=1e-12)
    turned = build_robot_model(tree, RobotSpec(urdf=tree.path, mobile_base=True,
                                               base_pose=Pose.from_xyz_yaw(0.5, -1.0, 0.0, 0.3)))
    assert np.allclose(turned.default_q[:3], (0.5, -1.0, 0.3))
    # a joint name refers to its child link's frame (tmit-star names grippers by joint)
    assert model.frame("l_gripper_tool_joint") == model.frame("l_gripper_tool_frame")


def test_unknown_joint_in_scene_is_a_clear_error():
    from tmpc.compiler.robot import build_robot_model
    from tmpc.lang.diagnostics import SceneError
    tree = load_urdf(ROBOTS["panda"])
    with pytest.raises(SceneError, match="panda_joint9") as info:
        build_robot_model(tree, RobotSpec(urdf=tree.path, joint_values=(("panda_joint9", 0.1),)))
    assert info.value.diagnostics[0].code == "E564"
    assert "did you mean" in info.value.diagnostics[0].hint


def test_missing_urdf_and_package():
    from tmpc.lang.diagnostics import SceneError
    with pytest.raises(SceneError) as info:
        load_urdf("package://no_such_pkg/robot.urdf")
    assert info.value.diagnostics[0].code == "E560"
