"""Compiler benchmarks: kernel throughput (batched vs single calls), projection, compile time,
memory and artifact size. Run with `pytest -m bench -s tests/bench/test_bench_compiler.py`."""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.support import EXAMPLES
from tmpc.compiler.compile import compile_world

pytestmark = pytest.mark.bench


def _world(tmp_path, n=14, red=True):
    from tmpc.lang.world.generate import clutter_problem, clutter_scene
    d = tmp_path / f"clutter{n}"
    d.mkdir(exist_ok=True)
    (d / "domain.pddl").write_text((EXAMPLES / "clutter" / "domain.pddl").read_text())
    (d / "problem.pddl").write_text(clutter_problem(n, red))
    (d / "scene.json").write_text(json.dumps(clutter_scene(n, red)))
    (d / "run.toml").write_text('[problem]\ndomain = "domain.pddl"\nproblem = "problem.pddl"\n'
                                'scene = "scene.json"\n')
    return d / "run.toml"


def _per_state(fn, arg, n, repeat=3):
    out = fn(arg)
    np.asarray(out[0] if isinstance(out, tuple) else out)
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn(arg)
        np.asarray(out[0] if isinstance(out, tuple) else out)
        best = min(best, time.perf_counter() - t)
    return n / best


def test_kernel_throughput_and_projection(tmp_path):
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.kernels import make_projector, state_inputs, uniform_starts
    from tmpc.compiler.state import initial_state
    jax = configured()
    w = open_world(_world(tmp_path, 1, False))
    cp = compile_world(w)
    q, T, par = state_inputs(cp.tables, initial_state(w.scene, compile_world(w).model))
    Q = np.random.default_rng(0).uniform(compile_world(w).model.lower, compile_world(w).model.upper, (4096, compile_world(w).model.dof))
    rows = []
    for label, name, args in [("PR2 gripper `at` (FK)", "at", ["r_gripper_tool_frame",
                                                               "blue_stick_1"]),
                              ("PR2 left gripper `at` (FK)", "at", ["l_gripper_tool_frame",
                                                                    "blue_stick_1"])]:
        f = cp.predicate(name)
        k, _ = cp.kernels(f)
        ids = cp.bind_args(f, args)
        vg = jax.value_and_grad(lambda q: k(q, T, par, ids)[1])
        batched = _per_state(jax.jit(jax.vmap(vg)), Q, len(Q))
        single_fn = jax.jit(vg)
        single = _per_state(lambda Qs: [single_fn(x) for x in Qs][-1], Q[:200], 200)
        proj = []
        for iters in (10, 30):
            P = make_projector(k, compile_world(w).model.lower, compile_world(w).model.upper, iterations=iters)
            Q0 = uniform_starts(np.random.default_rng(1), compile_world(w).model.lower, compile_world(w).model.upper, 4096)
            P(Q0, T, par, ids)
            t = time.perf_counter()
            _, holds, _ = P(Q0, T, par, ids)
            holds = np.asarray(holds)
            dt = time.perf_counter() - t
            proj.append((iters, holds.mean(), holds.sum() / dt))
        rows.append((label, batched, single, proj))
    print("\n| predicate | distance+gradient batched (states/s) | single calls (states/s) | ratio "
          "| projection 10 it: converged, accepted/s | 30 it: converged, accepted/s |")
    print("|---|---|---|---|---|---|")
    for label, b, s, proj in rows:
        (i1, c1, a1), (i2, c2, a2) = proj
        print(f"| {label} | {b:,.0f} | {s:,.0f} | {b / s:.0f}x | {c1:.0%}, {a1:,.0f} | "
              f"{c2:.0%}, {a2:,.0f} |")


def test_compile_time_memory_and_artifact_size(tmp_path):
    run = _world(tmp_path, 14, True)
    env = dict(os.environ, TMPC_CACHE_DIR=str(tmp_path / "cache"))
    times = []
    for label in ("cold (empty JAX cache)", "warm (persistent cache)"):
        out = tmp_path / "c.tmpa"
        t = time.perf_counter()
        r = subprocess.run([sys.executable, "-c",
                            "import resource, sys; from tmpc.runtime.cli.main import main; "
                            f"rc = main(['compile', {str(run)!r}, '-o', {str(out)!r}]); "
                            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); "
                            "sys.exit(rc)"], capture_output=True, text=True, env=env)
        dt = time.perf_counter() - t
        assert r.returncode == 0, r.stderr
        times.append((label, dt, int(r.stdout.split()[-1]) / 1024, out.stat().st_size / 1e6))
    print("\n| 14-stick clutter + 14 red | process time | peak RSS | artifact |\n|---|---|---|---|")
    for label, dt, rss, size in times:
        print(f"| compile, {label} | {dt:.1f} s | {rss:,.0f} MiB | {size:.2f} MB |")
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss > 0
