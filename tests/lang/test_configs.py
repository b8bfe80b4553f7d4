"""Run configurations: native manifest, planet run TOML (+ params TOML), tmit-star spec."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import DOCS, EXAMPLES, FIXTURES, LEGACY, pos_of, raises, tmpc_here, where
from tmpc.lang.diagnostics import SceneError
from tmpc.lang.source import SourceFile
from tmpc.lang.world import LoadReport, load_allowed_pairs, load_scene
from tmpc.lang.world.configs import (
    CONFIG_LOADERS,
    PLANNER_PARAMS,
    load_config,
    load_planet_params,
    toml_positions,
)

CONFIGS = FIXTURES / "configs"
SCENES = FIXTURES / "scenes"
NATIVE = CONFIGS / "native" / "run.toml"
PLANET = CONFIGS / "planet" / "run.toml"
TMIT = CONFIGS / "tmit" / "problems" / "demo" / "problems" / "demo.json"


def check_error(code: str, path: Path, needle: str | None, nth: int = 0):
    """``code`` error naming the file, at ``needle`` (None: line 1, column 1)."""
    diag, files = raises(code, load_config, path)
    assert path.name in diag.message
    expected = pos_of(path.read_text(), needle, nth) if needle else (1, 1)
    assert where(diag, files) == expected, diag.message
    return diag


def copy_tree(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


# --------------------------------------------------------------------------------------------
# the fixtures


def test_registry_names_match_config_format():
    assert set(CONFIG_LOADERS) == {"tmpc-toml", "planet-toml", "tmit-star-json"}
    for fmt, path in (("tmpc-toml", NATIVE), ("planet-toml", PLANET), ("tmit-star-json", TMIT)):
        assert load_config(path).format == fmt
        assert load_config(path, fmt=fmt).format == fmt


def test_native_manifest():
    c = load_config(NATIVE)
    d = CONFIGS / "native"
    assert (c.domain, c.problem) == (d / "domain.pddl", d / "problem.pddl")
    assert c.scene == SCENES / "native" / "scene.json"
    assert c.allowed_collisions == d / "pairs.csv" and c.semantics is None
    assert c.mesh_dir == SCENES / "native" / "meshes"
    assert c.params == (("coin_bias", 0.4), ("gd_tries", 5))
    assert c.time_limit == 30.0 and c.output == d / "out" / "plan.json"
    assert load_scene(c.scene, mesh_dir=c.mesh_dir).format == "tmpc-json"
    assert len(load_allowed_pairs(c.allowed_collisions)) == 3


def test_planet_run_toml_with_params():
    report = LoadReport()
    c = load_config(PLANET, report=report)
    d = CONFIGS / "planet"
    assert report.warnings == []
    assert c.domain == d / "demo" / "domain.pddl" and c.semantics == d / "demo.lua"
    assert c.scene == SCENES / "planet" / "demo" / "demo.xml"
    assert c.mesh_dir == SCENES / "planet" / "demo"
    assert c.allowed_collisions == d / "models" / "blacklist.csv"
    assert c.params == (("coin_bias", 0.25), ("gd_tries", 4), ("success_scale", 50.0))
    assert c.time_limit == 60.0 and c.output == d / "demo_solution.json"
    s = load_scene(c.scene, mesh_dir=c.mesh_dir)
    assert s.format == "planet-xml" and len(s.objects) == 3


def test_tmit_spec_resolves_against_ancestors():
    report = LoadReport()
    c = load_config(TMIT, report=report)
    root = CONFIGS / "tmit"
    assert report.warnings == []                  # max_iterations is known and ignored
    assert c.domain == root / "problems" / "demo" / "pddl" / "domain.pddl"
    assert c.semantics == root / "lua" / "predicates.lua"
    assert c.allowed_collisions == root / "models" / "blocklist.csv"
    assert c.params == (("name", "demo"), ("min_steps", 1), ("max_steps", 6))
    assert c.time_limit is None and c.mesh_dir is None
    s = load_scene(c.scene)
    assert s.format == "tmit-star-json" and s.robot.urdf == root / "models" / "arm2.urdf"


def test_toml_positions():
    src = SourceFile("t.toml", '# c\n[problem]\ndomain = "d.pddl"  # x\n\n[planner]\n'
                               '"coin_bias" = 0.5\n')
    values, keys = toml_positions(src)
    assert src.text[values["problem.domain"].start:values["problem.domain"].end] == '"d.pddl"'
    assert src.line_col(keys["planner.coin_bias"].start) == (6, 1)
    assert src.line_col(keys["planner"].start) == (5, 1)


def test_planner_params_are_documented():
    text = (DOCS / "world.md").read_text()
    for name in PLANNER_PARAMS:
        assert f"`{name}`" in text


# --------------------------------------------------------------------------------------------
# errors: code, file name, line:column


def test_native_unknown_key_missing_key_and_missing_file(tmp_path):
    d = copy_tree(CONFIGS / "native", tmp_path / "native")
    run = d / "run.toml"
    text = NATIVE.read_text()
    run.write_text(text.replace("coin_bias = 0.4", "coin_bais = 0.4"))
    diag = check_error("E504", run, "coin_bais")
    assert "`coin_bias`" in diag.hint
    run.write_text(text.replace('domain = "domain.pddl"\n', ""))
    diag = check_error("E505", run, "[problem]")
    assert '"domain"' in diag.message
    run.write_text(text.replace('problem = "problem.pddl"', 'problem = "p2.pddl"'))
    diag = check_error("E515", run, '"p2.pddl"')
    assert str(d / "p2.pddl") in diag.hint
    run.write_text(text.replace("../../scenes/native/scene.json", "scene.json"))
    diag = check_error("E515", run, '"scene.json"')       # native: no search of parents


def test_native_types_and_values(tmp_path):
    d = copy_tree(CONFIGS / "native", tmp_path / "native")
    run = d / "run.toml"
    text = NATIVE.read_text()
    run.write_text(text.replace("gd_tries = 5", 'gd_tries = "five"'))
    check_error("E506", run, '"five"')
    run.write_text(text.replace("gd_tries = 5", "gd_tries = 2.5"))
    check_error("E506", run, "2.5")
    run.write_text(text.replace("time_limit = 30", "time_limit = -1"))
    check_error("E512", run, "-1")
    run.write_text(text.replace("[problem]", "problem = 3\n[x]"))
    raises("E503", load_config, run)
    run.write_text(text.replace('scene = "', 'scene = '))
    diag, _ = raises("E502", load_config, run)
    assert "run.toml" in diag.message


def test_toml_syntax_error_position(tmp_path):
    p = tmp_path / "run.toml"
    p.write_text('[problem]\ndomain = "d.pddl"\nproblem = p.pddl\n')
    diag, files = raises("E502", load_config, p)
    assert "run.toml" in diag.message and where(diag, files) == (3, 11)


def test_planet_errors_and_warnings(tmp_path):
    d = copy_tree(CONFIGS / "planet", tmp_path / "configs" / "planet")
    shutil.copytree(SCENES, tmp_path / "scenes")    # "../../scenes/..." from the copy
    run = d / "run.toml"
    text = PLANET.read_text()
    run.write_text(text + "max_iterations = 3\n")
    report = LoadReport()
    assert load_config(run, report=report).format == "planet-toml"
    assert [w.code for w in report.warnings] == ["W500"]
    run.write_text(text.replace('scene     = "../../scenes/planet/demo/demo.xml"\n', ""))
    diag = check_error("E505", run, None)
    assert '"scene"' in diag.message
    run.write_text(text.replace("models/blacklist.csv", "models/blocklist.csv"))
    diag = check_error("E515", run, '"models/blocklist.csv"')
    assert str(d / "models" / "blocklist.csv") in diag.hint and str(tmp_path) in diag.hint
    run.write_text(text.replace("timeout   = 60", 'timeout   = "60"'))
    check_error("E506", run, '"60"')
    run.write_text(text)
    (d / "params.toml").write_text("coin_bias = 0.3\ngd_tries = -2\nseed = 4\n")
    diag, files = raises("E512", load_config, run)
    assert "params.toml" in diag.message and where(diag, files) == (2, 12)
    report = LoadReport()
    (d / "params.toml").write_text("coin_bias = 0.3\nseed = 4\n")
    assert load_planet_params(d / "params.toml", report) == (("coin_bias", 0.3),)
    assert [w.code for w in report.warnings] == ["W500"]


def test_tmit_spec_errors(tmp_path):
    root = copy_tree(CONFIGS / "tmit", tmp_path / "tmit")
    spec = root / "problems" / "demo" / "problems" / "demo.json"
    text = TMIT.read_text()
    spec.write_text(text.replace('"min_steps": 1', '"min_steps": 9'))
    check_error("E511", spec, "6\n")
    spec.write_text(text.replace('"min_steps": 1', '"min_steps": "one"'))
    check_error("E506", spec, '"one"')
    spec.write_text(text.replace('  "domain": "problems/demo/pddl/domain.pddl",\n', ""))
    diag = check_error("E505", spec, "{")
    assert '"domain"' in diag.message
    spec.write_text(text.replace("pb_1_scene.json", "pb_2_scene.json"))
    diag = check_error("E515", spec, '"problems/demo/scenes/pb_2_scene.json"')
    assert "scene file" in diag.message
    spec.write_text(text.replace('"max_iterations": 3', '"max_iteration": 3'))
    report = LoadReport()
    load_config(spec, report=report)
    assert [w.code for w in report.warnings] == ["W500"]
    assert "`max_iterations`" not in (report.warnings[0].hint or "")
    spec.write_text(text.replace('"max_steps": 6\n}', '"max_steps": 6,\n}'))
    check_error("E500", spec, "}")


def test_wrong_kind_of_file_and_unknown_format(tmp_path):
    diag, _ = raises("E503", load_config, LEGACY / "planet" / "params.toml")
    assert "params file" in diag.message
    diag, _ = raises("E503", load_config, SCENES / "native" / "scene.json")
    assert "scene, not a run configuration" in diag.message
    diag, _ = raises("E503", load_config, NATIVE, fmt="toml")
    assert "tmpc-toml" in diag.hint
    raises("E010", load_config, tmp_path / "missing.toml")


def test_config_loader_does_not_import_heavy_modules():
    code = ("import sys, tmpc.lang.world.configs\n"
            "print(sorted(m for m in ('numpy', 'jax', 'z3', 'lxml', 'yourdfpy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# --------------------------------------------------------------------------------------------
# the real legacy configurations


def test_every_legacy_config_loads():
    """The legacy configurations of tests/fixtures/legacy: planet run TOMLs (+ params TOML) and
    every tmit-star problem spec but the one that names a missing scene."""
    root = LEGACY / "planet"
    planet = load_config(root / "two-table-sort.toml")
    assert planet.format == "planet-toml" and planet.params == (("coin_bias", 0.4),)
    assert planet.mesh_dir == root / "two-table-sort"
    assert planet.allowed_collisions == root / "models" / "pr2_collision_blacklist.csv"
    assert planet.semantics == root / "predicates.lua" and planet.time_limit == 700.0
    assert load_planet_params(root / "params.toml") == (("coin_bias", 0.4),)
    runs = sorted(p for p in root.glob("*.toml") if p.name != "params.toml")
    assert [p.name for p in runs] == ["cupboard-shelf.toml", "two-table-sort.toml"]
    for f in runs:
        report = LoadReport()
        c = load_config(f, report=report)
        assert c.format == "planet-toml" and report.warnings == []
        assert c.domain.is_file() and c.problem.is_file() and c.semantics.is_file()
        scene = load_scene(c.scene, mesh_dir=c.mesh_dir, strict_meshes=False)
        assert scene.format == "planet-xml"
    assert load_config(root / "cupboard-shelf.toml").params == ()      # no params file

    tmit = LEGACY / "tmit-star"
    specs = sorted(tmit.glob("*/problems/*.json"))
    loaded, broken = [], []
    for f in specs:
        name = str(f.relative_to(tmit))
        try:
            c = load_config(f)
        except SceneError as exc:
            broken.append((name, exc))
            continue
        assert c.format == "tmit-star-json" and c.scene.is_file()
        assert c.semantics == tmit / "lua" / "predicates.lua"      # found in an ancestor
        assert c.allowed_collisions == tmit / "models" / "pr2_blocklist.csv"
        assert load_scene(c.scene, strict_meshes=False).format == "tmit-star-json"
        loaded.append(name)
    # shelf-restock/problems/pb_2.json names a scene the fixtures do not contain
    assert [name for name, _ in broken] == ["shelf-restock/problems/pb_2.json"]
    assert broken[0][1].diagnostics[0].code == "E515"
    assert loaded == ["bin-picking/problems/pb_1.json", "bin-picking/problems/pb_2.json",
                      "shelf-restock/problems/pb_1.json"]
    assert dict(load_config(tmit / "bin-picking" / "problems" / "pb_1.json").params) == \
        {"name": "bin-picking-1", "min_steps": 2, "max_steps": 12}


def test_native_manifest_sets_the_collision_tolerance(tmp_path):
    """`[planner] collision_tolerance` is the penetration depth `tmpc run`/`validate` ignore
    (docs/planning.md); E823's help points users at it, so the manifest must accept it."""
    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.validate.core import default_tolerance
    d = copy_tree(EXAMPLES / "tabletop", tmp_path / "tabletop")
    run = d / "tabletop.toml"
    run.write_text(run.read_text() + "\n[planner]\ncollision_tolerance = 0.015\n")
    c = load_config(run)
    assert dict(c.params)["collision_tolerance"] == 0.015
    assert default_tolerance(open_world(run, with_program=False)) == 0.015
    run.write_text(run.read_text().replace("0.015", "-1"))
    check_error("E512", run, "-1")
    # what `check` accepted and `run` rejected: every one an error at its line
    base = run.read_text().replace("collision_tolerance = -1", "")
    for line, code, needle in [("collision_tolerance = nan", "E512", "nan"),
                               ("collision_tolerance = inf", "E512", "inf"),
                               ("coin_bias = 7", "E512", "7"),
                               ("time_limit = nan", "E512", "nan")]:
        run.write_text(base + line + "\n")
        check_error(code, run, needle)
    run.write_text(base + 'output = "nowhere/plan.json"\n')
    r = tmpc_here("check", run)
    line, col = pos_of(run.read_text(), '"nowhere/plan.json"')
    assert f"{run}:{line}:{col}: warning[W507]" in r.stderr, r.stderr
    r = tmpc_here("run", run, env={**os.environ, "TMPC_CACHE_DIR": str(tmp_path / "cache")})
    assert r.returncode == 1 and "error[E828]: cannot write" in r.stderr, r.stderr
    assert not (tmp_path / "cache" / "runs").exists()          # refused before compiling


def test_check_of_a_run_config_checks_what_it_names(tmp_path):
    """`tmpc check CONFIG` checks the domain and problem it names and that the Lua file defines
    every geometric predicate without inline semantics (E707), as a run would."""
    import shutil
    ex = tmp_path / "ps"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    ok = tmpc_here("check", ex / "sort.toml")
    assert ok.returncode == 0 and "problem" in ok.stderr, ok.stderr
    lua = ex / "sort.lua"
    lua.write_text(lua.read_text().replace("function at(", "function at_renamed("))
    bad = tmpc_here("check", ex / "sort.toml")
    assert bad.returncode == 1 and "E707" in bad.stderr and "domain.pddl:" in bad.stderr, bad.stderr
    # the wrong number of parameters: E708 from `check`, as from a run (it was run-only)
    lua.write_text(lua.read_text().replace("function at_renamed(m, x)", "function at(m, x, y)"))
    bad = tmpc_here("check", ex / "sort.toml")
    assert bad.returncode == 1 and "error[E708]: Lua function `at` takes 3 parameter(s) but " \
        "predicate `at` has 2" in bad.stderr, bad.stderr
    lua.write_text(lua.read_text().replace("function at(m, x, y)", "function at(m, x)"))
    prob = ex / "problem.pddl"
    prob.write_text(prob.read_text().replace("(:goal (and", "(:goal (and (no-such-pred a)"))
    bad = tmpc_here("check", ex / "sort.toml")
    assert bad.returncode == 1 and "problem.pddl:" in bad.stderr, bad.stderr


def test_lua_limits_come_from_the_manifest(tmp_path):
    """`[planner] lua_seconds` (and `lua_instructions`, `lua_memory`) set the sandbox's limits
    for `check` as for a run; the E704 hint names them (it named a Python API)."""
    import subprocess
    import sys
    ex = tmp_path / "ps"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    lua = ex / "sort.lua"
    lua.write_text('for i = 1, 3e6 do local s = ("x"):rep(1e6) end\n' + lua.read_text())
    (ex / "run.toml").write_text('[problem]\ndomain = "domain.pddl"\nproblem = "problem.pddl"\n'
                                 'scene = "scene.xml"\nsemantics = "sort.lua"\n'
                                 'mesh_dir = "meshes"\n[planner]\nlua_seconds = 0.5\n')
    r = subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", "check", str(ex / "run.toml")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1 and "error[E704]" in r.stderr and "time limit (0.5 s" in r.stderr
    assert "`lua_seconds`" in r.stderr, r.stderr


def test_lua_limits_from_the_command_line_for_a_legacy_configuration(tmp_path, capsys):
    """A planet TOML has no place for the sandbox's limits (L 1): `--lua-seconds` and
    `--lua-instructions` set them, over a manifest's too, and the hints name the flags."""
    from tmpc.lang import lua
    from tmpc.runtime.cli.main import main
    ex = tmp_path / "ps"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    lua_file = ex / "sort.lua"
    lua_file.write_text('for i = 1, 3e6 do local s = ("x"):rep(1e6) end\n' + lua_file.read_text())
    saved = lua.clear_lua_overrides()
    try:
        capsys.readouterr()
        assert main(["check", str(ex / "sort.toml"), "--lua-seconds", "0.3"]) == 1
        err = capsys.readouterr().err
        assert "error[E704]" in err and "time limit (0.3 s" in err and "--lua-seconds" in err
        lua.clear_lua_overrides()
        lua_file.write_text("for i = 1, 1e5 do end\n" + lua_file.read_text())
        assert main(["check", str(ex / "sort.toml"), "--lua-instructions", "1000"]) == 1
        assert "instruction limit (1,000)" in capsys.readouterr().err
    finally:
        lua.clear_lua_overrides()
        lua.override_lua_limits(**saved)
    with pytest.raises(SystemExit) as exc:
        main(["check", str(ex / "sort.toml"), "--lua-seconds", "-1"])
    assert exc.value.code == 2


def test_check_traces_the_lua_predicates_as_run_does(tmp_path, capsys):
    """`tmpc check` of a run configuration finds what tracing its Lua predicates finds (L 4):
    an unknown field (E709) and a predicate that never returns (E704), each at its Lua line
    with a hint; before, only `run` and `compile` did."""
    from tmpc.runtime.cli.main import main
    ex = tmp_path / "ps"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    lua = ex / "sort.lua"
    text = lua.read_text()
    text = text.replace("  local d2 = (m.px - x.px)", "  local w = x.mass\n  local d2 = (m.px - x.px)")
    text = text.replace("  local r = s.sssp.region", "  while true do end\n  local r = s.sssp.region")
    lua.write_text(text)
    (ex / "run.toml").write_text('[problem]\ndomain = "domain.pddl"\nproblem = "problem.pddl"\n'
                                 'scene = "scene.xml"\nsemantics = "sort.lua"\n'
                                 'mesh_dir = "meshes"\n[planner]\nlua_instructions = 100000\n')
    lines = text.splitlines()
    capsys.readouterr()
    assert main(["check", str(ex / "run.toml"), "--format", "json"]) == 1
    got = json.loads(capsys.readouterr().out)
    found = {d["code"]: d for d in got}
    assert set(found) == {"E709", "E704"}, got
    assert lines[found["E709"]["span"]["line"] - 1].strip() == "local w = x.mass"
    assert lines[found["E704"]["span"]["line"] - 1].strip() == "while true do end"
    assert all(d["span"]["path"].endswith("sort.lua") and d["hint"] for d in found.values()), got


def test_native_manifest_names_its_planner(tmp_path):
    """`[planner] name` is the planner `tmpc run` uses without --planner; a name that is not a
    string is an error at its value, one that names no planner is E826 at the run."""
    d = copy_tree(EXAMPLES / "tabletop", tmp_path / "tabletop")
    run = d / "tabletop.toml"
    base = run.read_text()
    assert load_config(run).planner is None
    run.write_text(base + '\n[planner]\nname = "decoupled"\n')
    assert load_config(run).planner == "decoupled"
    run.write_text(base + "\n[planner]\nname = 3\n")
    check_error("E506", run, "3")
    run.write_text(base + '\n[planner]\nname = "optimel"\n')
    r = tmpc_here("run", run, "--time-limit", "1")
    assert r.returncode != 0 and "E826" in r.stdout + r.stderr and "Traceback" not in r.stderr


def test_native_manifest_names_its_task_planner(tmp_path):
    """`[planner] task_planner` is one of auto, sat, greedy (E512 at its value otherwise) and
    is a parameter of the optimal and decoupled planners; an unknown value given to a
    planner's factory directly is its range error (E825, E851). (What each value builds:
    tests/runtime/test_greedy.py.)"""
    from tmpc.lang.diagnostics import InputError
    from tmpc.runtime.planners import PLANNERS
    d = copy_tree(EXAMPLES / "tabletop", tmp_path / "tabletop")
    run = d / "tabletop.toml"
    base = run.read_text()
    run.write_text(base + '\n[planner]\ntask_planner = "sat"\n')
    assert dict(load_config(run).params)["task_planner"] == "sat"
    run.write_text(base + '\n[planner]\ntask_planner = "fast"\n')
    diag = check_error("E512", run, '"fast"')
    assert "auto, sat, greedy" in diag.message
    run.write_text(base + "\n[planner]\ntask_planner = 1\n")
    check_error("E506", run, "1")
    assert "task_planner" in PLANNERS["optimal"].parameters
    assert "task_planner" in PLANNERS["decoupled"].parameters
    from tmpc.runtime.planners.decoupled import DecoupledPlanner
    from tmpc.runtime.planners.optimal import OptimalPlanner

    class World:
        config = None

    class Problem:
        world = World()

    for cls, code in ((OptimalPlanner, "E825"), (DecoupledPlanner, "E851")):
        with pytest.raises(InputError) as exc:
            cls.from_options(Problem(), 0, {"task_planner": "fast"})
        assert exc.value.diagnostics[0].code == code
