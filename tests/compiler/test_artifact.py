"""Artifacts: self-contained, verified on load, kernels equal to freshly built ones."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from tests.support import EXAMPLES, tmpc_here
from tmpc.compiler.compile import compile_world
from tmpc.runtime.collision import collision_world


def cli(*args, cwd=None):
    """`tmpc ARGS` in this process (exit code, stdout, stderr as a process gives them)."""
    return tmpc_here(*args, cwd=cwd)


def cli_process(*args, cwd=None):
    """`tmpc ARGS` in a fresh interpreter."""
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
    # a fresh interpreter: nothing of the sources (deleted) in memory either
    r = cli_process("eval", str(artifact), "--predicate", "over", "panda_hand_tcp", "bench",
                    "--json", "--collisions")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["value"] is True and out["valid"] is True
    r = cli_process("sample", str(artifact), "--predicate", "reach", "panda_hand_tcp", "red_cube", "-n", "1")
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


def test_the_artifacts_scene_is_the_sources_to_the_bit(artifact, tabletop_world):
    """Every pose, grasp and support of the artifact's scene equals the sources' exactly: a
    problem planned from its artifact (``tmpc bench``'s workers) and from its sources
    (``tmpc run``) must be the same problem, or one seed gives two plans."""
    from tmpc.compiler.artifact import open_world
    world = open_world(artifact)
    a = {o.name: o for o in world.scene.objects}
    b = {o.name: o for o in tabletop_world.scene.objects}
    assert a.keys() == b.keys()
    for name in a:
        assert (a[name].pose, a[name].support, a[name].grasps, a[name].stable_poses) == \
            (b[name].pose, b[name].support, b[name].grasps, b[name].stable_poses), name


def test_manifest_and_members(artifact):
    with zipfile.ZipFile(artifact) as z:
        manifest = json.loads(z.read("manifest.json"))
        names = set(z.namelist())
    assert manifest["format"] == "tmpc-artifact/1"
    kernels = manifest["bank"]["kernels"]
    assert {k for k in kernels if k.startswith("cond/")} == {
        "cond/predicate/reach", "cond/predicate/over", "cond/predicate/resting",
        "cond/action/pick", "cond/action/place"}
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


def test_equal_kernels_share_one_executable(artifact):
    """Keys whose serialized kernels are byte-identical resolve to one jitted call (one load);
    a different kernel to its own; the shared call computes what each key's kernel does."""
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.bank import KernelBank
    from tmpc.compiler.kernels import state_inputs
    from tmpc.compiler.state import initial_state
    world = open_world(artifact)
    compiled = compile_world(world)
    f, g = compiled.predicate("reach"), compiled.predicate("over")
    reach, over = (compiled.bank.exported(f"cond/{x.key}") for x in (f, g))
    assert reach is not None and over is not None and reach != over
    bank = KernelBank({"a": reach, "b": bytes(reach), "c": over}, "test")
    spec = [((compiled.model.dof,), "float64")]
    fns = {k: bank.function(k, lambda: pytest.fail("traced"), spec) for k in "abc"}
    q, T, par = state_inputs(compiled.tables, initial_state(world.scene, compiled.model))
    ids = compiled.bind_args(f, ["panda_hand_tcp", "red_cube"])
    want = compiled.kernels(f)[0](q, T, par, ids)
    for k in "ab":
        got = fns[k](q, T, par, ids)
        assert bool(got[0]) == bool(want[0]) and float(got[1]) == float(want[1])
    fns["c"](q, T, par, compiled.bind_args(g, ["panda_hand_tcp", "tray"]))
    assert fns["a"]._jitted is fns["b"]._jitted is not fns["c"]._jitted
    assert bank.stats.deserialized == 2 and bank.stats.traced == 0


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
                          (tampered, "modified or damaged"), (future, "artifact format")]:
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


def _rezip(src, dst, edit_manifest=None, extra=()):
    """A copy of an artifact with its manifest edited (``edit_manifest(dict)``) and extra
    members (name, bytes) added."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == "manifest.json" and edit_manifest is not None:
                m = json.loads(data)
                edit_manifest(m)
                data = json.dumps(m).encode()
            zout.writestr(name, data)
        for name, data in extra:
            zout.writestr(name, data)
    return dst


def _e590(fn, *args) -> str:
    from tmpc.lang.diagnostics import InputError
    with pytest.raises(InputError) as info:
        fn(*args)
    (d,) = info.value.diagnostics
    assert d.code == "E590", d
    return d.message


def test_a_zip_bomb_is_refused_before_it_is_decompressed(artifact, tmp_path, monkeypatch):
    """A member larger than the manifest says, or than the hard cap, stops the read at the cap:
    the 64 MiB of zeros below are never held in memory."""
    import hashlib

    import tmpc.compiler.artifact as A
    zeros = bytes(64 << 20)
    digest = hashlib.sha256(zeros).hexdigest()

    def declare(m, size):
        m["members"]["blobs/zeros.bin"] = digest
        if size is not None:
            m["sizes"]["blobs/zeros.bin"] = size
    lying = _rezip(artifact, tmp_path / "lying.tmpa", lambda m: declare(m, 1000),
                   [("blobs/zeros.bin", zeros)])
    assert "more than the 1000 the manifest records" in _e590(A.read_manifest, lying)
    monkeypatch.setattr(A, "MAX_MEMBER", 8 << 20)
    unsized = _rezip(artifact, tmp_path / "unsized.tmpa", lambda m: declare(m, None),
                     [("blobs/zeros.bin", zeros)])
    assert f"more than the {8 << 20} a member may have" in _e590(A.read_manifest, unsized)
    monkeypatch.setattr(A, "MAX_TOTAL", 1 << 10)
    assert "add up to more than" in _e590(A.read_manifest, artifact)


@pytest.mark.parametrize("edit, fragment", [
    (lambda m: m.update(members=7), "`members` is a number"),
    (lambda m: m.update(members=["src/run.toml"]), "`members` is a list"),
    (lambda m: m.pop("members"), "`members` is missing"),
    (lambda m: m.update(members={}), "no member src/run.toml"),
    (lambda m: m["members"].update({"../evil": "0" * 64}), "not a relative path"),
    (lambda m: m["members"].update({"src/run.toml": "xyz"}), "not a SHA-256"),
    (lambda m: m.update(sizes={"src/run.toml": -1}), "`sizes`"),
    (lambda m: m.update(bank=[]), "`bank` is a list"),
    (lambda m: m["bank"].update(kernels={"fk": "kernels/none.jaxexport"}), "`bank.kernels`"),
    (lambda m: m.update(format=3), "artifact format 3"),
])
def test_a_malformed_manifest_is_an_e590(artifact, tmp_path, edit, fragment):
    from tmpc.compiler.artifact import read_manifest
    bad = _rezip(artifact, tmp_path / "bad.tmpa", edit)
    assert fragment in _e590(read_manifest, bad)


def test_fuzzed_artifacts_give_e590_or_load(artifact, tmp_path, monkeypatch):
    """Random bit flips and truncations of a real artifact: reading and extracting it either
    works (the flip hit nothing that matters, e.g. a zip comment) or is an E590; never another
    exception (zlib errors from flipped bits were internal errors once)."""
    from tmpc.compiler.artifact import extract
    from tmpc.lang.diagnostics import InputError
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path / "cache"))
    data = artifact.read_bytes()
    rng = np.random.default_rng(5)
    outcomes = {"ok": 0, "E590": 0}
    bad = tmp_path / "fuzz.tmpa"
    for i in range(160):
        b = bytearray(data)
        if i % 4 == 3:
            b = b[:int(rng.integers(0, len(b)))]
        else:
            for _ in range(int(rng.integers(1, 4))):
                k = int(rng.integers(0, len(b)))
                b[k] ^= 1 << int(rng.integers(0, 8))
        bad.write_bytes(bytes(b))
        try:
            extract(bad)
            outcomes["ok"] += 1
        except InputError as exc:
            assert exc.diagnostics[0].code in ("E590",), exc.diagnostics[0]
            outcomes["E590"] += 1
    assert outcomes["E590"] > 100, outcomes


def test_export_reports_each_kernel_as_it_goes():
    """A first run compiles for 20-45 s: the export tells its progress kernel by kernel (L 3),
    with names a user reads (`projector pick`), i/n in order."""
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.export import kernel_label
    from tmpc.runtime.problem import register_run_kernels
    world = open_world(EXAMPLES / "tabletop" / "tabletop.toml")     # its own, not the fixture's
    compiled = compile_world(world)
    compiled.register_kernels(run_only=True)
    register_run_kernels(world, compiled)
    seen = []
    compiled.bank.export(lambda key, spec, make: b"stored",
                         lambda i, n, key: seen.append((i, n, kernel_label(key))))
    n = len(compiled.bank.keys)
    assert n > 5 and [(i, m) for i, m, _ in seen] == [(i, n) for i in range(1, n + 1)]
    labels = {label for _, _, label in seen}
    assert {"projector pick", "projector place", "condition resting", "kinematics"} <= labels
    assert kernel_label("proj/action/pick@16") == "projector pick"


def test_a_kernels_first_call_gives_the_heaps_free_pages_back(monkeypatch):
    """Loading an executable leaves freed buffers in glibc's heap: the bank trims after each
    kernel's first call (once per kernel, not on every call)."""
    from tmpc.compiler import bank as bank_mod
    from tmpc.compiler.jaxcfg import trim_heap

    trim_heap()                                  # callable where glibc is not, too
    trims = []
    monkeypatch.setattr(bank_mod, "trim_heap", lambda: trims.append(1))
    b = bank_mod.KernelBank()
    f = b.function("test/double", lambda: (lambda x: 2 * x), ((("b", 3), "float64"),))
    for _ in range(3):
        np.testing.assert_allclose(np.asarray(f(np.ones((4, 3)))), 2.0)
    assert len(trims) == 1


def test_exported_kernels_without_lapack_skip_its_set_up_and_one_with_it_still_runs(tmp_path):
    """A kernel whose serialized module names no LAPACK routine is lowered without JAX's LAPACK
    set-up (which imports scipy.linalg: ~0.1 s of a run's setup); a kernel that solves a linear
    system, called after it in the same process, gets the set-up and the right answer. Exported
    in one fresh interpreter, run in another, where nothing has imported scipy yet."""
    head = """
import base64, json, sys
import numpy as np
from tmpc.compiler.bank import KernelBank
from tmpc.compiler.jaxcfg import configured
jnp = configured().numpy
spec_plain = ((("b", 3), "float64"),)
spec_solve = (((3, 3), "float64"), ((3,), "float64"))
"""
    export = head + f"""
src = KernelBank()
src.function("plain", lambda: (lambda x: 2 * x), spec_plain)
src.function("solve", lambda: (lambda a, b: jnp.linalg.solve(a, b)), spec_solve)
exported, skipped = src.export()
assert not skipped, skipped
open({str(tmp_path / "k.json")!r}, "w").write(json.dumps(
    {{k: base64.b64encode(v).decode() for k, v in exported.items()}}))
"""
    run = head + f"""
exported = {{k: base64.b64decode(v) for k, v in
            json.load(open({str(tmp_path / "k.json")!r})).items()}}
bank = KernelBank(exported, source="test")
plain = bank.function("plain", None, spec_plain)
solve = bank.function("solve", None, spec_solve)
out = {{"plain": np.asarray(plain(np.ones((4, 3)))).tolist(),
       "scipy_after_plain": "scipy.linalg" in sys.modules}}
A, b = np.array([[4.0, 1, 0], [1, 3, 1], [0, 1, 2]]), np.array([1.0, 2, 3])
out["solve"] = np.asarray(solve(A, b)).tolist()
out["truth"] = np.linalg.solve(A, b).tolist()
out["traced"] = bank.stats.traced
print(json.dumps(out))
"""
    for code in (export, run):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=300)
        assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["plain"] == [[2.0] * 3] * 4
    assert out["scipy_after_plain"] is False
    np.testing.assert_allclose(out["solve"], out["truth"], rtol=1e-12)
    assert out["traced"] == 0
