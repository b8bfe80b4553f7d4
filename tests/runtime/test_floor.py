"""A mobile base's reachable floor (runtime/collision/floor.py): Sort Clutter's arena wall
encloses it; a wall with a gap does not, nor does a fixed base's world.

The reference is the robot itself: base positions where the whole robot stands free inside the
wall must lie on the floor, and the free positions outside the wall (where an arm reaches a
table over it) must not."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from tests.support import ROOT
from tmpc.compiler.robot import robot_model
from tmpc.lang.inputs import load_world
from tmpc.runtime.collision import CollisionWorld, floor_bounds
from tmpc.runtime.problem import PlanningProblem

CLUTTER = ROOT / "examples/lagriffoul/clutter/run.toml"
WALL = 2.725                     # the arena's inner face (clutter_meshes/arena.obj)


@pytest.fixture(scope="module")
def clutter():
    world = load_world(CLUTTER)
    model = robot_model(world.scene, strict_meshes=True)
    return world, model, CollisionWorld(world.scene, model, allowed=world.allowed_pairs())


def test_the_arena_wall_bounds_the_floor_and_every_free_base_inside_is_on_it(clutter):
    _, model, cw = clutter
    assert abs(model.lower[0]) > 4 and abs(model.upper[1]) > 4      # W505's bounds: 2 m out
    floor = floor_bounds(cw, model.default_q, model.lower, model.upper)
    assert floor is not None
    xlo, xhi, ylo, yhi = floor
    assert -WALL < xlo < -2.2 and 2.2 < xhi < WALL and -WALL < ylo < -2.2 and 2.2 < yhi < WALL
    rng = np.random.default_rng(0)
    inside = outside = 0
    for _ in range(1500):
        q = model.default_q.copy()
        q[:3] = rng.uniform([-4.3, -4.2, -np.pi], [4.3, 4.2, np.pi])
        if not cw.check(q).valid:
            continue
        if max(abs(q[0]), abs(q[1])) < WALL:
            inside += 1
            assert xlo <= q[0] <= xhi and ylo <= q[1] <= yhi, q[:3]
        elif max(abs(q[0]), abs(q[1])) > WALL + 0.025:
            outside += 1
            assert not (xlo <= q[0] <= xhi and ylo <= q[1] <= yhi), q[:3]
    assert inside > 50 and outside > 50
    # a base on the far side of a table, its arm over the wall: free, and not on the floor
    q = model.default_q.copy()
    q[:3] = (-3.3, 0.0, 0.0)
    assert cw.check(q).valid and not xlo <= q[0]


def test_a_gap_in_the_wall_leaves_the_bounds_as_they_are(clutter):
    """The same scene with the base's floor cut by no wall: bounds inside the arena's ring
    (the start's cell then reaches their edge) are not narrowed."""
    _, model, cw = clutter
    lower, upper = model.lower.copy(), model.upper.copy()
    lower[:2], upper[:2] = -2.3, 2.3
    assert floor_bounds(cw, model.default_q, lower, upper) is None


def test_a_start_on_the_wall_or_a_fixed_base_is_not_narrowed(clutter):
    _, model, cw = clutter
    q = model.default_q.copy()
    q[:2] = (WALL + 0.0125, 0.0)                 # in the wall: the start's cell is blocked
    assert floor_bounds(cw, q, model.lower, model.upper) is None
    stub = SimpleNamespace(model=SimpleNamespace(mobile_base=False, lower=model.lower,
                                                 upper=model.upper),
                           collision=cw, q0=model.default_q, floor_map=None)
    PlanningProblem.narrow_to_floor(stub)
    assert stub.floor is None and np.array_equal(stub.lower, model.lower)


def test_the_problem_narrows_the_base_bounds_and_only_them(clutter):
    _, model, cw = clutter
    stub = SimpleNamespace(model=model, collision=cw, q0=model.default_q, floor_map=None)
    PlanningProblem.narrow_to_floor(stub)
    assert stub.floor == (stub.lower[0], stub.upper[0], stub.lower[1], stub.upper[1])
    assert stub.upper[0] - stub.lower[0] < 5.5 < model.upper[0] - model.lower[0]
    assert np.array_equal(stub.lower[2:], model.lower[2:])
    assert np.array_equal(stub.upper[2:], model.upper[2:])
    q0 = model.default_q[:2]
    assert np.all(stub.lower[:2] <= q0) and np.all(q0 <= stub.upper[:2])


def test_the_inscribed_radius_is_qhulls():
    """The footprint's circle about the base's origin (a hull by monotone chain, no scipy at
    set-up) against scipy's qhull on random point sets; 0 where the origin is outside."""
    from scipy.spatial import ConvexHull

    from tmpc.runtime.collision.floor import inscribed_radius
    rng = np.random.default_rng(0)
    for _ in range(200):
        P = rng.normal(size=(int(rng.integers(3, 60)), 2)) + rng.normal(scale=0.5, size=2)
        want = max(0.0, float((-ConvexHull(P).equations[:, -1]).min()))
        assert inscribed_radius(P) == pytest.approx(want, abs=1e-9)
    square = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [0, 0.5]], float)
    assert inscribed_radius(square) == 1.0 and inscribed_radius(square + 3) == 0.0
    assert inscribed_radius(np.array([[0, 0], [1, 1], [2, 2]], float)) == 0.0
