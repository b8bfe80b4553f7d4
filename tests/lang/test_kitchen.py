"""The kitchen (problem 5) reconstructed in the suite's XML + PDDL form: its files read and
check, every object rests on what carries it and touches nothing at the start, the non-geometric
actions order the task (clean before cook), and (slow) the PR2's right arm reaches every object
and every place with a horizontal side grasp from a base pose clear of the furniture."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from tests.support import EXAMPLES
from tmpc.lang.program import check_paths
from tmpc.lang.world import load_scene
from tmpc.lang.world.loaders import matrix_from_quat

P5 = EXAMPLES / "lagriffoul" / "data" / "problem5"
SCENES = [P5 / "kitchen.xml", P5 / "kitchen_noradish.xml"]


def world_point(obj, local) -> np.ndarray:
    R = np.array(matrix_from_quat(obj.pose.rotation))
    return R @ np.asarray(local) + np.asarray(obj.pose.translation)


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_every_object_rests_on_its_support(path):
    s = load_scene(path)
    by = {o.name: o for o in s.objects}
    carried = {c for o in s.objects for c in o.attachments}
    # every movable object and every place/spot is carried by something
    assert {o.name for o in s.objects if o.movable} <= carried
    for parent in s.objects:
        for c in parent.attachments:
            child = by[c]
            b = parent.support
            R = np.array(matrix_from_quat(parent.pose.rotation))
            local = R.T @ (np.asarray(child.pose.translation) - parent.pose.translation)
            assert all(b.lower[i] - 1e-9 <= local[i] <= b.upper[i] + 1e-9 for i in range(2)), \
                (parent.name, c, local)
            assert 0 <= local[2] - b.lower[2] <= 0.002, (parent.name, c, local[2] - b.lower[2])


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_nothing_touches_at_the_start(path):
    """A movable object against any other object, on the meshes' convex hulls (what tmpc's
    exact check uses); the places and spots too (the parts of the shelf touch each other)."""
    import fcl
    import trimesh
    s = load_scene(path)
    objs = {}
    for o in s.objects:
        m = trimesh.load(o.shape.mesh, force="mesh").convex_hull
        geom = fcl.Convex(m.vertices, len(m.faces),
                          np.hstack([np.full((len(m.faces), 1), 3), m.faces]).ravel())
        tf = fcl.Transform(np.array(matrix_from_quat(o.pose.rotation)), o.pose.translation)
        objs[o.name] = fcl.CollisionObject(geom, tf)
    loose = {o.name for o in s.objects if o.movable or "place" in o.name or "spot" in o.name}
    for a, b in itertools.combinations(objs, 2):
        if not {a, b} & loose:
            continue
        res = fcl.DistanceResult()
        d = fcl.distance(objs[a], objs[b], fcl.DistanceRequest(), res)
        assert d > 0, (a, b, d)


def test_the_task_needs_clean_before_cook():
    dom = P5 / "kitchen.pddl"
    rep = check_paths([dom, P5 / "kitchen_pb.pddl", P5 / "kitchen_noradish_pb.pddl"])
    assert rep.ok and not rep.diagnostics
    text = dom.read_text()
    cook = text[text.index("(:action cook"):]
    assert "(on-surface ?x stove)" in cook and "(clean ?x)" in cook
    clean = text[text.index("(:action clean"):text.index("(:action cook")]
    assert "(on-surface ?x dishwasher)" in clean
    # the radishes' goal is their start
    pb = (P5 / "kitchen_pb.pddl").read_text()
    goal = pb[pb.index(":goal"):]
    for r in ("radish1", "radish2"):
        fact = f"(on-surface {r} radish_spot{r[-1]})"
        assert fact in goal and fact in pb[:pb.index(":goal")]


def test_the_meshes_are_what_the_script_writes(tmp_path, monkeypatch):
    import importlib.util
    spec = importlib.util.spec_from_file_location("make_meshes", P5 / "make_meshes.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    monkeypatch.setattr(mod, "OUT", tmp_path)
    mod.main()
    written = sorted(p.name for p in tmp_path.glob("*.obj"))
    assert written == sorted(p.name for p in (P5 / "kitchen_meshes").glob("*.obj"))
    for name in written:
        assert (tmp_path / name).read_text() == (P5 / "kitchen_meshes" / name).read_text()


@pytest.mark.slow
@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_the_right_arm_reaches_everything(path):
    import trimesh

    from tests.lang.reach import Arm, footprint, reach_from_a_side
    s = load_scene(path)
    furniture = {o.name: o for o in s.objects if not o.movable and o.support is not None
                 and o.support.lower[0] < o.support.upper[0]}
    parent = {c: o.name for o in s.objects for c in o.attachments}

    def furniture_of(n: str) -> str:
        while n not in furniture:
            n = parent[n]
        return n

    points = []
    for o in s.objects:
        if o.movable:
            points.append((o.name, o.pose.translation[2] + o.grasps[0].template.translation[2],
                           o))
        elif o.support is not None:     # the corners of a region, a point place
            b = o.support
            for cx, cy in itertools.product({b.lower[0], b.upper[0]}, {b.lower[1], b.upper[1]}):
                p = world_point(o, (cx, cy, b.lower[2] + 0.001 + 0.08))
                points.append((f"{o.name} ({cx}, {cy})", p, o))
    sides = [0.0, math.pi, math.pi / 2, -math.pi / 2]
    arm = Arm(s, "r_gripper_tool_frame")
    for name, p, o in points:
        if not isinstance(p, np.ndarray):
            p = np.array([o.pose.translation[0], o.pose.translation[1], p])
        f = furniture[furniture_of(o.name)]
        box = footprint(trimesh.load(f.shape.mesh, force="mesh").bounds, f.pose)
        c = f.pose.translation
        toward = min(sides, key=lambda a: abs(math.remainder(a - math.atan2(c[1], c[0]),
                                                             2 * math.pi)))
        # the shelf only from its open side; the rest from any side
        facings = [toward] if f.name == "shelf" else [toward] + [a for a in sides if a != toward]
        assert reach_from_a_side(arm, p, box, facings) is not None, name
