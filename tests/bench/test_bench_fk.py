"""Forward-kinematics benchmark: batched (vmapped, one XLA call) vs one jitted call per config.

Run with `pytest -m bench -s tests/bench/test_bench_fk.py`; prints a table, asserts behaviour only.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from tmpc.lang.world import RobotSpec, load_urdf

pytestmark = pytest.mark.bench

ROBOTS = {
    "PR2 (mobile base, 23 dof, 82 frames)":
        ("package://example-robot-data/robots/pr2_description/urdf/pr2.urdf", True),
    "Panda (9 dof, 13 frames)":
        ("package://example-robot-data/robots/panda_description/urdf/panda.urdf", False),
}


def _rate(fn, arg, n_configs: int, repeat: int) -> float:
    fn(arg)  # warm (compile)
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn(arg)
        getattr(out, "R", out).block_until_ready()
        best = min(best, time.perf_counter() - t)
    return n_configs / best


def test_fk_batched_vs_per_call():
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.robot import build_robot_model, make_fk
    jax = configured()
    rows = []
    for label, (uri, mobile) in ROBOTS.items():
        tree = load_urdf(uri)
        model = build_robot_model(tree, RobotSpec(urdf=tree.path, mobile_base=mobile))
        fk = jax.jit(make_fk(model))
        Q = np.random.default_rng(0).uniform(model.lower, model.upper, (4096, model.dof))
        batched = _rate(fk, Q, len(Q), 5)

        def per_call(qs):
            for q in qs:
                out = fk(q)
            return out

        single = _rate(per_call, Q[:200], 200, 3)
        grad = jax.jit(jax.vmap(jax.grad(lambda q: make_fk(model)(q).p.sum())))
        grads = _rate(grad, Q, len(Q), 3)
        assert np.isfinite(np.asarray(grad(Q[:8]))).all()
        rows.append((label, batched, single, grads))
    print("\n| robot | batched FK (configs/s) | per-call FK (configs/s) | ratio | batched "
          "gradient of all frame positions (configs/s) |\n|---|---|---|---|---|")
    for label, b, s, g in rows:
        print(f"| {label} | {b:,.0f} | {s:,.0f} | {b / s:.0f}x | {g:,.0f} |")
