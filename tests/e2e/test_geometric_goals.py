"""A goal written with geometric predicates over movable objects plans (issue S): the tower of
examples/tower, ``(and (on c b) (on b a) (on a bench))`` with ``on`` a ``:semantics`` predicate,
plans with every planner and the independent validator accepts the plan; the rewrite behind it
(:mod:`tmpc.compiler.ground.symbols`) adds what it says and nothing when no goal atom needs it."""

from __future__ import annotations

import json

import pytest

from tests.support import EXAMPLES, TABLETOP
from tmpc.compiler.ground import SYMBOL, is_symbol, with_geometric_symbols
from tmpc.lang.source import SourceFile
from tmpc.runtime.planners import PLANNERS

TOWER = EXAMPLES / "tower" / "tower.toml"


@pytest.fixture(scope="module")
def tower_world():
    from tmpc.compiler.artifact import open_world
    return open_world(TOWER)


def test_goal_atoms_over_movable_objects_become_symbols(tower_world):
    from tmpc.runtime.problem import PlanningProblem
    gp = PlanningProblem(tower_world).ground         # the symbols that hold at the start set
    symbols = {gp.atom_name(i) for i, a in enumerate(gp.atoms) if is_symbol(a.predicate)}
    assert {f"(on{SYMBOL} c b)", f"(on{SYMBOL} b a)", f"(on{SYMBOL} a bench)"} <= symbols
    # a rests on the bench in the scene: its symbol holds at the start, the others do not
    init = set(gp.state_atoms(gp.init))
    assert f"(on{SYMBOL} a bench)" in init
    assert f"(on{SYMBOL} c b)" not in init and f"(on{SYMBOL} b a)" not in init
    # the goal needs the symbols; only releases achieve them, and show as the release
    goal_ids = set(gp.goal.pos)
    assert {gp.atom_id(f"on{SYMBOL}", "c", "b"), gp.atom_id(f"on{SYMBOL}", "b", "a")} <= goal_ids
    achievers = [a for a in gp.actions if a.add_mask >> gp.atom_id(f"on{SYMBOL}", "c", "b") & 1]
    # `place` requires (on ?c ?s) of the cube it releases: placing c on b achieves it
    assert [a.name for a in achievers] == ["(place panda_hand_tcp c b)"]
    assert any(g.predicate == "on" and g.args == ("c", "b") for g in achievers[0].pre_geometric)
    # a grasp of b forgets every symbol that names b
    pick_b = gp.find_action("pick", "panda_hand_tcp", "b")
    assert gp.atom_id(f"on{SYMBOL}", "c", "b") in pick_b.dels
    assert gp.atom_id(f"on{SYMBOL}", "b", "a") in pick_b.dels


BARE_PLACE = """  (:action place
    :parameters (?g - gripper ?c - cube)
    :precondition (holding ?g ?c)
    :effect (and (free ?g) (not (holding ?g ?c)))))"""


@pytest.fixture(scope="module")
def bare_tower(tmp_path_factory):
    """The tower with a `place` that names no surface: its releases get variants."""
    import re
    import shutil
    from tmpc.compiler.artifact import open_world
    d = tmp_path_factory.mktemp("bare") / "tower"
    shutil.copytree(EXAMPLES / "tower", d)
    dom = d / "domain.pddl"
    text = dom.read_text()
    text = re.sub(r"  ; put the cube down.*", BARE_PLACE, text, flags=re.S)
    dom.write_text(text)
    return open_world(d / "tower.toml")


def test_a_release_without_the_predicate_gets_variants(bare_tower):
    from tmpc.compiler.compile import compile_world
    gp = compile_world(bare_tower).ground
    achievers = [a for a in gp.actions if a.add_mask >> gp.atom_id(f"on{SYMBOL}", "c", "b") & 1]
    # releasing c onto b, or b under c: either release can make the relation hold; each is
    # a variant with (on c b) in its precondition, shown as the release it was made from
    assert {a.name for a in achievers} == {"(place panda_hand_tcp c)", "(place panda_hand_tcp b)"}
    assert all(a.shown is not None and "~" in a.schema for a in achievers)
    assert all(any(g.predicate == "on" and g.args == ("c", "b") for g in a.pre_geometric)
               for a in achievers)


def test_variants_plan_and_validate(bare_tower):
    _plan_and_validate(bare_tower, "optimal")


def test_no_symbols_without_a_geometric_goal(tabletop_world):
    program = tabletop_world.program
    movable = {o.name.lower() for o in tabletop_world.scene.objects if o.movable}
    assert with_geometric_symbols(program, movable, {"panda_hand_tcp"}) is program


def test_atoms_naming_a_robot_frame_are_left_to_the_goal_projection(tower_world):
    program = tower_world.program
    # with every object taken as a robot frame, no goal atom qualifies
    frames = set(program.scope.objects)
    assert with_geometric_symbols(program, {"a", "b", "c"}, frames) is program


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_tower_with_a_geometric_goal_plans_and_validates(name, tower_world):
    _plan_and_validate(tower_world, name)


def _plan_and_validate(world, name):
    tower_world = world
    from tmpc.runtime.plans import parse_plan, plan_document
    from tmpc.runtime.solve import plan_problem
    from tmpc.runtime.validate import validate_plan
    problem, result, _ = plan_problem(tower_world, name, seed=0, time_limit=120.0,
                                      overrides={"first_solution": True})
    assert result.status == "solved", (name, result.status)
    doc = plan_document(problem, result, planner=name, seed=0, input_path=str(TOWER),
                        setup_seconds=0.0)
    # only the action names of the domain, with their own arguments
    arity = {k: len(a.params) for k, a in world.program.scope.actions.items()}
    assert all(len(a.split()) - 1 == arity[a.split()[0][1:]] for a in doc["actions"]), \
        doc["actions"]
    # no symbol leaks into the plan's states
    assert not any(SYMBOL in atom for s in doc["states"] for atom in s["mode"]["atoms"])
    plan = parse_plan(SourceFile("<plan>", json.dumps(doc)))
    report = validate_plan(tower_world, plan)
    assert report.valid, report.text()
    # the validator decides the geometric goal itself: the plan without its last two actions
    # (c not yet on b) is rejected for the goal
    acting = [i for i, st in enumerate(doc["states"]) if st["action"] is not None]
    cut = dict(doc, actions=doc["actions"][:-2],
               states=[dict(st) for st in doc["states"][:acting[-2] + 1]])
    cut["states"][-1]["action"] = None
    bad = validate_plan(tower_world, parse_plan(SourceFile("<cut>", json.dumps(cut))))
    assert not bad.valid and "goal" in bad.text(), bad.text()


def test_tabletop_is_unchanged_by_the_rewrite(tabletop_world):
    from tmpc.compiler.compile import compile_world
    gp = compile_world(tabletop_world).ground
    assert not any(is_symbol(a.predicate) for a in gp.atoms)
    assert all(a.shown is None for a in gp.actions)
    assert TABLETOP.exists()
