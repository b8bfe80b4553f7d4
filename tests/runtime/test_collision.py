"""Collision checking (tmpc.runtime.collision: the world, its first pass and bounding volumes): hand-made scenes with known answers,
the sound first pass against exact fcl, and agreement with an independent implementation
(pinocchio + coal) on thousands of random PR2 and Panda states."""

from __future__ import annotations

import math
from pathlib import Path

import fcl  # python-fcl: a runtime dependency (pyproject), so no skip without it
import numpy as np
import pytest

from tmpc.lang.diagnostics import SceneError
from tmpc.lang.world import load_urdf
from tmpc.lang.world.scene import Pose, RobotSpec, Scene, SceneObject, Shape

ROBOTS = {
    "pr2": "package://example-robot-data/robots/pr2_description/urdf/pr2.urdf",
    "panda": "package://example-robot-data/robots/panda_description/urdf/panda.urdf",
}
TOOL = "r_gripper_tool_frame"


def _load(name: str, **spec):
    from tmpc.compiler.robot import build_robot_model
    from tmpc.runtime.collision.world import jit_fk
    tree = load_urdf(ROBOTS[name])
    model = build_robot_model(tree, RobotSpec(urdf=tree.path, **spec))
    return model, jit_fk(model)


@pytest.fixture(scope="module")
def pr2():
    return _load("pr2")


@pytest.fixture(scope="module")
def pr2_mobile():
    return _load("pr2", mobile_base=True)


@pytest.fixture(scope="module")
def panda():
    return _load("panda")


def box(name, xyz, half, movable=False, yaw=0.0, parent=None):
    return SceneObject(name, Pose.from_xyz_yaw(*xyz, yaw), movable, Shape("box", size=half),
                       parent=parent)


def sphere(name, xyz, r, movable=True):
    return SceneObject(name, Pose(tuple(xyz)), movable, Shape("sphere", radius=r))


def scene(model, *objects, allowed=()):
    return Scene("test", ((-3, 3), (-3, 3), (0, 2)), RobotSpec(urdf=model.tree.path),
                 tuple(objects), tuple(allowed))


def four_tables():
    """Four 1.5 x 0.7 x 0.75 m tables 1.6 m around the origin, facing it."""
    return [box(f"table{k}", (1.6 * math.cos(k * math.pi / 2), 1.6 * math.sin(k * math.pi / 2),
                              0.375), (0.75, 0.35, 0.375), yaw=k * math.pi / 2 + math.pi / 2)
            for k in range(4)]


def mobile_scene(model, objs):
    """A scene of ``objs`` for ``model`` on a mobile base, within 1.5 m of the origin."""
    return Scene("t", ((-1.5, 1.5), (-1.5, 1.5), (0, 2)),
                 RobotSpec(urdf=model.tree.path, mobile_base=True), tuple(objs))


def tables_and_sticks(n: int, x0: float):
    """:func:`four_tables` and n movable sticks standing in a row from x = ``x0``."""
    return four_tables() + [box(f"stick{i}", (x0 + 0.1 * i, 0.1 * (i % 3), 0.9),
                                (0.02, 0.02, 0.15), True) for i in range(n)]


def random_states(model, rng, n: int):
    """n random states of a mobile-base model: base within 1 m of the origin, joints uniform."""
    Q = rng.uniform(model.lower, model.upper, (n, model.dof))
    Q[:, :2] = rng.uniform(-1.0, 1.0, (n, 2))
    return Q


def random_motions(model, rng, n: int, spread: float):
    """n random motions (starts A, ends B) of a mobile-base model: base within 0.8 m of the
    origin, joints uniform, each end ``spread`` (normal) from its start, within the limits."""
    A = rng.uniform(model.lower, model.upper, (n, model.dof))
    A[:, :2] = rng.uniform(-0.8, 0.8, (n, 2))
    return A, np.clip(A + rng.normal(size=A.shape) * spread, model.lower, model.upper)


def world(robot, *objects, allowed_collisions=(), **kw):
    from tmpc.runtime.collision import CollisionWorld
    model, fk = robot
    return CollisionWorld(scene(model, *objects, allowed=allowed_collisions), model, **kw)


def frame_T(robot, q, name):
    from tmpc.compiler.robot import homogeneous
    model, fk = robot
    return homogeneous(fk(np.asarray(q, float)))[model.frame(name)]


def names(report):
    return {(a, b) for a, b, _ in report.pairs}


def q_with(model, **values):
    q = model.default_q.copy()
    for k, v in values.items():
        q[model.q_names.index(k)] = v
    return q


# ---------------------------------------------------------------------------------------------
# hand-made scenes


def test_pr2_default_configuration_is_free_and_allowed_pairs_come_from_srdf_and_tree(pr2):
    from tmpc.runtime.collision.world import (  # re-exported
        find_srdf,
        srdf_disabled_pairs,
    )
    model, _ = pr2
    w = world(pr2)
    assert w.check(model.default_q).valid
    link = w.link_body
    # adjacent through a joint, across the geometry-less wrist roll link and a fixed joint
    assert w.allowed[link["r_wrist_flex_link"], link["r_gripper_palm_link"]]
    srdf = srdf_disabled_pairs(find_srdf(model.tree.path))
    assert len(srdf) > 1000
    a, b = next((a, b) for a, b in srdf if a in link and b in link)
    assert w.allowed[link[a], link[b]]
    # the two shoulders can meet: not allowed
    assert not w.allowed[link["r_shoulder_pan_link"], link["l_shoulder_pan_link"]]
    # without the SRDF some disabled pair does touch at the default configuration
    bare = world(pr2, srdf=False)
    assert not bare.check(model.default_q).valid
    assert all(w.allowed[link[x], link[y]] for x, y, _ in bare.check(model.default_q).pairs)


def test_arm_inside_a_box_names_the_link_and_the_box(pr2):
    model, _ = pr2
    p = frame_T(pr2, model.default_q, "r_forearm_link") @ (0.15, 0, 0, 1)  # mid-forearm
    w = world(pr2, box("box", p[:3], (0.05, 0.05, 0.05)))
    r = w.check(model.default_q)
    assert not r.valid
    assert ("r_forearm_link", "box") in names(r)
    assert all(b == "box" for _, b, _ in r.pairs)
    assert all(d > 0 for *_, d in r.pairs)
    far = world(pr2, box("box", (2.5, 2.5, 0.5), (0.1, 0.1, 0.1)))
    assert far.check(model.default_q).valid


def test_allowed_pairs_by_link_joint_and_scene_names(pr2):
    model, _ = pr2
    p = frame_T(pr2, model.default_q, "r_forearm_link") @ (0.15, 0, 0, 1)
    obj = box("box", p[:3], (0.12, 0.12, 0.12))
    full = names(world(pr2, obj).check(model.default_q))
    by_link = world(pr2, obj, allowed=[("r_forearm_link", "box"), ("no_such_link", "Box")])
    assert names(by_link.check(model.default_q)) == full - {("r_forearm_link", "box")}
    assert by_link.unmatched_allowed == ("no_such_link",)
    # a joint name stands for its child link (tmit-star blocklists name joints)
    by_joint = world(pr2, obj, allowed=[("r_forearm_joint", "box")])
    assert names(by_joint.check(model.default_q)) == full - {("r_forearm_link", "box")}
    everything = [(a, "box") for a, _ in full]
    by_scene = world(pr2, obj, allowed_collisions=everything)
    assert by_scene.check(model.default_q).valid


def test_penetration_depth_against_tolerance_primitives_and_meshes(pr2, tmp_path):
    import trimesh
    model, _ = pr2
    slab = box("slab", (2.0, 0.0, 0.25), (0.3, 0.3, 0.25))          # top at z = 0.5
    ball = sphere("ball", (2.0, 0.0, 0.5 + 0.1 - 0.025), 0.1)          # 2.5 cm deep
    path = tmp_path / "cube.stl"
    trimesh.creation.box((0.2, 0.2, 0.2)).export(path)
    cube = SceneObject("cube", Pose((2.1, 0.0, 0.5 + 0.1 - 0.025)), True,
                       Shape("mesh", mesh=path))
    for obj in (ball, cube):
        exact = world(pr2, slab, obj).check(model.default_q)
        assert [(a, b) for a, b, _ in exact.pairs] == [("slab", obj.name)]
        assert exact.pairs[0][2] == pytest.approx(0.025, abs=1e-6)
        assert not world(pr2, slab, obj, tolerance=0.021).check(model.default_q).valid
        assert world(pr2, slab, obj, tolerance=0.029).check(model.default_q).valid
    # resting contact (depth 0) is no collision
    resting = sphere("ball", (2.0, 0.0, 0.6), 0.1)
    assert world(pr2, slab, resting).check(model.default_q).valid


def test_static_pairs_are_skipped_movable_pairs_are_checked(pr2):
    model, _ = pr2
    a = box("a", (2.0, 0.0, 0.2), (0.2, 0.2, 0.2))
    b = box("b", (2.1, 0.0, 0.2), (0.2, 0.2, 0.2))
    assert world(pr2, a, b).check(model.default_q).valid
    b_movable = box("b", (2.1, 0.0, 0.2), (0.2, 0.2, 0.2), movable=True)
    w = world(pr2, a, b_movable)
    assert names(w.check(model.default_q)) == {("a", "b")}
    # a world pose for the movable one moves it away
    T = np.eye(4)
    T[:3, 3] = (2.0, 1.0, 0.2)
    assert w.check(model.default_q, poses={"b": T}).valid


def test_object_parents_compose_poses(pr2):
    model, _ = pr2
    table = box("table", (2.0, 0.0, 0.375), (0.5, 0.5, 0.375))
    # 0.5 m above the table's center: 0.125 m above its top, relative to the table
    cup = SceneObject("cup", Pose((0.3, 0.0, 0.5)), True, Shape("sphere", radius=0.1),
                      parent="table")
    other = sphere("other", (2.3, 0.0, 0.875 + 0.15), 0.1)
    assert names(world(pr2, table, cup, other).check(model.default_q)) == {("cup", "other")}
    on_hand = SceneObject("tag", Pose((0.0, 0.0, 0.0)), True, Shape("sphere", radius=0.02),
                          parent=TOOL)
    w = world(pr2, on_hand, box("wall", (0.951, -0.188, 1.2), (0.3, 0.3, 0.1)))
    up = q_with(model, r_shoulder_lift_joint=-0.5)
    assert ("tag", "wall") in names(w.check(up))
    assert w.check(model.default_q).valid


def test_an_object_on_the_robot_moves_with_the_base(pr2_mobile):
    model, _ = pr2_mobile
    # "robot" (the robot's name) as a parent: the base frame
    bumper = SceneObject("bumper", Pose((1.0, 0.0, 0.3)), True, Shape("sphere", radius=0.05),
                         parent="robot")
    post = box("post", (2.0, 0.0, 0.3), (0.03, 0.03, 0.03))
    sc = Scene("t", ((-3, 3), (-3, 3), (0, 2)),
               RobotSpec(urdf=model.tree.path, mobile_base=True), (bumper, post))
    from tmpc.runtime.collision import CollisionWorld
    w = CollisionWorld(sc, model)
    there = q_with(model, base_x=1.0)
    assert w.check(model.default_q).valid
    assert names(w.check(there)) == {("bumper", "post")}
    assert list(w.check_batch(np.stack([model.default_q, there]))) == [True, False]


def _stick():
    return box("stick", (0.0, 2.0, 0.3), (0.02, 0.02, 0.15), movable=True)


def test_held_object_moves_with_the_gripper_and_hits_the_table(pr2):
    model, _ = pr2
    p = frame_T(pr2, model.default_q, TOOL)[:3, 3]
    table = box("table", (p[0], p[1], (p[2] - 0.1) / 2), (0.3, 0.3, (p[2] - 0.1) / 2))
    w = world(pr2, table, _stick())
    held = {"stick": (TOOL, np.eye(4))}
    # in the gripper at the default configuration: 5 cm into the table, touching the fingers
    r = w.check(model.default_q, attached=held)
    assert names(r) == {("table", "stick")}
    assert r.pairs[0][2] == pytest.approx(0.05, abs=1e-6)
    assert w.check(model.default_q).valid                 # not held: the stick stays away
    up = q_with(model, r_shoulder_lift_joint=-0.4)
    assert w.check(up, attached=held).valid
    # the hand exclusion is what hides the fingers: without it they collide with the stick
    strict = world(pr2, table, _stick(), attach_allowed={TOOL: []})
    got = names(strict.check(up, attached=held))
    assert any(a.startswith("r_gripper") and b == "stick" for a, b in got)
    # held away from the hand, it hits the forearm
    back = np.eye(4)
    back[0, 3] = -0.3
    hit = names(w.check(up, attached={"stick": ("r_gripper_tool_joint", back)}))
    assert any(a in ("r_forearm_link", "r_wrist_flex_link") and b == "stick" for a, b in hit)


def test_motion_finds_the_first_collision_and_takes_the_short_way_round(pr2):
    model, _ = pr2
    p = frame_T(pr2, model.default_q, TOOL)[:3, 3]
    table = box("table", (p[0], p[1], (p[2] - 0.1) / 2), (0.3, 0.3, (p[2] - 0.1) / 2))
    w = world(pr2, table, _stick())
    held = {"stick": (TOOL, np.eye(4))}
    up = q_with(model, r_shoulder_lift_joint=-0.4)
    m = w.check_motion(up, model.default_q, resolution=0.01, attached=held)
    assert not m.valid and 0.0 < m.t_first_collision < 1.0
    assert m.steps == 40
    assert names(m.report) == {("table", "stick")}
    exact = world(pr2, table, _stick(), first_pass=False)
    assert exact.check_motion(up, model.default_q, 0.01, attached=held) == m
    # the state just before the first collision is free
    before = up + (m.t_first_collision - 1 / m.steps) * (model.default_q - up)
    assert w.check(before, attached=held).valid
    assert w.check_motion(model.default_q, up, attached=held).t_first_collision == 0.0
    assert w.check_motion(up, q_with(model, r_shoulder_lift_joint=-0.3), attached=held).valid
    # a continuous joint from 3.0 to -3.0 goes through pi, not through 0
    a, b = q_with(model, r_forearm_roll_joint=3.0), q_with(model, r_forearm_roll_joint=-3.0)
    Q = w.interpolate(a, b, 0.02)
    i = model.q_names.index("r_forearm_roll_joint")
    assert len(Q) == math.ceil((2 * math.pi - 6.0) / 0.02) + 1
    assert np.all(np.abs(np.diff(Q[:, i])) <= 0.02 + 1e-12)
    assert np.all(np.abs(Q[:, i]) >= 3.0 - 1e-12)


# ---------------------------------------------------------------------------------------------
# the first pass is sound


def test_covers_contain_their_geometry():
    from tmpc.runtime.collision.geometry import load_mesh
    from tmpc.runtime.collision.spheres import ball, cover, hull_points
    rng = np.random.default_rng(0)
    tree = load_urdf(ROBOTS["pr2"])
    shapes = [(g.shape, load_mesh(g.shape.mesh, g.shape.scale) if g.shape.kind == "mesh"
               else None) for lk in tree.links for g in lk.collision]
    shapes += [(Shape("box", size=(0.02, 0.3, 0.7)), None),
               (Shape("cylinder", radius=0.03, length=0.4), None),
               (Shape("sphere", radius=0.2), None)]
    for shape, mesh in shapes:
        if mesh is not None:      # points on the surface: random points of random triangles
            tri = mesh.vertices[mesh.faces[rng.integers(len(mesh.faces), size=4000)]]
            u = rng.dirichlet(np.ones(3), 4000)
            pts = (tri * u[:, :, None]).sum(1)
        elif shape.kind == "box":
            pts = rng.uniform(-1, 1, (4000, 3)) * shape.size
        elif shape.kind == "cylinder":
            ang, rad = rng.uniform(0, 2 * np.pi, 4000), shape.radius * np.sqrt(rng.random(4000))
            pts = np.stack([rad * np.cos(ang), rad * np.sin(ang),
                            rng.uniform(-0.5, 0.5, 4000) * shape.length], 1)
        else:
            v = rng.normal(size=(4000, 3))
            pts = v / np.linalg.norm(v, axis=1)[:, None] * shape.radius * rng.random((4000, 1))
        C, r = cover(shape, mesh)
        d = np.linalg.norm(pts[:, None] - C[None], axis=2) - r[None]
        assert (d.min(1) <= 0).all(), shape
        c, R = ball(shape, mesh)
        assert (np.linalg.norm(pts - c, axis=1) <= R).all()
        # the convex stage's hull: no point beyond its support in any of 200 directions
        fast, every, rad = hull_points(shape, mesh)
        assert len(fast) and every is None     # qhull hulls of the PR2 meshes are trusted
        D = rng.normal(size=(200, 3))
        D /= np.linalg.norm(D, axis=1)[:, None]
        assert ((pts @ D.T) <= (fast @ D.T).max(0) + rad + 1e-12).all(), shape


def _convex_pair(shapes, rng):
    """Two of ``shapes`` (shape, MeshData or None) at random poses 0-0.6 m apart: their fcl
    objects (geometry, hull) and the convex stage's arrays for
    :func:`tmpc.runtime.collision.pass_kernel.apart`."""
    from tmpc.runtime.collision.geometry import fcl_geometry
    from tmpc.runtime.collision.spheres import hull_points, ragged
    R, p = np.zeros((2, 3, 3, 1)), np.zeros((2, 3, 1))
    objs, fast, every, rad = [], [], [], []
    for k in range(2):
        shape, mesh = shapes[rng.integers(len(shapes))]
        q = rng.normal(size=4)
        w, x, y, z = q / np.linalg.norm(q)
        R[k, :, :, 0] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        p[k, :, 0] = rng.uniform(-0.3, 0.3, 3) * k
        geom, hull, *_ = fcl_geometry(shape, "test")
        tf = fcl.Transform(R[k, :, :, 0], p[k, :, 0])
        objs.append((fcl.CollisionObject(geom, tf),
                     fcl.CollisionObject(hull if hull is not None else geom, tf)))
        f, e, r = hull_points(shape, mesh)
        fast.append(f)
        every.append(np.zeros((0, 3)) if e is None else e)
        rad.append(r)
    hp, hs = ragged(fast)
    ap, as_ = ragged(every)
    return objs, (hp, ap, hs[0], hs[1], as_[0], as_[1], rad[0], 0, hs[1], hs[2], as_[1], as_[2],
                  rad[1], 1, R, p, 0)


def test_convex_stage_separates_only_what_fcl_finds_apart():
    """GJK with a checked separating plane (pass_kernel.apart) on 1,500 random pairs of PR2
    link meshes, boxes, cylinders and spheres: a pair it calls apart never touches in fcl
    (sound), and every pair whose convex hulls fcl puts over 1 mm apart it calls apart (the
    stage works), from any starting direction."""
    from tmpc.runtime.collision.geometry import load_mesh
    from tmpc.runtime.collision.pass_kernel import apart as separated
    rng = np.random.default_rng(4)
    tree = load_urdf(ROBOTS["pr2"])
    shapes = [(g.shape, load_mesh(g.shape.mesh, g.shape.scale)) for lk in tree.links[:40]
              for g in lk.collision if g.shape.kind == "mesh"]
    shapes += [(Shape("box", size=(0.02, 0.1, 0.15)), None),
               (Shape("cylinder", radius=0.05, length=0.2), None),
               (Shape("sphere", radius=0.06), None)]
    S, d = np.empty((4, 3)), np.empty(3)
    seen = {"apart": 0, "touch": 0, "near": 0}
    for _ in range(1500):
        (a, b), args = _convex_pair(shapes, rng)
        touch = fcl.collide(a[0], b[0], fcl.CollisionRequest(), fcl.CollisionResult())
        hull_gap = fcl.distance(a[1], b[1], fcl.DistanceRequest(), fcl.DistanceResult())
        p = args[-2]
        for start in (p[1, :, 0] - p[0, :, 0] + 1e-3, rng.normal(size=3)):
            apart = separated(*args, *start, S, d)
            assert not (apart and touch)
            assert apart or hull_gap <= 1e-3 or touch, hull_gap
        seen["apart" if apart else ("touch" if touch else "near")] += 1
    assert min(seen.values()) > 20, seen


def test_a_hull_that_misses_a_vertex_is_checked_on_every_vertex():
    """A mesh whose stored hull leaves out a vertex (a cube with a spike, given the cube's hull)
    is not trusted: the stage's separating plane is checked on every vertex, so a ball on the
    spike's tip, which fcl finds touching, is not ruled out; away from the spike it still is."""
    import trimesh

    from tmpc.runtime.collision.geometry import MeshData
    from tmpc.runtime.collision.pass_kernel import apart as separated
    from tmpc.runtime.collision.spheres import hull_points, ragged
    cube = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    spiky = trimesh.util.concatenate([cube, trimesh.creation.cone(0.05, 0.2)])
    V, F = np.asarray(spiky.vertices), np.asarray(spiky.faces)
    mesh = MeshData(V, F, np.asarray(cube.vertices), np.asarray(cube.faces))
    fast, every, r = hull_points(Shape("mesh", mesh="spike.stl"), mesh)
    assert every is not None and len(every) == len(V)
    bvh = fcl.BVHModel()
    bvh.beginModel(len(V), len(F))
    bvh.addSubModel(V, F)
    bvh.endModel()
    S, d = np.empty((4, 3)), np.empty(3)
    R, p = np.tile(np.eye(3)[None, :, :, None], (2, 1, 1, 1)), np.zeros((2, 3, 1))
    hp, hs = ragged([fast, np.zeros((1, 3))])
    ap, as_ = ragged([every, np.zeros((0, 3))])
    for z, touching in ((0.19, True), (-0.25, False)):
        p[1, :, 0] = (0, 0, z)
        ball = fcl.CollisionObject(fcl.Sphere(0.02), fcl.Transform(np.eye(3), p[1, :, 0]))
        hit = fcl.collide(fcl.CollisionObject(bvh, fcl.Transform()), ball,
                          fcl.CollisionRequest(), fcl.CollisionResult())
        assert hit == touching
        apart = separated(hp, ap, hs[0], hs[1], as_[0], as_[1], r, 0, hs[1], hs[2], as_[1], as_[2],
                       0.02, 1, R, p, 0, 0.0, 0.0, z, S, d)
        assert apart == (not touching), z


def test_first_pass_never_frees_a_colliding_state(pr2_mobile):
    """Thousands of random PR2 states with a mobile base among boxes, movable sticks and a held
    object: the batched path (pass + fcl on candidates) equals exact fcl on every state, and
    every colliding pair of every state is among the pass's candidates (of a state with a pair
    sure to collide, that one is enough)."""
    from tmpc.runtime.collision import CollisionWorld
    model, fk = pr2_mobile
    objs = four_tables()
    objs += [box(f"stick{i}", (1.6 + 0.1 * i, 0.1 * (i % 3), 0.9), (0.02, 0.02, 0.15), True)
             for i in range(4)]
    objs.append(sphere("ball", (0.0, 0.0, 1.6), 0.1))
    sc = mobile_scene(model, objs)
    w = CollisionWorld(sc, model)
    exact = CollisionWorld(sc, model, first_pass=False)
    rng = np.random.default_rng(11)
    Q = rng.uniform(model.lower, model.upper, (3000, model.dof))
    Q[:, :2] = rng.uniform(-1.0, 1.0, (3000, 2))
    held = {"stick0": (TOOL, np.eye(4))}
    for att in (None, held):
        batch = w.check_batch(Q, attached=att)
        truth = exact.check_batch(Q, attached=att)
        assert (batch == truth).all(), np.nonzero(batch != truth)
        assert 0.1 < (~truth).mean() < 0.9
    # several modes in one call (the kinematics shared, chunks crossing group boundaries):
    # each group's answer is exact fcl's for its own held objects and object poses
    T = np.eye(4)
    T[:3, 3] = (0.3, -0.2, 1.1)
    moved = {"stick1": T}
    groups = [(Q[:70], None, None), (Q[70:71], None, held), (Q[71:71], moved, None),
              (Q[71:400], moved, held), (Q[400:420], None, None)]
    for (G, poses, att), got in zip(groups, w.check_batches(groups)):
        assert (got == exact.check_batch(G, poses=poses, attached=att)).all()
    assert [len(ok) for ok in w.check_batches([(Q[:0], None, None), (Q[:0], moved, held)])] \
        == [0, 0]
    # pair level, on 500 states: colliding pairs are a subset of the candidates (but for the
    # states settled by a pair sure to collide, the pass's last of those)
    fp = w.first_pass()
    place, allowed = w.placements(attached=held)
    cand = fp.candidates(Q[:500], fp.plan(place, allowed))
    body = lambda g: w.bodies[w.geoms[g].body].name
    got = {(int(s), frozenset((body(a), body(b))))
           for s, a, b in zip(cand.states, cand.ga, cand.gb)}
    fixed = {o.name for o in objs} - {"stick0"}        # checked once per batch, not per state
    settled = set(cand.states[cand.sure].tolist())
    missing = [(i, a, b) for i in range(500) for a, b, _ in w.check(Q[i], attached=held).pairs
               if (i, frozenset((a, b))) not in got and not {a, b} <= fixed
               and i not in settled]
    assert missing == [] and 10 < len(settled) < 400
    assert w.stats.states >= 6000 and w.stats.sure > 0
    # the convex stage (GJK on the hulls) rules out a fifth or more of what the covers leave
    assert w.stats.fine_pairs < 0.8 * w.stats.cover_pairs, w.stats


def test_objects_that_stay_put_collide_as_exact_fcl_says_placement_after_placement(pr2_mobile):
    """The answer for two objects that stay put is kept by their two poses: placements that
    move one stick onto another and away, and back to poses seen before (answered from what
    was kept), give exact fcl's answer every time, and the kept answers are asked no more."""
    from tmpc.runtime.collision import CollisionWorld
    model, fk = pr2_mobile
    objs = four_tables() + [box(f"stick{i}", (1.6 + 0.1 * i, 0.1 * i, 0.9), (0.02, 0.02, 0.15),
                                True) for i in range(3)]
    sc = mobile_scene(model, objs)
    w, exact = CollisionWorld(sc, model), CollisionWorld(sc, model, first_pass=False)
    Q = np.repeat(model.default_q[None], 5, 0)
    Q[:, 0] = np.linspace(-0.3, 0.3, 5)

    def at(x, y):
        T = np.eye(4)
        T[:3, 3] = (x, y, 0.9)
        return T
    onto, away, aside = at(1.7, 0.1), at(1.2, -0.4), at(1.72, 0.12)
    seq = [{"stick0": away}, {"stick0": onto}, {"stick0": away}, {"stick0": aside},
           {"stick0": onto, "stick1": away}, {"stick0": onto}, {"stick0": away}]
    answers = []
    for poses in seq:
        got = w.check_batch(Q, poses=poses)
        assert (got == exact.check_batch(Q, poses=poses)).all(), poses
        answers.append(bool(got.all()))
    assert answers == [True, False, True, False, True, False, True]
    kept = dict(w.batch._fixed_pair)
    w.batch._fixed_of.clear()             # the placements forgotten, the pairs' answers kept
    w.exact.fixed = None
    asked = []
    real = w.exact.depth
    w.exact.depth = lambda a, b: asked.append((a, b)) or real(a, b)
    for poses in seq:
        assert (w.check_batch(Q, poses=poses) == exact.check_batch(Q, poses=poses)).all()
    assert asked == [] and w.batch._fixed_pair == kept


def test_pairs_sure_to_collide_collide_in_exact_fcl(pr2_mobile):
    """The pairs the pass marks sure to collide (a link mesh's hull vertex deeper than the
    tolerance + SURE_DEPTH inside a box, settled with no fcl query) are colliding pairs of exact
    fcl, with a held box and at a tolerance; each is its state's last candidate; and the states
    they settle save queries (same answers with the test switched off)."""
    from tmpc.runtime.collision import CollisionWorld, first_pass
    model, fk = pr2_mobile
    sc = mobile_scene(model, tables_and_sticks(3, 1.2))
    Q = random_states(model, np.random.default_rng(8), 1500)
    body = lambda w, g: w.bodies[w.geoms[g].body].name
    for tol, att in ((0.0, None), (0.02, {"stick0": (TOOL, np.eye(4))})):
        w = CollisionWorld(sc, model, tolerance=tol)
        fp = w.first_pass()
        cand = fp.candidates(Q, fp.plan(*w.placements(attached=att)))
        sure = cand.sure
        assert 30 < sure.sum() < len(sure)
        rows = np.nonzero(sure)[0]
        rows = rows[rows + 1 < len(sure)]
        assert (cand.states[rows + 1] != cand.states[rows]).all()     # its state's last pair
        for s, a, b in zip(cand.states[sure], cand.ga[sure], cand.gb[sure]):
            pairs = {frozenset(p[:2]) for p in w.check(Q[s], attached=att).pairs}
            assert frozenset((body(w, a), body(w, b))) in pairs
        ok = w.check_batch(Q, attached=att)
        off = CollisionWorld(sc, model, tolerance=tol)
        old = first_pass.SURE_DEPTH
        try:
            first_pass.SURE_DEPTH = math.inf
            assert (off.check_batch(Q, attached=att) == ok).all()
        finally:
            first_pass.SURE_DEPTH = old
        assert w.stats.sure > 0 and off.stats.sure == 0
        assert w.stats.queries < 0.9 * off.stats.queries, (w.stats, off.stats)


def test_first_pass_outputs_grow_when_a_batch_has_many_candidates(pr2_mobile, monkeypatch):
    """The compiled pass writes candidates into arrays of 4 per state and starts again with
    larger ones when they fill up: a batch buried in a box (most links a candidate in every
    state; no pair taken as sure to collide, which would end each state's list) gives, state
    for state, the candidates of the same states passed one at a time."""
    from tmpc.runtime.collision import CollisionWorld, first_pass
    monkeypatch.setattr(first_pass, "SURE_DEPTH", math.inf)
    model, fk = pr2_mobile
    objs = [box("slab", (0.0, 0.0, 0.8), (1.0, 1.0, 0.6)),
            box("post", (0.3, 0.0, 1.0), (0.1, 0.1, 0.5), True)]
    sc = mobile_scene(model, objs)
    w = CollisionWorld(sc, model)
    rng = np.random.default_rng(3)
    Q = rng.uniform(model.lower, model.upper, (40, model.dof))
    Q[:, :2] = rng.uniform(-0.2, 0.2, (40, 2))
    fp = w.first_pass()
    place, allowed = w.placements()
    plan = fp.plan(place, allowed)
    batch = fp.candidates(Q, plan)
    assert len(batch.states) > 4 * len(Q)              # the first outputs were too short
    one = [fp.candidates(Q[i:i + 1], plan) for i in range(len(Q))]
    for i, c in enumerate(one):
        sel = batch.states == i
        assert sorted(zip(batch.ga[sel].tolist(), batch.gb[sel].tolist())) == \
            sorted(zip(c.ga.tolist(), c.gb.tolist()))
    assert batch.coarse == sum(c.coarse for c in one)
    assert (w.check_batch(Q) == CollisionWorld(sc, model, first_pass=False).check_batch(Q)).all()


def test_batched_motion_checks_equal_exact_fcl(pr2_mobile):
    """Random straight motions: the batched path (all interpolated states through the first
    pass, fcl only on its candidates) finds the same first colliding state as exact fcl."""
    from tmpc.runtime.collision import CollisionWorld
    model, fk = pr2_mobile
    objs = four_tables()
    sc = mobile_scene(model, objs)
    fast, exact = CollisionWorld(sc, model), CollisionWorld(sc, model, first_pass=False)
    A, B = random_motions(model, np.random.default_rng(5), 60, 0.4)
    outcomes = set()
    for a, b in zip(A, B):
        m1 = fast.check_motion(a, b, 0.05, details=False)
        m2 = exact.check_motion(a, b, 0.05, details=False)
        assert (m1.valid, m1.t_first_collision, m1.steps) == \
            (m2.valid, m2.t_first_collision, m2.steps)
        outcomes.add(m1.valid)
    assert outcomes == {True, False}          # both kinds of motion were exercised


def test_motion_segments_equal_exact_fcl_with_fewer_exact_queries(pr2_mobile):
    """``check_segments`` (the planners' batched motions: exact fcl stops a motion at its first
    colliding state, middle first) gives each motion the validity exact fcl gives all its
    states, over several groups in one call (held objects, moved objects, empty motions),
    with and without the first pass, and confirms fewer pairs than the per-state answer."""
    from tmpc.runtime.collision import CollisionWorld
    from tmpc.runtime.collision.exact import ExactChecker
    from tmpc.runtime.collision.motion import bisection_ranks
    model, fk = pr2_mobile
    objs = four_tables()
    objs.append(box("stick1", (1.6, 0.1, 0.9), (0.02, 0.02, 0.15), True))
    sc = mobile_scene(model, objs)
    fast, exact = CollisionWorld(sc, model), CollisionWorld(sc, model, first_pass=False)
    A, B = random_motions(model, np.random.default_rng(9), 90, 0.5)
    T = np.eye(4)
    T[:3, 3] = (0.3, -0.2, 1.1)
    held = {"stick1": (TOOL, np.eye(4))}

    def motions(lo, hi, poses, att):
        segs = [fast.interpolate(a, b, 0.05) for a, b in zip(A[lo:hi], B[lo:hi])]
        segs.insert(len(segs) // 2, np.zeros((0, model.dof)))       # a motion of no state
        return (np.concatenate(segs), poses, att, [len(q) for q in segs]), segs

    parts = [motions(0, 30, None, None), motions(30, 31, {"stick1": T}, None),
             motions(31, 90, None, held)]
    groups = [g for g, _ in parts]
    truth = [np.array([exact.check_batch(q, poses=g[1], attached=g[2]).all() if len(q) else True
                       for q in segs]) for g, segs in parts]
    assert set(np.concatenate(truth).tolist()) == {True, False}
    for w in (fast, exact):
        got = w.check_segments(groups)
        assert [g.tolist() for g in got] == [t.tolist() for t in truth]
    calls = {"n": 0}
    depth = ExactChecker.depth

    def counting(self, a, b):
        calls["n"] += 1
        return depth(self, a, b)

    ExactChecker.depth = counting
    try:
        fast.check_segments(groups)
        by_segment = calls["n"]
        calls["n"] = 0
        fast.check_batches([g[:3] for g in groups])
        per_state = calls["n"]
    finally:
        ExactChecker.depth = depth
    assert by_segment < 0.8 * per_state, (by_segment, per_state)
    # one mode's motions (OMPL's, the shortcuts'): the first pass saw each motion's middle and
    # quarter states, then the rest of the motions that held there only (motion.PROBE_STATES)
    before = fast.stats.states
    assert fast.check_segments([groups[2]])[0].tolist() == truth[2].tolist()
    passed, states = fast.stats.states - before, len(groups[2][0])
    assert passed < 0.8 * states, (passed, states)
    # bisection order: the middle state first, then the middles of the halves
    assert bisection_ranks(np.array([1, 0, 5, 2])).tolist() == [0, 3, 1, 0, 4, 2, 1, 0]
    with pytest.raises(ValueError):
        fast.check_segments([(A[:3], None, None, [1, 1])])


def test_pass_built_ahead_of_time_equals_numba_jit_and_takes_what_the_pass_gives(pr2_mobile):
    """The collision pass a run loads (built ahead of time by numba.pycc) and numba's JIT of
    the same source give the same candidates, state for state, on random states with and
    without a held object; every argument the pass hands it has the exported signature's type
    (an AOT module raises on others instead of compiling anew)."""
    import numba

    from tmpc.compiler import aot
    from tmpc.runtime.collision import CollisionWorld
    from tmpc.runtime.collision import kernel
    from tmpc.runtime.collision import pass_kernel as jit
    model, fk = pr2_mobile
    module, why = aot.obtain(kernel.PASS_KERNEL)
    assert module is not None, why
    objs = four_tables()
    objs.append(box("stick0", (1.6, 0.1, 0.9), (0.02, 0.02, 0.15), True))
    sc = mobile_scene(model, objs)
    w = CollisionWorld(sc, model)
    fp = w.first_pass()
    rng = np.random.default_rng(4)
    Q = rng.uniform(model.lower, model.upper, (600, model.dof))
    Q[:, :2] = rng.uniform(-1.0, 1.0, (600, 2))
    sig = numba.core.sigutils._parse_signature_string(dict(kernel.PASS_KERNEL.exports)
                                                      ["candidates"])
    seen = []

    def typed(*args):
        seen.append(tuple(numba.typeof(a) for a in args))
        return module.candidates(*args)

    state = dict(kernel.KERNEL_STATE)
    try:
        for att in (None, {"stick0": (TOOL, np.eye(4))}):
            plan = fp.plan(*w.placements(attached=att))
            got = []
            for fn in (typed, jit.candidates):
                kernel.KERNEL_STATE["candidates"] = fn
                got.append(fp.candidates(Q, plan))
            a, b = got
            assert len(a.states) > 100
            for f in ("states", "ga", "gb", "sure"):
                assert (getattr(a, f) == getattr(b, f)).all()
            assert a.coarse == b.coarse
    finally:
        kernel.KERNEL_STATE.update(state)
    assert seen and all(t == tuple(sig.args) for t in seen), (seen[0], sig.args)


def test_exact_queries_ask_the_pairs_found_colliding_before_first(pr2_mobile):
    """Confirming a state's candidate pairs in the order of how often each pair was found
    colliding so far costs fewer exact queries than the pass's order (a colliding state then
    needs about one), with the same answers. Without the convex stage, which leaves fewer pairs
    to order (with it: 1,745 queries against 2,051)."""
    from tmpc.runtime.collision import CollisionWorld
    model, fk = pr2_mobile
    sc = mobile_scene(model, tables_and_sticks(4, 1.6))
    Q = random_states(model, np.random.default_rng(2), 3000)
    learned, forgetful = CollisionWorld(sc, model), CollisionWorld(sc, model)
    for w in (learned, forgetful):
        fp = w.first_pass()
        fp.hulls = [(np.zeros((0, 3)), None, 0.0)] * len(fp.hulls)
    confirm = forgetful.batch.confirm

    def forget(*args):
        if forgetful.batch.pair_tries is not None:
            forgetful.batch.pair_tries[:] = 0
            forgetful.batch.pair_hits[:] = 0
        return confirm(*args)

    forgetful.batch.confirm = forget
    a, b = learned.check_batch(Q), forgetful.check_batch(Q)
    assert (a == b).all() and 0.1 < (~a).mean() < 0.9
    assert learned.stats.queries < 0.85 * forgetful.stats.queries, \
        (learned.stats.queries, forgetful.stats.queries)


def test_a_refused_call_of_the_built_pass_is_answered_by_the_jit(pr2_mobile, monkeypatch):
    """The pass's call reaches numba's JIT when the module built ahead of time refuses its
    arguments (a TypeError): the batch's answers are still exact fcl's, with a warning."""
    from tmpc.runtime.collision import CollisionWorld, kernel
    model, fk = pr2_mobile
    sc = mobile_scene(model, four_tables())
    w, exact = CollisionWorld(sc, model), CollisionWorld(sc, model, first_pass=False)

    def refuses(*args):
        raise TypeError("No matching definition")

    kernel.pass_kernel()                  # both functions loaded, then the pass refuses
    state = dict(kernel.KERNEL_STATE)
    state.update(candidates=refuses, why=None)
    monkeypatch.setattr(kernel, "KERNEL_STATE", state)
    Q, _ = random_motions(model, np.random.default_rng(3), 200, 0.1)
    with pytest.warns(UserWarning, match="refused a call"):
        got = w.check_batch(Q)
    assert (got == exact.check_batch(Q)).all() and not got.all() and got.any()
    assert kernel.KERNEL_STATE["why"].startswith("a refused call")


def _stacked_numpy_free(T, Q):
    """The stacked tables' formula in numpy, all tables at once (what the compiled
    ``table_free`` replaced): a second reference."""
    x = np.asarray(Q)[:, T.cols]                             # (B, T, 2)
    span = np.where(T.wrap, 2 * np.pi, 1.0)
    x = np.where(T.wrap, (x - T.lo) % span + T.lo, x)
    idx = np.rint((x - T.lo) / T.step).astype(np.int64)
    idx = np.where(T.wrap, idx % T.n, np.minimum(np.maximum(idx, 0), T.n - 1))
    dev = np.abs(x - (T.lo + idx * T.step))
    dev = np.where(T.wrap, np.minimum(dev, 2 * np.pi - dev), dev)
    flat = T.start + idx[..., 0] * T.n[:, 1] + idx[..., 1]
    return (T.dist[flat] > (T.rate * dev).sum(-1)).T


def _one_table_free(t, Q):
    """A table's bound at the nearest grid point against the most the pair can have
    approached since (docs/collision.md, "Pair tables"), one table at a time: the reference
    for the stacked tables."""
    x = Q[:, t.cols]
    span = np.where(t.wrap, 2 * np.pi, 1.0)
    x = np.where(t.wrap, (x - t.lo) % span + t.lo, x)
    idx = np.rint((x - t.lo) / t.step).astype(np.int64)
    idx = np.where(t.wrap, idx % t.n, np.clip(idx, 0, t.n - 1))
    dev = np.abs(x - (t.lo + idx * t.step))
    dev = np.where(t.wrap, np.minimum(dev, 2 * np.pi - dev), dev)
    flat = np.ravel_multi_index(tuple(idx.T), tuple(t.n))
    return t.dist[flat] > (t.rate * dev).sum(1)


def test_pair_tables_read_at_once_answer_as_each_table():
    """The stacked tables (one compiled call per first pass) answer exactly as each table alone,
    by the formula written out one table at a time: one- and two-coordinate tables, wrapping
    coordinates (states several turns away), states outside the limits and on grid
    points."""
    from tmpc.runtime.collision.pair_table import PairTable, PairTables
    rng = np.random.default_rng(5)
    tables = []
    for k, (cols, wrap) in enumerate([((3,), (False,)), ((1, 4), (False, True)),
                                      ((0,), (True,)), ((2, 5), (False, False)),
                                      ((5, 1), (True, True))]):
        wrap = np.array(wrap)
        lo = np.where(wrap, -np.pi, rng.uniform(-2, 0, len(cols)))
        hi = np.where(wrap, np.pi, rng.uniform(0.5, 2, len(cols)))
        n = rng.integers(2, 40, len(cols))
        step = np.where(wrap, (hi - lo) / n, (hi - lo) / (n - 1))
        tables.append(PairTable(k, k + 1, np.array(cols), lo, step, n, wrap,
                                rng.uniform(0.01, 0.5, len(cols)),
                                rng.uniform(-0.01, 0.3, int(np.prod(n)))))
    Q = rng.uniform(-9, 9, (3000, 6))
    Q[:500] = np.round(Q[:500], 1)                 # some on grid lines and cell borders
    stacked = PairTables.of(tables)
    each = np.stack([_one_table_free(t, Q) for t in tables])
    assert stacked.free(Q).shape == each.shape == (5, 3000)
    assert (stacked.free(Q) == each).all() and 0.05 < each.mean() < 0.95
    assert (_stacked_numpy_free(stacked, Q) == each).all()
    assert (np.stack([stacked.free(q[None])[:, 0] for q in Q[:200]], 1) == each[:, :200]).all()
    assert PairTables.of([]).free(Q).shape == (0, 3000)
    # the module built ahead of time takes exactly what free passes, as numba's JIT does
    import numba

    from tmpc.compiler import aot
    from tmpc.runtime.collision import kernel
    from tmpc.runtime.collision import pass_kernel as jit
    module, why = aot.obtain(kernel.PASS_KERNEL)
    assert module is not None, why
    sig = numba.core.sigutils._parse_signature_string(dict(kernel.PASS_KERNEL.exports)
                                                      ["table_free"])
    args = (np.ascontiguousarray(Q), *stacked._args, np.empty((5, 3000), bool))
    assert tuple(numba.typeof(a) for a in args) == tuple(sig.args)
    for fn in (module.table_free, jit.table_free):
        args[-1][:] = ~each
        fn(*args)
        assert (args[-1] == each).all()


def test_pair_table_frees_only_pairs_that_do_not_touch(pr2):
    """The PR2 shoulder pan links depend on two joints only: their table's "free" answer is
    checked against fcl over the whole range of both joints (they do meet in it)."""
    from tmpc.runtime.collision.exact import world_transforms
    model, _ = pr2
    w = world(pr2)
    fp = w.first_pass()
    plan = fp.plan(*w.placements())
    (k, table), = plan.tables
    names = {w.bodies[w.geoms[g].body].name for g in (table.ga, table.gb)}
    assert names == {"r_shoulder_pan_link", "l_shoulder_pan_link"}
    assert [model.q_names[c] for c in table.cols] == ["r_shoulder_pan_joint",
                                                      "l_shoulder_pan_joint"]
    rng = np.random.default_rng(2)
    Q = np.repeat(model.default_q[None], 4000, 0)
    Q[:, table.cols] = rng.uniform(model.lower[table.cols], model.upper[table.cols], (4000, 2))
    free = table.free(Q)
    fpos, local, R, p = w.frames(Q, w.default_place)
    touching = np.zeros(len(Q), bool)
    for i in range(len(Q)):
        T = world_transforms(R[i], p[i], fpos, local)
        for g in (table.ga, table.gb):
            w.exact.set_pose(g, T[w.dynamic_position[g]])
        touching[i] = w.exact.depth(table.ga, table.gb) is not None
    assert not (free & touching).any()
    assert touching.sum() > 50 and free.mean() > 0.6
    # the Lipschitz bound itself, where it matters: half a cell away from grid points whose
    # distance is small, the true (BVH) distance is at least the table's bound
    near = np.nonzero((table.dist > 0) & (table.dist < 0.05))[0][:200]
    idx = np.stack(np.unravel_index(near, tuple(table.n)), 1)
    X = np.repeat(model.default_q[None], len(near), 0)
    sign = rng.choice([-1.0, 1.0], (len(near), 2))
    X[:, table.cols] = table.lo + idx * table.step + sign * table.step / 2
    inside = ((X[:, table.cols] >= model.lower[table.cols])
              & (X[:, table.cols] <= model.upper[table.cols])).all(1)
    X, near = X[inside], near[inside]
    bound = table.dist[near] - (table.rate * table.step / 2).sum()
    fpos, local, R, p = w.frames(X, w.default_place)
    true = np.empty(len(X))
    for i in range(len(X)):
        T = world_transforms(R[i], p[i], fpos, local)
        for g in (table.ga, table.gb):
            w.exact.set_pose(g, T[w.dynamic_position[g]])
        true[i] = fcl.distance(w.geoms[table.ga].obj, w.geoms[table.gb].obj,
                               fcl.DistanceRequest(), fcl.DistanceResult())
    assert len(X) > 50 and (true >= bound - 1e-9).all(), (true - bound).min()


# ---------------------------------------------------------------------------------------------
# errors


def test_user_errors_have_codes(pr2, tmp_path):
    from tmpc.runtime.collision import CollisionWorld
    model, fk = pr2

    def code(fn):
        with pytest.raises(SceneError) as info:
            fn()
        d = info.value.diagnostics[0]
        assert d.hint
        return d.code

    bad = tmp_path / "bad.stl"
    bad.write_text("not a mesh")
    assert code(lambda: world(pr2, SceneObject("m", Pose(), True, Shape("mesh", mesh=bad)))) \
        == "E565"
    w = world(pr2, box("table", (2, 0, 0.3), (0.3, 0.3, 0.3)), _stick())
    moved = np.eye(4)
    moved[0, 3] = 5.0
    assert code(lambda: w.check(model.default_q, poses={"table": moved})) == "E566"
    assert code(lambda: w.check(model.default_q, attached={"table": (TOOL, np.eye(4))})) \
        == "E566"
    assert code(lambda: w.check(model.default_q, poses={"mug": np.eye(4)})) == "E567"
    assert code(lambda: w.check(model.default_q, attached={"stick": ("claw", np.eye(4))})) \
        == "E568"
    assert code(lambda: world(pr2, attach_allowed={TOOL: ["no_link"]})) == "E568"
    loop = [SceneObject("a", Pose(), True, Shape("sphere", radius=0.1), parent="b"),
            SceneObject("b", Pose(), True, Shape("sphere", radius=0.1), parent="a")]
    assert code(lambda: world(pr2, *loop)) == "E569"
    assert code(lambda: world(pr2, SceneObject("a", Pose(), True, Shape("sphere", radius=0.1),
                                               parent="nowhere"))) == "E569"
    srdf = tmp_path / "bad.srdf"
    srdf.write_text("<robot><disable_collisions")
    assert code(lambda: world(pr2, srdf=srdf)) == "E570"
    assert code(lambda: world(pr2, tolerance=-0.01)) == "E572"
    assert code(lambda: w.check(model.default_q[:-1])) == "E573"
    assert code(lambda: w.check_batch(np.full((2, model.dof), np.nan))) == "E573"
    assert w.check_batch(np.zeros((0, model.dof))).shape == (0,)
    assert code(lambda: w.check(model.default_q, poses={"stick": np.eye(3)})) == "E573"
    assert code(lambda: world(pr2, box("flat", (2, 0, 0), (0.3, 0.0, 0.3)))) == "E574"
    assert code(lambda: w.check_motion(model.default_q, model.default_q, resolution=0.0)) \
        == "E575"
    assert isinstance(CollisionWorld, type)


# ---------------------------------------------------------------------------------------------
# agreement with an independent implementation: pinocchio's geometry model + coal


def _pin_q(pin, pmodel, model, q):
    """Our configuration as pinocchio's q (continuous joints are (cos, sin) there)."""
    values = dict(zip(model.q_names, q))
    values.update(model.fixed)
    for j in model.tree.joints:
        if j.mimic is not None:
            values[j.name] = j.mimic.multiplier * values[j.mimic.joint] + j.mimic.offset
    pq = pin.neutral(pmodel)
    for jid in range(1, pmodel.njoints):
        jm, v = pmodel.joints[jid], values[pmodel.names[jid]]
        if jm.nq == 2:
            pq[jm.idx_q:jm.idx_q + 2] = (np.cos(v), np.sin(v))
        else:
            pq[jm.idx_q] = v
    return pq


AGREEMENT_SCENES = {
    "pr2": [box("shelf", (0.75, -0.1, 0.65), (0.15, 0.35, 0.08)),
            box("block", (0.35, -0.65, 1.0), (0.12, 0.12, 0.12), yaw=0.5)],
    "panda": [box("shelf", (0.5, 0.0, 0.3), (0.1, 0.25, 0.05)),
              box("block", (0.0, 0.45, 0.5), (0.08, 0.08, 0.08), yaw=0.3)],
}
BAND = 1e-4     # pairs within 1e-4 m of touching (by either implementation) are not compared


@pytest.mark.parametrize("name", ["pr2", "panda"])
def test_agrees_with_pinocchio_and_coal_on_random_states(name, request):
    """Every colliding pair (self-collision and robot vs box) of 2000 random states, ours
    (python-fcl) against pinocchio + coal; pairs we allow are not compared."""
    pin = pytest.importorskip("pinocchio")
    from tmpc.lang.world.robot import example_robot_data_dir
    model, fk = request.getfixturevalue(name)
    objs = AGREEMENT_SCENES[name]
    w = world((model, fk), *objs)
    path = model.tree.path
    pmodel = pin.buildModelFromUrdf(path)
    gmodel = pin.buildGeomFromUrdf(pmodel, path, pin.GeometryType.COLLISION,
                                   package_dirs=[str(example_robot_data_dir().parent)])
    owner = [pmodel.frames[o.parentFrame].name for o in gmodel.geometryObjects]
    import coal

    from tmpc.compiler.rotations import pose_matrix
    for o in objs:
        T = pose_matrix(o.pose)
        gmodel.addGeometryObject(pin.GeometryObject(o.name, 0, pin.SE3(T[:3, :3], T[:3, 3]),
                                                    coal.Box(*(2 * np.array(o.shape.size)))))
        owner.append(o.name)
    index = {**w.link_body, **{o.name: w.object_body(o.name, "") for o in objs}}
    n = len(owner)
    for i in range(n):
        for k in range(i + 1, n):
            a, b = index[owner[i]], index[owner[k]]
            if a != b and not w.allowed[a, b]:
                gmodel.addCollisionPair(pin.CollisionPair(i, k))
    assert len(gmodel.collisionPairs) > 15
    pdata, gdata = pmodel.createData(), pin.GeometryData(gmodel)
    by_key: dict[frozenset, list[int]] = {}
    for k, cp in enumerate(gmodel.collisionPairs):
        by_key.setdefault(frozenset((owner[cp.first], owner[cp.second])), []).append(k)
    rng = np.random.default_rng(5)
    agree = band = seen = boxes = 0
    outside = []
    for q in rng.uniform(model.lower, model.upper, (2000, model.dof)):
        ours = {frozenset((a, b)) for a, b, _ in w.check(q).pairs}
        pin.computeCollisions(pmodel, pdata, gmodel, gdata, _pin_q(pin, pmodel, model, q), False)
        theirs = {key for key, ks in by_key.items()
                  if any(gdata.collisionResults[k].isCollision() for k in ks)}
        seen += len(theirs)
        agree += len(theirs & ours)
        boxes += sum(1 for key in theirs & ours if key & {"shelf", "block"})
        for key in theirs ^ ours:
            if key in ours:     # coal said free: is it within BAND (coal with a margin)?
                near = False
                for k in by_key[key]:
                    gdata.collisionRequests[k].security_margin = BAND
                    near |= pin.computeCollision(gmodel, gdata, k)
                    gdata.collisionRequests[k].security_margin = 0.0
            else:               # we said free: is fcl's distance below BAND?
                a, b = (w.bodies[index[x]].geoms for x in key)
                near = min(fcl.distance(w.geoms[x].obj, w.geoms[y].obj, fcl.DistanceRequest(),
                                        fcl.DistanceResult()) for x in a for y in b) < BAND
            band += near
            if not near:
                outside.append((sorted(key), key in ours))
    print(f"\n{name}: 2000 states, {seen} colliding pairs (coal), {agree} agreed ({boxes} robot "
          f"vs box), {band} disagreements within {BAND} m of touching, {len(outside)} outside")
    assert outside == []
    assert agree > 500 and boxes > 100 and band <= 0.01 * agree


def test_many_motions_interpolate_as_one_at_a_time(pr2_mobile):
    """`interpolate_many` gives every motion's states exactly (bitwise) as `interpolate` does
    one motion at a time, the ends dropped on request, zero-length and wrapping motions and no
    motion at all included."""
    from tmpc.runtime.collision import CollisionWorld
    model, _ = pr2_mobile
    w = CollisionWorld(mobile_scene(model, four_tables()), model)
    rng = np.random.default_rng(7)
    for k in (0, 1, 5, 12):
        Q0 = rng.uniform(model.lower, model.upper, (k, model.dof))
        Q1 = Q0 + rng.normal(0.0, 1.0, Q0.shape) * rng.choice([0.001, 0.05, 1.0], (k, 1))
        Q1[:1] = Q0[:1]                                   # a motion of length 0
        for res, ends in ((0.02, True), (0.1, False), (0.007, False)):
            Q, lens = w.interpolate_many(Q0, Q1, res, ends)
            segs = [w.interpolate(a, b, res)[slice(None) if ends else slice(1, -1)]
                    for a, b in zip(Q0, Q1)]
            assert lens.tolist() == [len(s) for s in segs]
            want = np.concatenate(segs) if k else np.zeros((0, model.dof))
            assert Q.shape == want.shape and np.array_equal(Q, want)
    wrapping = np.nonzero(model.wraps)[0]
    assert len(wrapping)
    a, b = np.array(model.default_q, float), np.array(model.default_q, float)
    a[wrapping[0]], b[wrapping[0]] = 3.1, -3.1            # the short way: 0.083 rad, not 6.2
    Q, lens = w.interpolate_many(a[None], b[None], 0.02)
    assert lens.tolist() == [6] and np.abs(np.diff(Q[:, wrapping[0]])).max() < 0.02


def test_the_jit_answers_as_the_built_module_and_exact_fcl(pr2_mobile, monkeypatch):
    """With numba's JIT forced (what a machine runs when numba.pycc is gone or its build
    fails: :mod:`tmpc.runtime.collision.kernel`), batches, batched motions and a motion give
    the answers of the module built ahead of time and of exact fcl, state by state."""
    from tmpc.compiler import aot
    from tmpc.runtime.collision import CollisionWorld, kernel
    from tmpc.runtime.collision import pass_kernel as jit
    model, _ = pr2_mobile
    module, why = aot.obtain(kernel.PASS_KERNEL)
    assert module is not None, why
    objs = tables_and_sticks(3, 1.2)
    objs.append(box("held", (0.0, 0.0, 0.0), (0.02, 0.02, 0.15), True))
    sc = mobile_scene(model, objs)
    exact = CollisionWorld(sc, model, first_pass=False)
    A, B = random_motions(model, np.random.default_rng(11), 120, 0.3)
    Q = np.concatenate([A, B])
    held = {"held": (TOOL, np.eye(4))}
    segs = [exact.interpolate(a, b, 0.05) for a, b in zip(A[:40], B[:40])]
    group = (np.concatenate(segs), None, held, [len(s) for s in segs])
    truth = (exact.check_batch(Q, attached=held), exact.check_segments([group])[0],
             exact.check_motion(A[0], B[0], 0.05, details=False).t_first_collision)
    assert truth[0].any() and not truth[0].all()
    got = {}
    for how in ("built", "jit"):
        state = {"candidates": module.candidates, "kinematics": module.kinematics,
                 "table_free": module.table_free, "why": None}
        if how == "jit":
            state = {"candidates": jit.candidates, "kinematics": jit.kinematics,
                     "table_free": jit.table_free, "why": "test"}
        monkeypatch.setattr(kernel, "KERNEL_STATE", state)
        w = CollisionWorld(sc, model)
        got[how] = (w.check_batch(Q, attached=held), w.check_segments([group])[0],
                    w.check_motion(A[0], B[0], 0.05, details=False).t_first_collision)
        assert kernel.KERNEL_STATE["candidates"] is state["candidates"]
    for how in got:
        assert (got[how][0] == truth[0]).all() and (got[how][1] == truth[1]).all(), how
        assert got[how][2] == truth[2], how


LAGRIFFOUL = Path(__file__).resolve().parents[2] / "examples" / "lagriffoul" / "data"


def _hollow_meshes():
    """Sort Clutter's arena (a wall 0.4 m high around the floor), shrunk to a 2.5 m square,
    and one of its tables (a top on four legs) beside the origin."""
    arena = Shape("mesh", mesh=LAGRIFFOUL / "problem3/clutter_meshes/arena.obj",
                  scale=(0.45, 0.45, 1.0))
    table = Shape("mesh", mesh=LAGRIFFOUL / "problem3/clutter_meshes/table.obj")
    return [SceneObject("arena", Pose((0.0, 0.0, 0.2)), False, arena),
            SceneObject("table", Pose.from_xyz_yaw(0.0, 0.75, 0.0, 0.0), False, table)]


def test_a_hollow_mesh_is_cut_into_parts_that_hold_its_whole_surface():
    """mesh_parts: the arena and a table come out in parts whose triangles are the mesh's
    (the same area; every vertex in a part's box and hull), whose hulls hold a fraction of
    the mesh's hull; a solid mesh (a stick) has none."""
    from scipy.spatial import ConvexHull, Delaunay

    from tmpc.runtime.collision.geometry import load_mesh
    from tmpc.runtime.collision.spheres import mesh_parts
    for name, at_most in (("arena", 0.1), ("table", 0.2)):
        shape = Shape("mesh", mesh=LAGRIFFOUL / f"problem3/clutter_meshes/{name}.obj")
        mesh = load_mesh(shape.mesh)
        c, h, pts, start, r = mesh_parts(shape, mesh)
        assert 2 <= len(c) <= 64 and len(start) == len(c) + 1 and (r < 1e-6).all()
        hulls = [pts[start[i]:start[i + 1]] for i in range(len(c))]
        whole = ConvexHull(mesh.vertices).volume
        assert sum(ConvexHull(H).volume for H in hulls) < at_most * whole
        inside = np.zeros(len(mesh.vertices), bool)
        for ci, hi, H in zip(c, h, hulls):
            in_box = (np.abs(mesh.vertices - ci) <= hi + 1e-9).all(axis=1)
            inside |= in_box & (Delaunay(H).find_simplex(mesh.vertices, tol=1e-9) >= 0)
        assert inside.all()
        # every point of the surface: points drawn on the triangles lie in some part
        rng = np.random.default_rng(3)
        tri = mesh.vertices[mesh.faces]
        u = rng.dirichlet(np.ones(3), len(tri) * 20)
        P = np.einsum("nk,nkd->nd", u, np.repeat(tri, 20, axis=0))
        hit = np.zeros(len(P), bool)
        for ci, hi, H in zip(c, h, hulls):
            hit |= ((np.abs(P - ci) <= hi + 1e-9).all(axis=1)
                    & (Delaunay(H).find_simplex(P, tol=1e-9) >= 0))
        assert hit.all()
    stick = Shape("mesh", mesh=LAGRIFFOUL / "problem3/clutter_meshes/stick_red.obj")
    assert mesh_parts(stick, load_mesh(stick.mesh)) is None
    assert mesh_parts(Shape("box", size=(1, 1, 1)), None) is None


def test_first_pass_by_parts_of_hollow_meshes_equals_exact_fcl_with_fewer_candidates(
        pr2_mobile, monkeypatch):
    """A mobile PR2 inside an arena wall, beside a table (hollow meshes, seen by parts): the
    batched checks equal exact fcl on every random state and motion, every colliding pair is a
    candidate, and the pass leaves far fewer pairs than it did seeing each mesh whole."""
    from tmpc.runtime.collision import CollisionWorld, first_pass
    model, fk = pr2_mobile
    sc = mobile_scene(model, _hollow_meshes() + [box("stick", (0.0, 0.75, 0.93),
                                                     (0.02, 0.02, 0.15), True)])
    w, exact = CollisionWorld(sc, model), CollisionWorld(sc, model, first_pass=False)
    rng = np.random.default_rng(5)
    Q = random_states(model, rng, 2000)
    held = {"stick": (TOOL, np.eye(4))}
    for att in (None, held):
        batch, truth = w.check_batch(Q, attached=att), exact.check_batch(Q, attached=att)
        assert (batch == truth).all(), np.nonzero(batch != truth)
        assert 0.1 < (~truth).mean() < 0.9
    A, B = random_motions(model, rng, 60, 0.3)
    got = w.check_segments([(np.vstack([w.interpolate(a, b, 0.05) for a, b in zip(A, B)]),
                             None, None, np.array([len(w.interpolate(a, b, 0.05))
                                                   for a, b in zip(A, B)]))])[0]
    want = [exact.check_batch(w.interpolate(a, b, 0.05)).all() for a, b in zip(A, B)]
    assert (got == np.array(want)).all() and got.any() and not got.all()
    fp = w.first_pass()
    place, allowed = w.placements(attached=held)
    plan = fp.plan(place, allowed)
    assert plan.split and len(plan.box_geom) > len(set(plan.box_geom.tolist())) + 20
    cand = fp.candidates(Q[:500], plan)
    body = lambda g: w.bodies[w.geoms[g].body].name
    keys = list(zip(cand.states.tolist(), cand.ga.tolist(), cand.gb.tolist()))
    assert len(keys) == len(set(keys))                    # a pair two parts left: once
    pairs = {(s, frozenset((body(a), body(b)))) for s, a, b in keys}
    missing = [(i, a, b) for i in range(500) for a, b, _ in w.check(Q[i], attached=held).pairs
               if (i, frozenset((a, b))) not in pairs and "stick" not in (a, b)]
    assert missing == []
    monkeypatch.setattr(first_pass, "mesh_parts", lambda *a: None)
    whole = CollisionWorld(sc, model).first_pass()
    plan = whole.plan(place, allowed)
    assert not plan.split
    assert len(cand.states) < 0.5 * len(whole.candidates(Q[:500], plan).states)
