"""The generated example worlds load through the scene loader and start valid."""

from __future__ import annotations

import json

import pytest

from tests.support import EXAMPLES, check
from tmpc.compiler.compile import compile_world
from tmpc.lang.world.generate import clutter_problem, clutter_scene, tabletop_scene
from tmpc.runtime.collision import collision_world


@pytest.mark.parametrize("n, red", [(1, False), (8, False), (8, True), (14, True)])
def test_clutter_scene_loads_checks_and_starts_collision_free(tmp_path, n, red):
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.state import initial_state
    scene_file = tmp_path / "scene.json"
    scene_file.write_text(json.dumps(clutter_scene(n, red)))
    world = open_world(scene_file)
    names = {o.name for o in world.scene.objects}
    assert len(names) == 4 + n + (14 if red else 0)
    domain = (EXAMPLES / "clutter" / "domain.pddl").read_text()
    report = check(domain + clutter_problem(n, red))
    assert report.ok, report.diagnostics
    objects = {o.name.key for o in report.programs[0].problem.objects}
    assert objects - {"l_gripper_tool_frame", "r_gripper_tool_frame"} == \
        {x.lower() for x in names}
    st = initial_state(world.scene, compile_world(world).model)
    rep = collision_world(world, compile_world(world)).check(st.q, poses=st.poses)
    assert rep.valid, rep.pairs


def test_bundled_examples_match_their_generators():
    assert json.loads((EXAMPLES / "clutter" / "scene.json").read_text()) == clutter_scene(1)
    assert (EXAMPLES / "clutter" / "problem.pddl").read_text() == clutter_problem(1)
    assert json.loads((EXAMPLES / "tabletop" / "scene.json").read_text()) == tabletop_scene()


def test_tabletop_starts_valid_with_the_hand_over_the_bench(tabletop_world):
    from tmpc.compiler.state import initial_state
    world = tabletop_world
    st = initial_state(world.scene, compile_world(world).model)
    assert collision_world(world, compile_world(world)).check(st.q, poses=st.poses).valid
    tcp = compile_world(world).fk(st.q).p[compile_world(world).model.frame("panda_hand_tcp")]
    assert 0.5 < float(tcp[2]) < 0.7


def test_urdf_library_warnings_are_quiet():
    """yourdfpy warned once per mimic joint and state (2,676 lines for one validate of a
    tmit-star shelves plan); tmpc's own diagnostics say what matters."""
    import logging

    from tmpc.lang.world import import_yourdfpy
    import_yourdfpy()
    for name in ("yourdfpy.urdf", "trimesh"):
        assert logging.getLogger(name).getEffectiveLevel() >= logging.ERROR
