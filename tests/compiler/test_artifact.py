"""Artifacts: self-contained, verified on load, kernels equal to freshly built ones."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from tests.support import EXAMPLES
from tmpc.compiler.compile import compile_world
from tmpc.runtime.collision import collision_world


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", *args], capture_output=True,
                          text=True, cwd=cwd)


@pytest.fixture(scope="module")
def artifact(tmp_path_factory):
    d = tmp_path_factory.mktemp("art")
    src = d / "tabletop"
    shutil.copytree(EXAMPLES / "tabletop", src)
    out = d / "tabletop.tmpa"
    r = cli("compile", str(src / "tabletop.toml"), "-o", str(out))
    assert r.returncode == 0, r.stderr
    shutil.rmtree(src)                       # a run from the artifact needs no source file
    return out


def test_artifact_runs_without_its_sources(artifact):
    r = cli("eval", str(artifact), "--predicate", "over", "panda_hand_tcp", "bench", "--json",
            "--collisions")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["value"] is True and out["valid"] is True
    r = cli("sample", str(artifact), "--predicate", "reach", "panda_hand_tcp", "red_cube", "-n", "1")
    assert r.returncode == 0, r.stderr


def test_artifact_carries_the_robots_srdf(artifact, tabletop_world):
    """Self-collision pairs the SRDF disables must stay disabled in a run from the artifact
    (without it the PR2's finger tips collide in its start state)."""
    import numpy as np

    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.state import initial_state
    with zipfile.ZipFile(artifact) as z:
        assert any(n.endswith(".srdf") for n in z.namelist())
    world = open_world(artifact)
    source = tabletop_world
    a, b = collision_world(world, compile_world(world)), collision_world(source, compile_world(source))
    assert np.array_equal(a.allowed, b.allowed)
    s0 = initial_state(world.scene, compile_world(world).model)
    assert a.check(s0.q, poses=s0.poses, attached=s0.held).valid


def test_manifest_and_members(artifact):
    with zipfile.ZipFile(artifact) as z:
        manifest = json.loads(z.read("manifest.json"))
        names = set(z.namelist())
    assert manifest["format"] == "tmpc-artifact/1"
    kernels = manifest["bank"]["kernels"]
    assert {k for k in kernels if k.startswith("cond/")} == {
        "cond/predicate/reach", "cond/predicate/over", "cond/action/pick", "cond/action/place"}
    assert {"fk", "fk/frames", "proj/action/pick", "proj/action/place", "grad/predicate/reach",
            "proj/predicate/over"} <= set(kernels)
    assert all(member in names for member in kernels.values()) and not manifest["bank"]["skipped"]
    assert set(manifest["members"]) | {"manifest.json"} == names
    assert not any(n.endswith((".pkl", ".pickle", ".py")) for n in names)
    assert manifest["layout"]["q"] == [f"panda_joint{i}" for i in range(1, 8)]


def test_exported_kernels_equal_rebuilt_ones(artifact):
    """The artifact's kernels (deserialized) and kernels traced from the same sources agree."""
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.compile import CompiledProgram
    from tmpc.compiler.kernels import state_inputs
    from tmpc.compiler.state import initial_state
    world = open_world(artifact)
    compiled = compile_world(world)                     # kernels from the artifact
    traced = CompiledProgram(world.program, world.scene, compiled.model, compiled.options,
                             compiled.external)          # an empty bank: traced
    q, T, par = state_inputs(compiled.tables, initial_state(world.scene, compiled.model))
    rng = np.random.default_rng(0)
    Q = rng.uniform(compiled.model.lower, compiled.model.upper, (16, compiled.model.dof))
    for name, args in (("reach", ["panda_hand_tcp", "red_cube"]), ("over", ["panda_hand_tcp",
                                                                           "tray"])):
        f, g = compiled.predicate(name), traced.predicate(name)
        ids = compiled.bind_args(f, args)
        exported, rebuilt = compiled.kernels(f)[0], traced.kernels(g)[0]
        for i in range(16):
            (t1, d1), (t2, d2) = exported(Q[i], T, par, ids), rebuilt(Q[i], T, par, ids)
            assert bool(t1) == bool(t2) and float(d1) == pytest.approx(float(d2), abs=1e-12)
    assert compiled.bank.stats.traced == 0 and compiled.bank.stats.deserialized >= 2
    assert traced.bank.stats.traced >= 2


def test_bad_artifacts_are_rejected_clearly(artifact, tmp_path):
    truncated = tmp_path / "t.tmpa"
    truncated.write_bytes(artifact.read_bytes()[:5000])
    foreign = tmp_path / "f.tmpa"
    foreign.write_text("(define (domain d))")
    tampered = tmp_path / "x.tmpa"
    with zipfile.ZipFile(artifact) as zin, zipfile.ZipFile(tampered, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            zout.writestr(name, data + b" " if name == "src/domain.pddl" else data)
    future = tmp_path / "v.tmpa"
    with zipfile.ZipFile(artifact) as zin, zipfile.ZipFile(future, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == "manifest.json":
                data = data.replace(b"tmpc-artifact/1", b"tmpc-artifact/99")
            zout.writestr(name, data)
    for bad, fragment in [(truncated, "not a tmpc artifact"), (foreign, "not a tmpc artifact"),
                          (tampered, "does not match its digest"), (future, "artifact format")]:
        r = cli("eval", str(bad), "--expr", "(position red_cube)")
        assert r.returncode == 1 and "E590" in r.stderr and fragment in r.stderr, r.stderr
        assert "Traceback" not in r.stderr


def test_failed_compile_leaves_no_file(tmp_path):
    d = tmp_path / "p"
    shutil.copytree(EXAMPLES / "tabletop", d)
    (d / "domain.pddl").write_text((d / "domain.pddl").read_text().replace("(free ?g)", "(fre ?g)"))
    out = tmp_path / "out.tmpa"
    r = cli("compile", str(d / "tabletop.toml"), "-o", str(out))
    assert r.returncode == 1 and "E200" in r.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == [d]


def test_artifact_carries_the_smt_templates(artifact):
    """The task planner's step encoding travels in the artifact: from its text alone, the
    tabletop task (two picks and two places) has a plan of length 4 and none of length 3."""
    import z3
    with zipfile.ZipFile(artifact) as z:
        manifest = json.loads(z.read("manifest.json"))
        t = {name: z.read(member).decode() for name, member in
             manifest["smt"]["templates"].items()}
    assert "readme" in t and "@K" in t["layer"]

    def horizon(n: int) -> str:
        text = "".join(t["layer"].replace("@K", f"@{k}") for k in range(n + 1)) + t["init"]
        text += "".join(t["step"].replace("@P", f"@{k - 1}").replace("@K", f"@{k}")
                        for k in range(1, n + 1))
        goal = t["goal"] + "".join(f"(assert {lit})" for lit in t["goal-literals"].split("\n")
                                   if lit)
        return text + goal.replace("@K", f"@{n}")

    for n, want in ((3, z3.unsat), (4, z3.sat)):
        s = z3.SolverFor("QF_FD")
        s.from_string(horizon(n))
        assert s.check() == want
