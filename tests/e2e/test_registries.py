"""Every registry entry is exercised: each planner of ``PLANNERS`` plans the bundled tabletop task
and the independent validator accepts its plan; each scene loader of ``SCENE_LOADERS`` reads a
fixture of its format. Adding an entry without a fixture here fails."""

from __future__ import annotations

import json

import pytest

from tests.support import FIXTURES, TABLETOP
from tmpc.lang.source import SourceFile
from tmpc.lang.world import load_scene
from tmpc.lang.world.loaders import SCENE_LOADERS
from tmpc.runtime.planners import PLANNERS

SCENES = FIXTURES / "scenes"
#: one fixture per scene format, with an object it must contain
SCENE_FIXTURES = {
    "tmpc-json": (SCENES / "native" / "scene.json", "crate"),
    "tmit-star-json": (SCENES / "tmit" / "problems" / "demo" / "scenes" / "demo_scene.json", None),
    "planet-xml": (SCENES / "planet" / "demo" / "demo.xml", None),
}


def test_every_planner_and_scene_format_has_a_case():
    assert set(SCENE_FIXTURES) == set(SCENE_LOADERS)
    assert PLANNERS, "no planner registered"


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_planner_plans_tabletop_and_the_plan_validates(name, tabletop_world):
    from tmpc.runtime.plans import parse_plan, plan_document
    from tmpc.runtime.solve import plan_problem
    from tmpc.runtime.validate import validate_plan
    world = tabletop_world
    # anytime planners stop at their first plan here (the others ignore the option)
    problem, result, _ = plan_problem(world, name, seed=0, time_limit=60.0,
                                      overrides={"first_solution": True})
    assert result.status == "solved", (name, result.status)
    doc = plan_document(problem, result, planner=name, seed=0, input_path=str(TABLETOP),
                        setup_seconds=0.0)
    assert len(doc["actions"]) == 4          # two picks and two places, no detours
    plan = parse_plan(SourceFile("<plan>", json.dumps(doc)))
    report = validate_plan(world, plan)
    assert report.valid, report.text()


@pytest.mark.parametrize("fmt", sorted(SCENE_LOADERS))
def test_scene_loader_reads_its_format(fmt):
    path, obj = SCENE_FIXTURES[fmt]
    scene = load_scene(path)
    assert scene.format == fmt
    assert load_scene(path, fmt=fmt).format == fmt
    assert scene.objects, f"{path} has no objects"
    if obj is not None:
        assert scene.object(obj).movable
