"""The artifact is what runs (issue G): a run, a sample and an evaluation from a compiled artifact
lower no IR and trace no kernel; `tmpc run CONFIG` compiles into the artifact cache once, and the
next run of the same sources compiles nothing; a damaged or foreign cache entry is rebuilt with a
warning."""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
TABLETOP = ROOT / "examples" / "tabletop"


class _NoLowering:
    """Stands in for the IR lowerer and the Lua tracer: any call fails the test."""

    def __init__(self, *a, **k):
        raise AssertionError("IR lowering was called")


def _no_urdf_parse(*a, **k):
    raise AssertionError("a URDF was parsed")


def _forbid_lowering(monkeypatch):
    import tmpc.compiler.compile as c
    monkeypatch.setattr(c, "Lowerer", _NoLowering)
    monkeypatch.setattr(c, "trace_module", _NoLowering)
    monkeypatch.setattr(c, "condition_kernel", _NoLowering)
    monkeypatch.setattr(c, "projector_fn", _NoLowering)


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory, aot_folder):
    """A cache of tmpc's own parts that has seen nothing (no run artifact, no robot), sharing
    XLA's executables with the default cache (what is compiled there is JAX's business, not the
    artifact's), its exported kernels (the export cache, keyed by sources, kernel, tmpc's
    code and JAX: a compile here still builds and writes the run's artifact; exporting every
    kernel afresh is test_the_same_sources_compile_to_the_same_bytes's, with a cache of its
    own) and the collision pass built ahead of time (machine code, never in an artifact; else
    a run here starts its numba build in a child process nobody waits for)."""
    from tmpc.compiler.cache import cache_root
    d = tmp_path_factory.mktemp("tmpc-cache")
    for part in ("jax", "exports"):
        (cache_root() / part).mkdir(parents=True, exist_ok=True)
        (d / part).symlink_to(cache_root() / part)
    (d / "aot").symlink_to(aot_folder)
    return d


@pytest.fixture(scope="module")
def artifact(tmp_path_factory, cache_dir):
    """The tabletop example compiled, its sources deleted."""
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.export import build_artifact
    d = tmp_path_factory.mktemp("art")
    shutil.copytree(TABLETOP, d / "src")
    out = d / "tabletop.tmpa"
    build_artifact(open_world(d / "src" / "tabletop.toml"), out)
    shutil.rmtree(d / "src")
    return out


def test_plan_sample_and_eval_from_the_artifact_lower_nothing(artifact, monkeypatch):
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.compile import compile_world
    from tmpc.compiler.state import initial_state
    from tmpc.lang.source import SourceFile
    from tmpc.runtime.plans import parse_plan, plan_document
    from tmpc.runtime.probe import predicate_at, sample_states
    from tmpc.runtime.solve import plan_problem
    from tmpc.runtime.validate import validate_plan
    _forbid_lowering(monkeypatch)
    world = open_world(artifact)
    problem, result, _ = plan_problem(world, seed=0, time_limit=60.0)
    assert result.status == "solved"
    compiled = compile_world(world)
    assert problem.setup["traced"] == [] and compiled.bank.stats.deserialized > 0
    doc = plan_document(problem, result, planner="unified", seed=0, input_path=str(artifact),
                        setup_seconds=0.0)
    assert validate_plan(world, parse_plan(SourceFile("<p>", json.dumps(doc)))).valid

    # sample: the predicate's projector, from the artifact
    s0 = initial_state(world.scene, compiled.model)
    f = compiled.predicate("reach")
    obj = next(o.name for o in world.scene.objects if o.movable)
    ids = compiled.bind_args(f, ["panda_hand_tcp", obj])
    got = sample_states(compiled, f, ids, s0, 3, np.random.default_rng(0), 30, 4096)
    assert len(got.found) == 3
    # eval: truth, distance and gradient of the same predicate
    out = predicate_at(compiled, s0, ["reach", "panda_hand_tcp", obj])
    assert out["distance"] >= 0 and len(out["gradient"]) == compiled.model.dof
    assert compiled.bank.stats.traced == 0, compiled.bank.stats.traced_keys


def test_a_run_from_the_cache_compiles_nothing(cache_dir, monkeypatch, tmp_path):
    from tmpc.runtime.solve import open_input, plan_problem
    monkeypatch.setenv("TMPC_CACHE_DIR", str(cache_dir))
    src = tmp_path / "tabletop"
    shutil.copytree(TABLETOP, src)
    world, split = open_input(src / "tabletop.toml")
    assert split["kernels"] == "compiled"
    _forbid_lowering(monkeypatch)
    # nor is the URDF parsed again (the cache keeps the tree; yourdfpy is not even imported)
    import tmpc.compiler.cache as cache
    monkeypatch.setattr(cache, "load_urdf", _no_urdf_parse)
    world, split = open_input(src / "tabletop.toml")
    assert split["kernels"] == "cache"
    # the run's batch sizes are exported concretely (no symbolic-shape refinement when loaded);
    # the collision checker's kinematics is its own compiled loop, not an exported kernel
    kernels = world.artifact[1]["bank"]["kernels"]
    assert "proj/action/pick@16" in kernels and not any(k.startswith("fk/frames@")
                                                         for k in kernels)
    problem, result, _ = plan_problem(world, seed=1, time_limit=60.0)
    assert result.status == "solved" and problem.setup["traced"] == []
    # a comment is no change of meaning: the same artifact (issue S)
    monkeypatch.undo()
    monkeypatch.setenv("TMPC_CACHE_DIR", str(cache_dir))
    problem_file = src / "problem.pddl"
    problem_file.write_text(problem_file.read_text() + "\n; changed\n")
    _, split = open_input(src / "tabletop.toml")
    assert split["kernels"] == "cache"
    # a changed meaning is a different key: compiled anew, not the stale artifact (a compile
    # after a key the cache lacks: test_a_damaged_cache_entry_is_rebuilt_with_a_warning)
    from tmpc.compiler.cache import run_artifact, source_key
    from tmpc.compiler.kernels import Options
    from tmpc.lang.inputs import load_world
    key = source_key(load_world(src / "tabletop.toml"), Options())
    problem_file.write_text(problem_file.read_text().replace("(on red_cube tray)",
                                                             "(on red_cube bench)"))
    changed = source_key(load_world(src / "tabletop.toml"), Options())
    assert changed != key and run_artifact(key).exists()
    assert not run_artifact(changed).exists()


def test_a_damaged_cache_entry_is_rebuilt_with_a_warning(cache_dir, monkeypatch, tmp_path):
    from tmpc.compiler.cache import run_artifact, source_key
    from tmpc.compiler.kernels import Options
    from tmpc.lang.inputs import load_world
    from tmpc.runtime.solve import open_input
    monkeypatch.setenv("TMPC_CACHE_DIR", str(cache_dir))
    src = tmp_path / "tabletop"
    shutil.copytree(TABLETOP, src)
    open_input(src / "tabletop.toml")
    art = run_artifact(source_key(load_world(src / "tabletop.toml"), Options()))
    data = bytearray(art.read_bytes())
    data[len(data) // 2] ^= 0xFF
    art.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="damaged"):
        _, split = open_input(src / "tabletop.toml")
    assert split["kernels"] == "compiled"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, split = open_input(src / "tabletop.toml")
    assert split["kernels"] == "cache"


def test_kernels_of_another_jax_are_traced_with_a_warning(artifact, tmp_path):
    from tmpc.compiler.artifact import load_bank, read_manifest
    manifest, z = read_manifest(artifact)
    manifest = dict(manifest, jax="0.0.1")
    with pytest.warns(UserWarning, match="JAX 0.0.1"):
        bank = load_bank(artifact, manifest)
    assert not bank.has_exported("fk")
    z.close()


def test_the_same_sources_compile_to_the_same_bytes(artifact, tmp_path, monkeypatch,
                                                   aot_folder):
    """A compile with a cache of its own (nothing shared but the sources, read from another
    directory) gives the module's artifact byte for byte: no timestamps, no paths, a fixed
    member order, deterministic exports. (Its cache links the user cache's aot/ folder: the
    collision pass's machine code, never part of an artifact; without it the compile starts a
    numba build of the pass in a child process that outlives the test.)"""
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.export import build_artifact
    (tmp_path / "cache").mkdir()
    (tmp_path / "cache" / "aot").symlink_to(aot_folder)
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "t.tmpa"
    build_artifact(open_world(TABLETOP / "tabletop.toml"), out)
    assert out.read_bytes() == artifact.read_bytes()
    # nor where tmpc is installed, nor who called it (the exports' source locations)
    import zipfile
    with zipfile.ZipFile(out) as z:
        for name in z.namelist():
            data = z.read(name)
            assert str(ROOT).encode() not in data and b"pytest" not in data, name


@pytest.mark.slow
def test_a_warm_run_imports_no_urdf_or_mesh_library(artifact, tmp_path):
    """Planning from an artifact whose robot and meshes the cache has seen parses no URDF and
    loads no mesh file: yourdfpy, trimesh and scipy.spatial (~0.7 s of imports) stay out."""
    import os
    import subprocess
    import sys
    code = ("import sys\n"
            "from tmpc.compiler.artifact import open_world\n"
            "from tmpc.runtime.solve import plan_problem\n"
            f"_, result, _ = plan_problem(open_world({str(artifact)!r}), seed=0, time_limit=60)\n"
            "assert result.status == 'solved'\n"
            "print(sorted(m for m in ('yourdfpy', 'trimesh', 'scipy.spatial') "
            "if m in sys.modules))\n")
    from tmpc.compiler.cache import cache_root
    (tmp_path / "cache").mkdir()
    # a cache that has seen nothing of this robot, but shares XLA's executables (no recompile)
    (cache_root() / "jax").mkdir(parents=True, exist_ok=True)
    (tmp_path / "cache" / "jax").symlink_to(cache_root() / "jax")
    env = {**os.environ, "TMPC_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, timeout=600) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), runs[-1].stderr
    assert "yourdfpy" in runs[0].stdout            # the first run parsed the robot
    assert runs[1].stdout.strip() == "[]", runs[1].stdout
