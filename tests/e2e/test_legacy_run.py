"""The bundled legacy planet example (examples/planet-sort: planet's run TOML, params TOML,
Lagriffoul XML scene, Lua predicates, glued-dash PDDL with `:kinematic`) runs unchanged through
`tmpc run`, and its plan passes the independent checker of `tmpc validate`.

One world is compiled for the whole module (JAX compile time dominates)."""

from __future__ import annotations

import json

import pytest

from tests.support import EXAMPLES

SORT = EXAMPLES / "planet-sort" / "sort.toml"


@pytest.fixture(scope="module")
def solved():
    from tmpc.runtime.plans import plan_document
    from tmpc.runtime.solve import plan_problem
    problem, result, setup = plan_problem(SORT, seed=1, time_limit=60.0)
    doc = plan_document(problem, result, planner="unified", seed=1, input_path=str(SORT),
                        setup_seconds=setup)
    return problem, result, doc


def test_example_is_a_planet_run_config():
    from tmpc.lang.lua import load_lua_predicates
    from tmpc.lang.world import load_config
    cfg = load_config(SORT)
    assert cfg.format == "planet-toml"
    assert cfg.scene.suffix == ".xml" and cfg.semantics.suffix == ".lua"
    assert dict(cfg.params)["coin_bias"] == 0.4
    module = load_lua_predicates(cfg.semantics)
    assert module.dialect == "planet"


def test_lua_predicates_are_traced_not_evaluated_directly():
    from tmpc.compiler.lua_trace import trace_module
    from tmpc.lang.lua import load_lua_predicates
    from tmpc.lang.program import check_paths
    from tmpc.lang.world import load_config
    cfg = load_config(SORT)
    checked = check_paths([cfg.domain, cfg.problem])
    assert checked.ok, checked.diagnostics
    domain = checked.programs[0].domain
    external = {p.name.text: p for p in domain.predicates if p.external}
    assert set(external) == {"at", "above"}
    result = trace_module(load_lua_predicates(cfg.semantics), external)
    assert set(result.traced) == {"at", "above"}
    assert not result.fallbacks and not result.diagnostics
    assert result.arg_kinds["above"][1] == "surface"


def test_run_solves_the_planet_example(solved):
    _, result, doc = solved
    assert result.status == "solved", doc["stats"]
    assert doc["status"] == "solved"
    # the red block goes to tableb, the green one to tablec, one gripper: 4 actions at least
    actions = doc["actions"]
    assert len(actions) >= 4
    assert "(putdown redblock tableb panda_hand_tcp)" in actions
    assert "(putdown greenblock tablec panda_hand_tcp)" in actions
    last = doc["states"][-1]
    assert {"(on-surface redblock tableb)", "(on-surface greenblock tablec)"} \
        <= set(last["mode"]["atoms"])
    assert last["mode"]["held"] == {}
    # each block released over its table: above the top (0.4 m), at most a few cm high
    for block, table in (("redblock", "tableb"), ("greenblock", "tablec")):
        x, y, z = last["object_poses"][block]["translation"]
        tx, ty, _ = last["object_poses"][table]["translation"]
        assert abs(x - tx) < 0.15 and abs(y - ty) < 0.15
        assert 0.4 < z < 0.47
    assert doc["stats"]["seconds"] < 30


def test_plan_of_the_planet_example_validates(solved, tmp_path):
    from tmpc.runtime.validate import validate_plan
    problem, _, doc = solved
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(doc))
    report = validate_plan(problem.world, str(path))
    assert report.valid, report.text()
    assert report.actions == len(doc["actions"])


def test_planet_legacy_output_validates(solved, tmp_path):
    """planet's bare state array (`--legacy-output planet`) is checked too, modes reconstructed."""
    from tmpc.runtime.plans import legacy_states
    from tmpc.runtime.validate import validate_plan
    problem, _, doc = solved
    states = legacy_states(doc, "planet")
    assert isinstance(states, list) and all("mode" not in s for s in states)
    assert [s["action"] for s in states if s.get("action")][0][0] == "pickup"
    path = tmp_path / "planet.json"
    path.write_text(json.dumps(states))
    report = validate_plan(problem.world, str(path))
    assert report.valid, report.text()


# ---- the tmit-star example: the same task in tmit-star's formats ------------------------------

TMIT_SORT = EXAMPLES / "tmit-star-sort" / "sort.json"


def test_tmit_star_example_loads_and_traces():
    from tmpc.compiler.lua_trace import trace_module
    from tmpc.lang.lua import load_lua_predicates
    from tmpc.lang.program import check_paths
    from tmpc.lang.world import load_config
    cfg = load_config(TMIT_SORT)
    assert cfg.format == "tmit-star-json" and dict(cfg.params)["min_steps"] == 4
    checked = check_paths([cfg.domain, cfg.problem])
    assert checked.ok, checked.diagnostics
    holding = next(p for p in checked.programs[0].domain.predicates if p.name.text == "holding")
    assert holding.kinematic is not None
    external = {p.name.text: p for p in checked.programs[0].domain.predicates if p.external}
    module = load_lua_predicates(cfg.semantics)
    assert module.dialect == "tmit-star"
    result = trace_module(module, external)
    assert set(result.traced) == {"at", "above"} and not result.fallbacks
    assert result.arg_kinds["above"] == ("object", "surface")


@pytest.mark.slow
def test_run_solves_the_tmit_star_example(tmp_path):
    """A second world (the Panda on tmit-star's always-mobile base): compiled only under -m slow."""
    from tmpc.runtime.plans import plan_document
    from tmpc.runtime.solve import plan_problem
    from tmpc.runtime.validate import validate_plan
    problem, result, setup = plan_problem(TMIT_SORT, seed=0, time_limit=60.0)
    assert result.status == "solved", result.stats
    doc = plan_document(problem, result, planner="unified", seed=0, input_path=str(TMIT_SORT),
                        setup_seconds=setup)
    assert "(putdown red_block table_b panda_hand_tcp_joint)" in doc["actions"]
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(doc))
    report = validate_plan(problem.world, str(path))
    assert report.valid, report.text()


def test_planet_names_robot_links_as_undeclared_constants(tmp_path, capsys):
    """planet's clutter_nohit.pddl names robot links (`l_upper_arm_link`) without declaring
    them (L): in the planet dialect that is a warning (W018), and the name is the robot's frame
    when the configuration gives the robot."""
    import shutil

    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.compile import compile_world
    from tmpc.runtime.cli.main import main
    ex = tmp_path / "planet-sort"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    dom = ex / "domain.pddl"
    dom.write_text(dom.read_text().replace(
        ":precondition (and (holding ?m ?x) (above ?m ?s))",
        ":precondition (and (holding ?m ?x) (above ?m ?s) (above panda_link7 ?s))"))
    capsys.readouterr()
    assert main(["check", str(ex / "sort.toml")]) == 0
    err = capsys.readouterr().err
    assert "warning[W018]" in err and "panda_link7" in err and "E206" not in err, err
    compiled = compile_world(open_world(ex / "sort.toml"))
    assert compiled.tables.entity("panda_link7") is not None         # the robot's frame
    # never an action argument: it has no type
    assert not [a for a in compiled.ground.actions if "panda_link7" in a.args]
    assert any("panda_link7" in g.args for g in compiled.ground.geometric)
