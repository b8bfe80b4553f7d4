"""``World.plan()`` without a planner or a time limit takes the manifest's ``[planner]`` name
and time limit, as ``tmpc run`` does."""

from __future__ import annotations

import tmpc
import tmpc.runtime.api.world as api_world
from tests.support import TABLETOP


def test_plan_takes_the_manifests_planner_and_time_limit(tmp_path, monkeypatch):
    here = TABLETOP.parent
    manifest = tmp_path / "run.toml"
    manifest.write_text(
        "[problem]\n"
        f'domain = "{here / "domain.pddl"}"\n'
        f'problem = "{here / "problem.pddl"}"\n'
        f'scene = "{here / "scene.json"}"\n'
        "[planner]\n"
        'name = "decoupled"\n'
        "time_limit = 45\n")
    limits = []
    real = api_world.plan_problem

    def spy(world, planner, seed, time_limit, *args, **kwargs):
        limits.append((planner, time_limit))
        return real(world, planner, seed, time_limit, *args, **kwargs)

    monkeypatch.setattr(api_world, "plan_problem", spy)
    world = tmpc.load(manifest)
    plan = world.plan(seed=0)
    assert plan.solved and plan.document["planner"] == "decoupled"
    assert limits == [("decoupled", 45)]
    assert world.validate(plan).valid
