"""Legacy Lua benchmark: a traced Lua predicate vs the same predicate written natively (both
compiled to kernels), and vs evaluating the Lua function directly with dual numbers.
Run with `pytest -m bench -s tests/bench/test_bench_lua.py`."""

from __future__ import annotations

import time

import numpy as np
import pytest

from tests.support import EXAMPLES, FIXTURES
from tmpc.compiler.compile import compile_world

pytestmark = pytest.mark.bench


def _rate(fn, n, repeat=3):
    fn()
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return n / best


def test_traced_lua_vs_native_vs_direct():
    from tmpc.compiler import ir
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.kernels import build_tables, condition_kernel, state_inputs
    from tmpc.compiler.lower import builtin
    from tmpc.compiler.lua_trace import LuaFallback, trace_module
    from tmpc.compiler.state import initial_state
    from tmpc.lang.lua import load_lua_predicates
    jax = configured()
    world = open_world(EXAMPLES / "tabletop" / "tabletop.toml")
    kw = build_tables(world.scene, compile_world(world).model, world.program.scope)
    module = load_lua_predicates(FIXTURES / "lua" / "planet_world.lua")
    traced = trace_module(module, {"close": 2}).traced["close"]
    pos = lambda i: builtin("position", [ir.Arg(i)])                    # noqa: E731
    native = builtin("<=", [builtin("distance", [pos(0), pos(1)]), ir.Const(0.25)])
    q, T, par = state_inputs(kw, initial_state(world.scene, compile_world(world).model))
    ids = np.array([kw.entity("panda_hand_tcp"), kw.entity("red_cube")])
    Q = np.random.default_rng(0).uniform(compile_world(world).model.lower, compile_world(world).model.upper,
                                         (4096, compile_world(world).model.dof))
    rates = {}
    for label, node in (("native", native), ("traced Lua", traced)):
        k = condition_kernel(node, kw)
        vg = jax.jit(jax.vmap(jax.value_and_grad(lambda q: k(q, T, par, ids)[1])))
        d_native = np.asarray(vg(Q)[0])
        rates[label] = (_rate(lambda: np.asarray(vg(Q)[0]), len(Q)), d_native)
    assert np.allclose(rates["native"][1], rates["traced Lua"][1], atol=1e-9)
    fb = LuaFallback(module, "close", ("object", "object"))
    fk = jax.jit(compile_world(world).fk)
    poses = []
    for qi in Q[:200]:
        f = fk(qi)
        hand = np.concatenate([np.asarray(f.p[compile_world(world).model.frame("panda_hand_tcp")]),
                               [0, 0, 0, 1]])
        poses.append(np.stack([hand, np.concatenate([T[2, :3, 3], [0, 0, 0, 1]])]))
    direct = _rate(lambda: [fb(p) for p in poses], len(poses))
    n, t = rates["native"][0], rates["traced Lua"][0]
    print("\n| `close` (distance <= 0.25) on the Panda, value + gradient | states/s | vs native |"
          "\n|---|---|---|"
          f"\n| native tmpc predicate, batched kernel | {n:,.0f} | 1.00 |"
          f"\n| traced Lua (planet style), batched kernel | {t:,.0f} | {t / n:.2f} |"
          f"\n| direct Lua evaluation with dual numbers (per state) | {direct:,.0f} | "
          f"{direct / n:.4f} |")
