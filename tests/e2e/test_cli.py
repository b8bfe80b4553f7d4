"""The CLI contract: exit codes, rendering, JSON, no tracebacks, no heavy imports in `check`."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from tests.support import EXAMPLES

CLUTTER = [str(EXAMPLES / "clutter" / "domain.pddl"), str(EXAMPLES / "clutter" / "problem.pddl")]


def run(*args, **kw):
    return subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", *args], capture_output=True,
                          text=True, **kw)


def test_check_clean_example():
    r = run("check", *CLUTTER)
    assert r.returncode == 0, r.stderr
    assert "ok: domain clutter + problem clutter-1" in r.stderr


def test_check_reports_rustc_style_and_exits_1(tmp_path):
    f = tmp_path / "bad.pddl"
    f.write_text("(define (domain d)\n  (:requirements :stripps)\n  (:predicates (p)))\n")
    r = run("check", str(f))
    assert r.returncode == 1
    assert f"{f}:2:18: error[E115]: unknown requirement `:stripps`" in r.stderr
    assert "2 |   (:requirements :stripps)" in r.stderr
    assert "^^^^^^^^" in r.stderr and "did you mean `:strips`?" in r.stderr
    assert "Traceback" not in r.stderr


def test_a_failing_check_piped_into_head_keeps_its_exit_status(tmp_path):
    """The reader closes the pipe after one line (`tmpc check bad.pddl 2>&1 | head -1`): the
    status is still 1 (errors), not 0, and no traceback or BrokenPipeError is printed."""
    f = tmp_path / "bad.pddl"
    f.write_text("(define (domain d)\n  (:requirements :strips)\n  (:predicates (p))\n" +
                 "".join(f"  (:action a{i} :parameters () :precondition (q{i}) :effect (p))\n"
                         for i in range(400)) + ")\n")
    for fmt in ("text", "json"):
        p = subprocess.Popen([sys.executable, "-m", "tmpc.runtime.cli", "check", str(f),
                              "--format", fmt], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT)
        p.stdout.readline()
        p.stdout.close()                       # the reader is gone
        assert p.wait(timeout=60) == 1


@pytest.mark.parametrize("args, fragment", [
    (["sample", "x.toml", "--predicate", "p", "-n", "0"], "-n: 0 must be an integer > 0"),
    (["sample", "x.toml", "--predicate", "p", "-n", "-3"], "-n: -3 must be an integer > 0"),
    (["sample", "x.toml", "--predicate", "p", "--iterations", "two"], "'two' is not an integer"),
    (["run", "x.toml", "--time-limit", "nan"], "--time-limit: nan must be a number > 0"),
    (["run", "x.toml", "--seed", "-1"], "--seed: -1 must be an integer >= 0"),
    (["run", "x.toml", "--heuristic-bias", "7"], "must be a number >= 0 and <= 1"),
    (["bench", "x.toml", "--seeds", "0"], "--seeds: 0 must be an integer > 0"),
])
def test_out_of_range_numbers_are_usage_errors(args, fragment):
    r = run(*args)
    assert r.returncode == 2 and fragment in r.stderr, r.stderr
    assert "Traceback" not in r.stderr


@pytest.mark.parametrize("args, code", [
    (["compile", str(EXAMPLES / "tabletop" / "tabletop.toml"), "-o", "/nonexistent/x.tmpa"],
     "E592"),
    (["run", str(EXAMPLES / "tabletop" / "tabletop.toml"), "-o", "/nonexistent/p.json"], "E828"),
    (["run", str(EXAMPLES / "tabletop" / "tabletop.toml"), "--html", "/nonexistent/p.html"],
     "E815"),
    (["run", str(EXAMPLES / "tabletop" / "tabletop.toml"), "--png", "/"], "E815"),
])
def test_unwritable_outputs_are_refused_before_any_work(args, code, tmp_path):
    """Checked before loading, compiling or planning (each of these exits in well under the
    seconds a compile takes: no kernel is built), with the path and why."""
    r = run(*args, env={**os.environ, "TMPC_CACHE_DIR": str(tmp_path / "cache")})
    assert r.returncode == 1 and f"error[{code}]: cannot write" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "cache" / "runs").exists()


def _nested_and(depth: int) -> str:
    return ("(define (domain d) (:requirements :strips) (:predicates (p))\n"
            "  (:action a :parameters () :precondition " + "(and " * depth + "(p)" +
            ")" * depth + " :effect (p)))\n")


def test_deep_nesting_is_handled_up_to_the_limit_and_refused_beyond(tmp_path):
    ok, deep = tmp_path / "ok.pddl", tmp_path / "deep.pddl"
    ok.write_text(_nested_and(95))
    deep.write_text(_nested_and(330))
    for cmd in (["check"], ["fmt", "--check"]):
        r = run(*cmd, str(ok))
        assert r.returncode in (0, 1) and "Traceback" not in r.stderr, r.stderr
        assert "error" not in r.stderr, r.stderr
        r = run(*cmd, str(deep))
        assert r.returncode == 1 and "error[E004]: parentheses nested deeper than 100" in \
            r.stderr and "Traceback" not in r.stderr, r.stderr
    assert run("fmt", str(ok)).returncode == 0


def test_diagnostics_output_is_bounded(tmp_path):
    """150,000 unclosed `(` on one line: one diagnostic, a snippet cut around the caret (not
    the 150 KB line); thousands of errors: the first 50 rendered, the rest counted; control
    characters in names are not echoed raw."""
    f = tmp_path / "parens.pddl"
    f.write_text("(define (domain d) " + "(" * 150_000)
    r = run("check", str(f))
    assert r.returncode == 1 and len(r.stderr) < 2000, len(r.stderr)
    wide = tmp_path / "wide.pddl"
    wide.write_text("(define (domain d) (:requirements :strips) (:predicates " +
                    "".join(f"(p{i}) " for i in range(20_000)) + ") (:action a :effect (q)))")
    r = run("check", str(wide))
    assert r.returncode == 1 and "error[E200]" in r.stderr and len(r.stderr) < 1500, r.stderr
    assert "| ..." in r.stderr and "(p19999) ) (:action a :effect (q)))" in r.stderr
    many = tmp_path / "many.pddl"
    many.write_text("(define (domain d) (:requirements :strips) (:predicates (p))\n" + "".join(
        f"  (:action a{i} :parameters () :precondition (q{i}) :effect (p))\n"
        for i in range(300)) + ")\n")
    r = run("check", str(many))
    assert r.returncode == 1 and r.stderr.count("error[E") == 50
    assert "... and 250 more (250 errors)" in r.stderr
    assert len(json.loads(run("check", "--format", "json", str(many)).stdout)) == 300
    evil = tmp_path / "evil.pddl"
    evil.write_text("(define (domain d) (:requirements :strips) (:predicates (p))\n"
                    "  (:action a :parameters () :precondition (q\x1b[31m\u202e) :effect (p)))\n")
    r = run("check", str(evil))
    assert r.returncode == 1 and "\x1b" not in r.stderr and "\u202e" not in r.stderr
    assert "\ufffd" in r.stderr


def test_a_file_that_is_not_utf8_is_pointed_at(tmp_path):
    f = tmp_path / "bad.pddl"
    f.write_bytes(b"(define (domain d)\n  (:predicates (p))\n  ;; caf\xe9\n)\n")
    r = run("check", str(f))
    assert r.returncode == 1 and f"{f}:3:9: error[E011]: {f} is not UTF-8 text (byte 47: " \
        "0xe9)" in r.stderr, r.stderr
    scene = tmp_path / "scene.json"
    scene.write_bytes(b'{"format": "tmpc-scene/1",\n "name": "\xff"}\n')
    r = run("check", str(scene))
    assert r.returncode == 1 and f"{scene}:2:11: error[E011]" in r.stderr, r.stderr


def test_check_json_format(tmp_path):
    f = tmp_path / "bad.pddl"
    f.write_text("(define (domain d) (:predicates (p))\n  (:action a :effect (q)))\n")
    r = run("check", "--format", "json", str(f))
    assert r.returncode == 1
    (d,) = json.loads(r.stdout)
    assert (d["code"], d["severity"], d["span"]["line"], d["span"]["column"]) == \
        ("E200", "error", 2, 23)


def test_missing_file_and_usage_errors(tmp_path):
    r = run("check", str(tmp_path / "nope.pddl"))
    assert r.returncode == 1 and "no such file" in r.stderr and "Traceback" not in r.stderr
    assert run("check").returncode == 2
    assert run("frobnicate").returncode == 2
    lua = tmp_path / "preds.lua"
    lua.write_text("function at(m, x)\n  return True(\nend\n")
    r = run("check", str(lua))
    assert r.returncode == 1 and "E70" in r.stderr and "preds.lua:3" in r.stderr
    assert "Traceback" not in r.stderr
    binary = tmp_path / "bin.pddl"
    binary.write_bytes(b"\xff\xfe\x00(")
    r = run("check", str(binary))
    assert r.returncode == 1 and "UTF-8" in r.stderr


def test_check_imports_nothing_heavy():
    code = ("import sys; from tmpc.runtime.cli.main import main; rc = main(['check', %r, %r]); "
            "heavy = [m for m in ('jax', 'z3', 'ompl', 'lupa', 'numpy', 'fcl', 'trimesh', 'numba') "
            "if m in sys.modules]; print(heavy); sys.exit(rc)") % tuple(CLUTTER)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


def test_check_reads_scenes_configs_and_lua(tmp_path):
    tabletop = EXAMPLES / "tabletop"
    r = run("check", str(tabletop / "scene.json"), str(tabletop / "tabletop.toml"),
            str(tabletop / "domain.pddl"), str(tabletop / "problem.pddl"))
    assert r.returncode == 0, r.stderr
    bad = tmp_path / "scene.json"
    bad.write_text((tabletop / "scene.json").read_text().replace('"movable"', '"moveable"', 1))
    r = run("check", str(bad))
    assert r.returncode == 1 and "E504" in r.stderr and "did you mean" in r.stderr


def test_problem_alone_finds_its_domain_beside_it():
    r = run("check", CLUTTER[1])
    assert r.returncode == 0, r.stderr
    assert "W011" in r.stderr


def test_check_static_reports_dead_actions_and_unreachable_goals(tmp_path):
    """`tmpc check --static` adds the SAT/relaxation warnings; plain `check` stays light."""
    dom = tmp_path / "d.pddl"
    dom.write_text("(define (domain d) (:requirements :strips :negative-preconditions)\n"
                   "  (:predicates (p) (q) (r))\n"
                   "  (:action a :parameters () :precondition (and (p) (not (p))) :effect (q))\n"
                   "  (:action b :parameters () :precondition (p) :effect (q)))\n")
    prob = tmp_path / "p.pddl"
    prob.write_text("(define (problem pr) (:domain d) (:init (p)) (:goal (and (q) (r))))\n")
    # a generous budget: the test is about what is found, not how fast (2 s flaked under load)
    r = run("check", str(dom), str(prob), "--static", "--budget", "60")
    assert r.returncode == 0, r.stderr
    assert "d.pddl:3:12: warning[W610]" in r.stderr and "action `a`" in r.stderr
    assert "warning[W612]" in r.stderr and "(r)" in r.stderr
    plain = run("check", str(dom), str(prob))
    assert plain.returncode == 0 and "W61" not in plain.stderr


def test_check_static_finds_geometry_nothing_can_satisfy(tmp_path):
    """W614: with a run configuration, `check --static` projects each geometric condition within
    the joint and base bounds; one asking for a stick 5 m up is reported at its declaration, the
    bundled example is clean."""
    import shutil
    ex = tmp_path / "clutter"
    shutil.copytree(EXAMPLES / "clutter", ex)
    dom = ex / "domain.pddl"
    dom.write_text(dom.read_text().replace(
        "(near ?m ?x 0.05)", "(and (near ?m ?x 0.05) (> (z (position ?x)) 5.0))"))
    r = run("check", "--static", str(ex / "clutter.toml"))
    assert r.returncode == 0, r.stderr
    assert "warning[W614]: geometric predicate `at`" in r.stderr
    assert "warning[W614]: the geometric precondition of action `pickup`" in r.stderr
    assert "`putdown`" not in r.stderr and "`placed`" not in r.stderr


def test_check_reads_an_allowed_collision_csv_as_one(tmp_path):
    """A blocklist CSV is checked as the CSV it is (it was parsed as PDDL)."""
    good, bad = tmp_path / "blacklist.csv", tmp_path / "bad.csv"
    good.write_text("# pairs never checked\ntable1,base_link\n\nstick1, r_gripper_palm_link\n")
    bad.write_text("table1,base_link\ntable2\n")
    r = run("check", str(good))
    assert r.returncode == 0 and "error" not in r.stderr, r.stderr
    r = run("check", str(bad))
    assert r.returncode == 1 and f"{bad}:2:1: error[E516]" in r.stderr, r.stderr


def test_check_honours_the_mesh_path_as_run_does(tmp_path):
    """tmit-star's repository lacks its .obj meshes: `check` looked only beside the scene
    where `run` also searched $TMPC_MESH_PATH. A mesh a run cannot find is an error (E514, L 4:
    it was warning W501, and the run then failed with E565)."""
    import re

    from tests.support import LEGACY
    spec = LEGACY / "tmit-star" / "bin-picking" / "problems" / "pb_1.json"
    r = run("check", str(spec))
    missing = sorted(set(re.findall(r'mesh file "models/([^"]+)" not found', r.stderr)))
    assert r.returncode == 1 and missing and "error[E514]" in r.stderr, r.stderr
    assert "TMPC_MESH_PATH" in r.stderr and "W501" not in r.stderr
    for name in missing:
        (tmp_path / name).write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    r = run("check", str(spec), env={**os.environ, "TMPC_MESH_PATH": str(tmp_path)})
    assert r.returncode == 0 and "W501" not in r.stderr, r.stderr


def test_check_fails_on_a_mesh_a_run_cannot_load(tmp_path):
    """A run configuration whose mesh is missing or holds no triangles fails `check` (E514,
    E565 at the scene's line, with the hint a user can act on): it was a warning, or nothing,
    and the run then failed (L 4)."""
    ex = tmp_path / "ps"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    block = ex / "meshes" / "block.obj"
    block.write_text("# an export that went wrong\nv 0 0 0\n")
    r = run("check", str(ex / "sort.toml"))
    assert r.returncode == 1 and "scene.xml:45:13: error[E565]" in r.stderr, r.stderr
    assert "no faces" in r.stderr and "help: use an STL, OBJ or PLY file" in r.stderr
    block.unlink()
    r = run("check", str(ex / "sort.toml"))
    assert r.returncode == 1 and "scene.xml:45:13: error[E514]" in r.stderr, r.stderr
    assert "help: looked for" in r.stderr and "TMPC_MESH_PATH" in r.stderr
    assert run("check", str(EXAMPLES / "planet-sort" / "sort.toml")).returncode == 0


def test_check_fails_on_a_robot_mesh_a_run_cannot_load(tmp_path):
    """The robot's link meshes too: a run loads every one for collision checking and stops at
    a missing one (E562), so `check` reports each missing (E562) or unloadable (E565) link
    mesh at its `<mesh>` tag in the URDF (L 4)."""
    from tmpc.lang.world.robot import find_file
    ex = tmp_path / "ps"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    urdf = find_file("package://example-robot-data/robots/panda_description/urdf/panda.urdf",
                     ex)
    text = urdf.read_text()
    text = text.replace("package://example-robot-data/robots/panda_description/meshes/"
                        "collision/link3.stl", "meshes/gone.stl")
    text = text.replace("package://example-robot-data/robots/panda_description/meshes/"
                        "collision/link5.stl", "meshes/empty.stl")
    (ex / "panda.urdf").write_text(text)
    (ex / "meshes" / "empty.stl").write_text("")
    scene = ex / "scene.xml"
    scene.write_text(scene.read_text().replace(
        "package://example-robot-data/robots/panda_description/urdf/panda.urdf", "panda.urdf"))
    line = next(i for i, ln in enumerate(text.splitlines(), 1) if "meshes/gone.stl" in ln)
    r = run("check", str(ex / "sort.toml"))
    assert r.returncode == 1, r.stderr
    assert f"panda.urdf:{line}:" in r.stderr and "error[E562]" in r.stderr, r.stderr
    assert "`meshes/gone.stl` of link `panda_link3` not found" in r.stderr
    assert "TMPC_MESH_PATH" in r.stderr
    assert "error[E565]" in r.stderr and "link `panda_link5`" in r.stderr and "empty" in r.stderr
    (ex / "meshes" / "gone.stl").write_bytes((ex / "meshes" / "empty.stl").read_bytes())
    (ex / "meshes" / "empty.stl").unlink()
    r = run("check", str(ex / "sort.toml"))
    assert r.returncode == 1 and "error[E562]" in r.stderr and "panda_link5" in r.stderr


def test_the_clutter_generator_writes_a_run_manifest(tmp_path):
    """`generate.py N` writes the manifest too, so `tmpc run` works on what it writes."""
    gen = subprocess.run([sys.executable, str(EXAMPLES / "clutter" / "generate.py"), "3", "--red",
                          "-o", str(tmp_path)], capture_output=True, text=True)
    assert gen.returncode == 0, gen.stderr
    r = run("check", str(tmp_path / "clutter-3-red.toml"))
    assert r.returncode == 0 and "ok: domain clutter + problem" in r.stderr, r.stderr


def test_tmpc_warnings_are_one_line_each(capsys):
    """In the CLI, a warning raised by tmpc's code is a `warning: MESSAGE` line (not Python's
    file:line form with a line of tmpc's source); another library's keeps Python's form."""
    import warnings

    import importlib

    from tmpc.runtime.collision import spheres
    show = importlib.import_module("tmpc.runtime.cli.main")._show_warning
    show(UserWarning("the build failed"), UserWarning, spheres.__file__, 3)
    show(UserWarning("elsewhere"), UserWarning, warnings.__file__, 7)
    show(DeprecationWarning("old"), DeprecationWarning, spheres.__file__, 9)
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "warning: the build failed"
    assert err[1].startswith(warnings.__file__ + ":7: UserWarning: elsewhere")
    assert any(": DeprecationWarning: old" in line for line in err[2:])
