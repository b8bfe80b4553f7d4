"""Lua predicates tracing cannot capture are called from kernels (a `lua` IR node: the LuaFallback
on the host through jax.pure_callback, gradients by its dual numbers via custom_jvp)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from tests.support import EXAMPLES
from tmpc.compiler.compile import compile_world


@pytest.fixture(scope="module")
def sort(untraceable_sort):
    """planet-sort with `at` made untraceable (a branch on the state, tests/compiler/conftest.py),
    and the original."""
    from tmpc.compiler.compile import CompiledProgram, external_predicates
    from tmpc.compiler.kernels import state_inputs
    from tmpc.compiler.state import initial_state
    world, fb = untraceable_sort.world, untraceable_sort.fallback
    traced = CompiledProgram(world.program, world.scene, compile_world(world).model,
                             external=external_predicates(str(EXAMPLES / "planet-sort" /
                                                              "sort.lua"), world.program))
    q0, T, par = state_inputs(fb.tables, initial_state(world.scene, compile_world(world).model))
    return world, fb, traced, (q0, T, par)


def _direct(sort, q, T, par, args):
    """The fallback evaluated directly at the arguments' poses (from a value kernel)."""
    from tmpc.compiler import ir
    from tmpc.compiler.kernels.emit import value_kernel
    world, fb, _, _ = sort
    poses = []
    for i in range(len(args)):
        pose = ir.op("pose", (ir.Arg(i),), ir.TRANSFORM)
        for part in ("position", "orientation"):
            node = ir.op(part, (pose,), ir.VEC3 if part == "position" else ir.QUAT)
            poses.append(np.asarray(value_kernel(node, fb.tables)(q, T, par, args)))
    poses = np.concatenate(poses).reshape(len(args), 7)
    w = fb.tables
    sup = [None if np.isnan(w.support_local[e]).any() else w.support_local[e] for e in args]
    return fb.external["at"].fallback(poses, sup, [w.names[e] for e in args])[0], poses


def test_untraceable_predicate_is_a_lua_node(sort):
    from tmpc.compiler import ir
    _, fb, traced, _ = sort
    assert ir.show(fb.predicate("at").body) == "(lua 'at' $arg0 $arg1)"
    assert "(lua 'at' $arg" in ir.show(fb.action("pickup").body)      # bound into actions
    assert fb.predicate("above").body == traced.predicate("above").body   # traced ones unchanged


def test_kernel_equals_fallback_and_traced_original(sort):
    from tmpc.compiler.jaxcfg import configured
    jax = configured()
    world, fb, traced, (q0, T, par) = sort
    f, fo = fb.predicate("at"), traced.predicate("at")
    kernel, kt = fb.kernels(f)[0], traced.kernels(fo)[0]
    rng = np.random.default_rng(3)
    lo, hi = np.asarray(compile_world(world).model.lower), np.asarray(compile_world(world).model.upper)
    Q = rng.uniform(lo, hi, (12, len(lo)))
    for block in ("redblock", "greenblock"):
        args = fb.bind_args(f, ["panda_hand_tcp", block])
        truth, dist = jax.vmap(kernel, in_axes=(0, None, None, None))(Q, T, par, args)
        t_o, d_o = jax.vmap(kt, in_axes=(0, None, None, None))(Q, T, par, args)
        for q, t, d, to, do in zip(Q, truth, dist, t_o, d_o):
            expected, poses = _direct(sort, q, T, par, args)
            assert float(d) == pytest.approx(expected, abs=1e-12)
            assert bool(t) == (expected <= fb.options.tol)
            if poses[0, 2] <= 2.0:                       # the inserted branch not taken
                assert float(d) == pytest.approx(float(do), abs=1e-9) and bool(t) == bool(to)
    # the branch taken: a "manipulator" argument above 2 m (the kernel is lifted: any entity)
    args = np.array([world_id(fb, "redblock"), world_id(fb, "greenblock")])
    k = list(world.scene.objects).index(next(o for o in world.scene.objects
                                              if o.name.lower() == "redblock"))
    T2 = np.array(T)
    T2[k, 2, 3], par2 = 2.5, np.array(par)
    par2[k] = -1
    truth, d = kernel(q0, T2, par2, args)
    expected, poses = _direct(sort, q0, T2, par2, args)
    assert poses[0, 2] == pytest.approx(2.5) and not bool(truth)
    assert float(d) == pytest.approx(expected) and expected > 0


def world_id(fb, name):
    return fb.tables.entity(name)


def test_gradient_matches_finite_differences_and_traced(sort):
    from tmpc.compiler.jaxcfg import configured
    jax = configured()
    world, fb, traced, (q0, T, par) = sort
    f = fb.predicate("at")
    kernel, kt = fb.kernels(f)[0], traced.kernels(traced.predicate("at"))[0]
    args = fb.bind_args(f, ["panda_hand_tcp", "redblock"])
    dist = lambda q: kernel(q, T, par, args)[1]          # noqa: E731
    grad = jax.grad(dist)
    grad_t = jax.grad(lambda q: kt(q, T, par, args)[1])
    rng = np.random.default_rng(5)
    lo, hi = np.asarray(compile_world(world).model.lower), np.asarray(compile_world(world).model.upper)
    for q in rng.uniform(lo, hi, (3, len(lo))):
        g = np.asarray(grad(q))
        assert np.abs(g).max() > 0
        np.testing.assert_allclose(g, np.asarray(grad_t(q)), atol=1e-9)
        h, fd = 1e-6, np.zeros_like(q)
        for i in range(len(q)):
            e = np.zeros_like(q)
            e[i] = h
            fd[i] = (float(dist(q + e)) - float(dist(q - e))) / (2 * h)
        np.testing.assert_allclose(g, fd, atol=1e-5)


def test_projection_reaches_states_where_it_holds(sort):
    from tmpc.compiler.kernels import make_projector, uniform_starts
    world, fb, _, (q0, T, par) = sort
    f = fb.predicate("at")
    kernel = fb.kernels(f)[0]
    args = fb.bind_args(f, ["panda_hand_tcp", "redblock"])
    lo, hi = np.asarray(compile_world(world).model.lower), np.asarray(compile_world(world).model.upper)
    project = make_projector(kernel, lo, hi, iterations=30)
    Q0 = uniform_starts(np.random.default_rng(7), lo, hi, 24)
    Q, holds, d = (np.asarray(x) for x in project(Q0, T, par, args))
    assert holds.sum() >= 3, d
    for q in Q[holds]:
        assert _direct(sort, q, T, par, args)[0] <= fb.options.tol


def test_artifact_skips_lua_kernels(sort, tmp_path):
    from tmpc.compiler.artifact import load_bank
    from tmpc.compiler.export import build_artifact
    world = sort[0]
    manifest = build_artifact(world, tmp_path / "ps.tmpa")
    kernels, skipped = manifest["bank"]["kernels"], manifest["bank"]["skipped"]
    # `at` calls its Lua function on the host: jax.export cannot serialize that
    assert kernels["cond/predicate/at"] is None and "Lua" in skipped["cond/predicate/at"]
    assert kernels["cond/predicate/above"]
    loaded = load_bank(tmp_path / "ps.tmpa", manifest)
    assert loaded.has_exported("cond/predicate/above")
    assert not loaded.has_exported("cond/predicate/at")


def test_throughput_fallback_vs_traced(sort, capsys):
    """Batched states/s of the fallback kernel against the traced one (printed; docs/lua.md)."""
    from tmpc.compiler.jaxcfg import configured
    jax = configured()
    world, fb, traced, (q0, T, par) = sort
    f = fb.predicate("at")
    args = fb.bind_args(f, ["panda_hand_tcp", "redblock"])
    lo, hi = np.asarray(compile_world(world).model.lower), np.asarray(compile_world(world).model.upper)
    Q = np.random.default_rng(9).uniform(lo, hi, (2000, len(lo)))
    rates = {}
    for label, prog in (("fallback", fb), ("traced", traced)):
        kernel = prog.kernels(prog.predicate("at"))[0]
        run = jax.jit(jax.vmap(kernel, in_axes=(0, None, None, None)))
        jax.block_until_ready(run(Q, T, par, args))
        t = time.perf_counter()
        jax.block_until_ready(run(Q, T, par, args))
        rates[label] = len(Q) / (time.perf_counter() - t)
    with capsys.disabled():
        print(f"\nat over 2000 states: fallback {rates['fallback']:.0f} states/s, "
              f"traced {rates['traced']:.0f} states/s")
    assert rates["fallback"] > 100
