"""Setup and end-to-end time of `tmpc run` (issue G), measured in one session.

For each bundled example: a run with an empty cache (XLA's included: everything compiled), a
second run of the same configuration (the artifact cache hit: nothing traced), and a run of a
compiled artifact file; `-v`'s setup split, process wall time and peak RSS of each. Then motion
checking on the PR2 clutter scene: straight motions through the batched first pass against the
same states checked one by one with exact fcl. Ratios are within this run.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.bench

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ["clutter/clutter.toml", "tabletop/tabletop.toml", "planet-sort/sort.toml"]


def _run(args, env) -> tuple[float, float, str]:
    """(process wall s, peak RSS MiB, stderr) of one `tmpc` process."""
    t = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "tmpc.runtime.cli", *map(str, args)], env=env,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    err = p.stderr.read()
    _, status, usage = os.wait4(p.pid, 0)        # this process's own peak RSS
    wall = time.perf_counter() - t
    p.returncode = os.waitstatus_to_exitcode(status)
    assert p.returncode == 0, err
    return wall, usage.ru_maxrss / 1024, err


def _split(stderr: str) -> dict[str, float]:
    line = next(l for l in stderr.splitlines() if l.startswith("setup: "))
    return {k: float(v) for k, v in re.findall(r"([a-z-]+(?: compile)?) ([0-9.]+) s", line)}


def test_setup_cold_warm_and_from_an_artifact(tmp_path):
    rows = []
    for ex in EXAMPLES:
        cfg = ROOT / "examples" / ex
        env = dict(os.environ, TMPC_CACHE_DIR=str(tmp_path / ex.split("/")[0]))
        out = tmp_path / "plan.json"
        cases = [("cold (empty caches)", ["run", cfg, "-q", "-v", "-o", out]),
                 ("warm (artifact cache hit)", ["run", cfg, "-q", "-v", "-o", out])]
        art = tmp_path / f"{ex.split('/')[0]}.tmpa"
        for label, args in cases:
            wall, rss, err = _run(args, env)
            rows.append((ex, label, wall, rss, _split(err)))
        _run(["compile", cfg, "-o", art], env)
        wall, rss, err = _run(["run", art, "-q", "-v", "-o", out], env)
        rows.append((ex, "artifact file", wall, rss, _split(err)))
        assert "traced this run: 0" in err
    print("\n| example | run | process wall s | setup s (load + problem + first calls) | "
          "imports s | first-call compile s | planning s | peak RSS MiB |\n"
          "|---|---|---|---|---|---|---|---|")
    for ex, label, wall, rss, sp in rows:
        setup = sum(sp.get(k, 0.0) for k in ("load", "compile", "problem", "deserialize",
                                             "first-call compile"))
        print(f"| {ex.split('/')[0]} | {label} | {wall:.2f} | {setup:.2f} | "
              f"{sp.get('imports', 0):.2f} | {sp.get('first-call compile', 0):.2f} | "
              f"{sp.get('planning', 0):.2f} | {rss:.0f} |")


def test_motion_checks_batched_vs_per_state():
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.compile import compile_world
    from tmpc.compiler.state import initial_state
    from tmpc.runtime.collision import CollisionWorld, collision_world
    world = open_world(ROOT / "examples" / "clutter" / "clutter.toml")
    compiled = compile_world(world)
    fast = collision_world(world, compiled)
    exact = CollisionWorld(world.scene, fast.model, compiled.fk_frames, first_pass=False,
                           allowed=world.allowed_pairs())
    model = compiled.model
    s0 = initial_state(world.scene, model)
    rng = np.random.default_rng(0)
    A = np.clip(s0.q + rng.normal(size=(300, model.dof)) * 0.3, model.lower, model.upper)
    B = np.clip(A + rng.normal(size=A.shape) * 0.3, model.lower, model.upper)
    free = fast.check_batch(A, poses=s0.poses)
    A, B = A[free][:150], B[free][:150]
    motions = [fast.interpolate(a, b, 0.02) for a, b in zip(A, B)]
    states = sum(len(m) for m in motions)
    for a, b in zip(A[:4], B[:4]):                   # compile the batch shapes first
        fast.check_motion(a, b, 0.02, poses=s0.poses, details=False)
    t = time.perf_counter()
    got = [fast.check_motion(a, b, 0.02, poses=s0.poses, details=False).valid
           for a, b in zip(A, B)]
    batched = time.perf_counter() - t
    t = time.perf_counter()
    want = [all(exact.check(q, poses=s0.poses).valid for q in m) for m in motions[:40]]
    per_state = (time.perf_counter() - t) / sum(len(m) for m in motions[:40])
    assert got[:40] == want
    print(f"\n| motion checks, PR2 clutter ({len(A)} motions, {states} states at 0.02) | "
          f"states/s |\n|---|---|\n"
          f"| batched first pass + fcl on candidates (`check_motion`) | "
          f"{states / batched:,.0f} |\n"
          f"| exact fcl, one state at a time | {1 / per_state:,.0f} |\n"
          f"| ratio | {states / batched * per_state:.1f}x |")
