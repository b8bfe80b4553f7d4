"""The collision checker's forward kinematics (a compiled loop, tmpc.runtime.collision.kinematics)
against pinocchio and against the artifact's JAX kinematics; built ahead of time and numba's JIT
agree and take the exported argument types; checks through either kinematics agree."""

from __future__ import annotations

import numpy as np
import pytest

from tests.runtime.test_collision import four_tables, mobile_scene, random_motions
from tmpc.lang.world import Pose, RobotSpec, load_urdf

ROBOTS = {
    "pr2": "package://example-robot-data/robots/pr2_description/urdf/pr2.urdf",
    "panda": "package://example-robot-data/robots/panda_description/urdf/panda.urdf",
}
#: (robot, spec): a fixed base placed off the origin and turned; the PR2 on a mobile base whose
#: scene pose is turned too (the yaw offset and height the kinematics keeps)
CASES = {
    "panda": ("panda", {"base_pose": Pose((0.3, -0.2, 0.1), (0.0, 0.0, 0.38268343, 0.92387953))}),
    "pr2": ("pr2", {"joint_values": (("torso_lift_joint", 0.1),)}),
    "pr2-mobile": ("pr2", {"mobile_base": True,
                           "base_pose": Pose((0.0, 0.0, 0.05), (0.0, 0.0, 0.2588190, 0.9659258))}),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.robot import build_robot_model, make_fk_frames
    name, spec = CASES[request.param]
    tree = load_urdf(ROBOTS[name])
    model = build_robot_model(tree, RobotSpec(urdf=tree.path, **spec))
    return tree, model, configured().jit(make_fk_frames(model))


def _states(model, rng, n):
    Q = rng.uniform(np.maximum(model.lower, -4.0), np.minimum(model.upper, 4.0), (n, model.dof))
    if model.mobile_base:
        Q[:, :2] = rng.uniform(-2.0, 2.0, (n, 2))
    return Q


def test_equals_the_jax_kinematics_at_every_batch_size(case):
    from tmpc.runtime.collision.kinematics import Kinematics
    _, model, jax_fk = case
    fk = Kinematics(model)
    rng = np.random.default_rng(5)
    for n in (1, 3, 16, 128, 300):
        Q = _states(model, rng, n)
        R, p = fk(Q)
        Rj, pj = (np.asarray(a) for a in jax_fk(Q))
        assert R.shape == Rj.shape == (len(model.frames), 3, 3, n) and p.shape == pj.shape
        assert (np.isnan(R) == np.isnan(Rj)).all() and (np.isnan(p) == np.isnan(pj)).all()
        assert np.nanmax(np.abs(R - Rj)) < 1e-12 and np.nanmax(np.abs(p - pj)) < 1e-12


def test_matches_pinocchio(case):
    """Against pinocchio's kinematics of the URDF (a fixed base at the URDF's origin: the
    scene's base pose is applied to pinocchio's frames here)."""
    pin = pytest.importorskip("pinocchio")
    from tests.compiler.test_fk import _pin_q
    from tmpc.compiler.robot import pose_matrix
    from tmpc.runtime.collision.kinematics import Kinematics
    tree, model, _ = case
    if model.mobile_base:
        pytest.skip("the mobile base is checked against the JAX kinematics above")
    pmodel = pin.buildModelFromUrdf(tree.path)
    pdata = pmodel.createData()
    base = pose_matrix(model.base_pose)
    Q = _states(model, np.random.default_rng(8), 40)
    R, p = Kinematics(model)(Q)
    worst = 0.0
    for s, q in enumerate(Q):
        pin.forwardKinematics(pmodel, pdata, _pin_q(pmodel, tree, model, q))
        pin.updateFramePlacements(pmodel, pdata)
        for link in tree.links:
            M = pdata.oMf[pmodel.getFrameId(link.name, pin.BODY)]
            i = model.frame(link.name)
            worst = max(worst,
                        np.abs(R[i, :, :, s] - base[:3, :3] @ M.rotation).max(),
                        np.abs(p[i, :, s] - (base[:3, :3] @ M.translation + base[:3, 3])).max())
    assert worst < 1e-9, worst


def test_built_ahead_of_time_equals_the_jit_and_takes_the_exported_types(case):
    import numba

    from tmpc.compiler import aot
    from tmpc.runtime.collision import pass_kernel as jit
    from tmpc.runtime.collision import kernel as kernel_loader
    from tmpc.runtime.collision.kinematics import Kinematics
    _, model, _ = case
    module, why = aot.obtain(kernel_loader.PASS_KERNEL)
    assert module is not None, why
    sig = numba.core.sigutils._parse_signature_string(dict(kernel_loader.PASS_KERNEL.exports)
                                                      ["kinematics"])
    fk = Kinematics(model)
    Q = _states(model, np.random.default_rng(2), 50)
    seen, got = [], []
    state = dict(kernel_loader.KERNEL_STATE)

    def typed(*args):
        seen.append(tuple(numba.typeof(a) for a in args))
        return module.kinematics(*args)

    try:
        for fn in (typed, jit.kinematics):
            kernel_loader.KERNEL_STATE["kinematics"] = fn
            got.append(fk(Q))
    finally:
        kernel_loader.KERNEL_STATE.update(state)
    (R, p), (Rj, pj) = got
    assert np.array_equal(R, Rj, equal_nan=True) and np.array_equal(p, pj, equal_nan=True)
    assert seen == [tuple(sig.args)], (seen, sig.args)


def test_checks_through_either_kinematics_agree():
    """A world on the compiled loop and one on the JAX kinematics answer batches and motions
    alike on the mobile PR2 among tables (the exact confirmations see the same transforms)."""
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.robot import build_robot_model, make_fk_frames
    from tmpc.runtime.collision import CollisionWorld
    from tmpc.runtime.collision.kinematics import Kinematics
    tree = load_urdf(ROBOTS["pr2"])
    model = build_robot_model(tree, RobotSpec(urdf=tree.path, mobile_base=True))
    sc = mobile_scene(model, four_tables())
    ours = CollisionWorld(sc, model)
    theirs = CollisionWorld(sc, model, configured().jit(make_fk_frames(model)))
    assert isinstance(ours.fk_frames, Kinematics)
    A, B = random_motions(model, np.random.default_rng(6), 300, 0.2)
    got = ours.check_batch(A)
    assert (got == theirs.check_batch(A)).all() and got.any() and not got.all()
    t = np.linspace(0.0, 1.0, 8)[:, None]
    segments = [(np.concatenate([a + t * (b - a) for a, b in zip(A[:60], B[:60])]), None, None,
                 [8] * 60)]
    assert [r.tolist() for r in ours.check_segments(segments)] == \
        [r.tolist() for r in theirs.check_segments(segments)]
