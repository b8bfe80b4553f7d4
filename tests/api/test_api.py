"""The Python API through its public names only (``import tmpc``): one test per public function,
against independent references (the validator, the scene's start, the CLI's outputs)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import tmpc
from tests.support import TABLETOP


@pytest.fixture(scope="module")
def world():
    return tmpc.load(TABLETOP)


@pytest.fixture(scope="module")
def plan(world):
    return world.plan(seed=0, time_limit=60.0, first_solution=True)


def test_import_tmpc_is_light():
    code = ("import sys, time; t = time.perf_counter(); import tmpc; "
            "print(time.perf_counter() - t, 'numpy' in sys.modules, 'jax' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[1:] == ["False", "False"]
    assert float(out[0]) < 0.5          # ~5 ms; generous on a loaded machine
    assert set(tmpc.__all__) <= set(dir(tmpc))
    with pytest.raises(AttributeError):
        tmpc.no_such_name  # noqa: B018


def test_load_and_plan(world, plan):
    assert isinstance(world, tmpc.World) and isinstance(plan, tmpc.Plan)
    assert plan.solved and plan.explanation is None
    assert len(plan.actions) == 4 and plan.actions[0].startswith("(pick")
    assert plan.states[0]["action"] is None and plan.cost > 0
    assert plan.stats["plan_seconds"] > 0
    assert json.loads(plan.to_json())["actions"] == plan.actions


def test_validate_is_the_independent_validator(world, plan):
    assert world.validate(plan).valid
    doc = json.loads(plan.to_json())
    doc["states"][1]["joints"]["panda_joint1"] = 9.0        # out of its limits
    report = world.validate(doc)
    assert not report.valid and report.violations


def test_write_and_view(world, plan, tmp_path):
    plan.write(tmp_path / "plan.json")
    assert json.loads((tmp_path / "plan.json").read_text()) == json.loads(plan.to_json())
    assert world.validate(tmp_path / "plan.json").valid
    world.view(plan, html=tmp_path / "p.html", png=tmp_path / "p.png")
    assert (tmp_path / "p.html").read_text().startswith("<!")
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"


def test_plan_again_from_the_start_is_the_same_plan(world, plan):
    again = world.plan(seed=0, time_limit=60.0, first_solution=True)
    assert again.states == plan.states
    assert world.last_overhead < 0.5     # nothing loaded again (~10 ms)


def test_plan_from_a_plan_state(world, plan):
    k = next(i for i, s in enumerate(plan.states) if s["mode"]["held"])   # holding a cube
    start = plan.states[k]
    again = world.plan(seed=1, time_limit=60.0, first_solution=True, start=start)
    assert again.solved
    assert again.states[0]["joints"] == pytest.approx(start["joints"])
    assert again.states[0]["mode"] == start["mode"]
    assert again.actions[0].startswith("(place")       # it holds a cube: it places it first
    assert len(again.actions) == len(plan.actions) - 1
    assert world.last_overhead < 0.5


def test_no_plan_has_an_explanation(world):
    got = world.plan(planner="unified", seed=0, time_limit=1e-3)
    assert not got.solved and got.cost is None
    why = got.explanation
    assert why is not None and why["status"] == got.status and "culprits" in why
    json.dumps(why)


def test_state_evaluate_and_sample(world):
    start = world.state()
    assert start["mode"]["held"] == {} and "(free panda_hand_tcp)" in start["mode"]["atoms"]
    name = next(iter(start["joints"]))
    moved = dict(start, joints={**start["joints"], name: start["joints"][name] + 0.1})
    assert world.state(moved)["joints"][name] == pytest.approx(start["joints"][name] + 0.1)
    states = world.sample("reach", ["panda_hand_tcp", "red_cube"], n=2, seed=0)
    assert len(states) == 2
    for s in states:
        got = world.evaluate("reach", ["panda_hand_tcp", "red_cube"], s)
        assert got["value"] is True and got["distance"] < 1e-3
    far = world.evaluate("reach", ["panda_hand_tcp", "red_cube"])
    assert far["value"] is False and far["distance"] > 0


def test_check_gives_diagnostics(tmp_path):
    assert tmpc.check([TABLETOP]) == []
    bad = tmp_path / "d.pddl"
    bad.write_text("(define (domain d) (:action a :parameters (?x) :effect (nope ?x)))")
    diags = tmpc.check(bad)
    assert diags and all(isinstance(d, tmpc.Diagnostic) for d in diags)
    assert any(d.code.startswith("E") for d in diags)


def test_compile_writes_an_artifact_that_loads(tmp_path, world):
    out = tmpc.compile(TABLETOP, tmp_path / "t.tmpa")
    assert out.is_file()
    again = tmpc.load(out)
    assert again.state()["joints"] == world.state()["joints"]
    assert world.compile() is None
