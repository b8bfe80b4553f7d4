"""`tmpc simulate` (MuJoCo, headless): a good tabletop plan settles and keeps its goal; the same
plan with its releases lifted 5 cm is caught by --strict."""

from __future__ import annotations

import json

import pytest

from tests.support import TABLETOP

pytest.importorskip("mujoco")


@pytest.fixture(scope="module")
def timed_plan(tabletop_world, tmp_path_factory):
    from tmpc.runtime.plans import plan_document
    from tmpc.runtime.solve import plan_problem
    from tmpc.runtime.timing import time_world_plan
    problem, result, _ = plan_problem(tabletop_world, "unified", seed=0, time_limit=60.0)
    assert result.status == "solved"
    doc = plan_document(problem, result, planner="unified", seed=0, input_path=str(TABLETOP),
                        setup_seconds=0.0)
    time_world_plan(tabletop_world, doc)
    return doc


def test_a_good_plan_settles(tabletop_world, timed_plan):
    from tmpc.runtime.simulate import simulate
    report = simulate(tabletop_world, timed_plan)
    assert set(report.drift) == {"red_cube", "blue_cube"}
    assert max(report.drift.values()) < 0.01, report.text()
    assert report.goal_holds, report.text()
    assert report.ok()


def test_a_release_lifted_5_cm_is_caught(tabletop_world, timed_plan, tmp_path):
    from tmpc.runtime.cli.main import main
    doc = json.loads(json.dumps(timed_plan))
    for s in doc["states"]:                      # every held object carried 5 cm higher
        for obj in (s["mode"]["held"] or {}):
            s["object_poses"][obj]["translation"][2] += 0.05
    plan = tmp_path / "lifted.json"
    plan.write_text(json.dumps(doc))
    assert main(["simulate", str(TABLETOP), str(plan), "--strict", "--json"]) == 1
    good = tmp_path / "good.json"
    good.write_text(json.dumps(timed_plan))
    assert main(["simulate", str(TABLETOP), str(good), "--strict"]) == 0
