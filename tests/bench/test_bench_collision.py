"""Collision benchmark: PR2 with a mobile base in a clutter-like scene.

Run with `pytest -m bench -s tests/bench/test_bench_collision.py`. Reports a markdown table of
exact fcl state checks/s, the batched path (sphere first pass + fcl on its candidate pairs), the
share of states the pass settles, where the time goes, and motion validation cost per metre of
joint-space path. Asserts only behaviour (the batched path equals exact fcl), never wall-clock.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from tmpc.lang.world import load_urdf
from tmpc.lang.world.scene import Pose, RobotSpec, Scene, SceneObject, Shape

pytestmark = pytest.mark.bench

PR2 = "package://example-robot-data/robots/pr2_description/urdf/pr2.urdf"
N_STATES = 16384


def clutter(spec: RobotSpec) -> Scene:
    """4 tables (1.5 x 0.7 x 0.75 m) with centers 2 m around the robot, 20 sticks (0.04 x 0.04 x
    0.3 m, movable) standing on them."""
    rng = np.random.default_rng(0)
    objs = []
    for k in range(4):
        a = k * math.pi / 2
        c = np.array([2.0 * math.cos(a), 2.0 * math.sin(a)])
        objs.append(SceneObject(f"table{k}", Pose.from_xyz_yaw(c[0], c[1], 0.375, a + math.pi / 2),
                                shape=Shape("box", size=(0.75, 0.35, 0.375))))
        along = np.array([-math.sin(a), math.cos(a)])
        for i in range(5):
            xy = c + along * (-0.6 + 0.3 * i + rng.uniform(-0.1, 0.1)) + \
                np.array([math.cos(a), math.sin(a)]) * rng.uniform(-0.25, 0.25)
            objs.append(SceneObject(f"stick{5 * k + i}", Pose((xy[0], xy[1], 0.9)), True,
                                    Shape("box", size=(0.02, 0.02, 0.15))))
    return Scene("clutter", ((-2.0, 2.0), (-2.0, 2.0), (0.0, 2.0)), spec, tuple(objs))


def _rate(fn, n: int, repeat: int = 3) -> float:
    best = math.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return n / best


def test_pr2_clutter_collision_throughput():
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.robot import build_robot_model, make_fk_frames
    from tmpc.runtime.collision.world import CHUNK, CollisionWorld, PassStats

    tree = load_urdf(PR2)
    spec = RobotSpec(urdf=tree.path, mobile_base=True)
    model = build_robot_model(tree, spec, bounds=((-2, 2), (-2, 2), (0, 2)))
    sc = clutter(spec)
    fast = CollisionWorld(sc, model)
    exact = CollisionWorld(sc, model, first_pass=False)
    rng = np.random.default_rng(1)
    Q = rng.uniform(model.lower, model.upper, (N_STATES, model.dof))
    Q[:, :2] = rng.uniform(-1.3, 1.3, (N_STATES, 2))      # base between the tables

    # exact fcl, state by state (FK batched, fcl broadphase + narrowphase, stop at first hit)
    n_exact = 2048
    truth = exact.check_batch(Q[:n_exact])
    exact_rate = _rate(lambda: exact.check_batch(Q[:n_exact]), n_exact)
    report_rate = _rate(lambda: [exact.check(q) for q in Q[:256]], 256, repeat=1)

    # batched: sphere pass + exact fcl on its candidate pairs
    fast.check_batch(Q[:4096])                            # compile
    assert (fast.check_batch(Q[:n_exact]) == truth).all()
    fast.stats = PassStats()
    valid = fast.check_batch(Q)
    st = fast.stats
    batch_rate = _rate(lambda: fast.check_batch(Q), N_STATES)

    # where the time goes (per chunk of CHUNK states, as check_batch runs them)
    fp = fast.first_pass()
    place, allowed = fast.placements()
    plan = fp.plan(place, allowed)
    chunk = Q[:CHUNK]
    t_fk = CHUNK / _rate(lambda: fast.kinematics(chunk), CHUNK, 7)
    # the kinematics' cost per state against the batch size (why CHUNK is what it is), the
    # compiled loop the checker runs and the artifact's JAX kernel (what it ran before)
    jax_fk = configured().jit(make_fk_frames(model))
    fk_curve, jax_curve = {}, {}
    for n in (16, 128, 1024):
        fk_curve[n] = 1e6 / _rate(lambda n=n: fast.kinematics(Q[:n]), n, 7)
        jax_fk(Q[:n])[0].block_until_ready()                          # compile this size
        jax_curve[n] = 1e6 / _rate(lambda n=n: jax_fk(Q[:n])[0].block_until_ready(), n, 7)
    t_pass = CHUNK / _rate(lambda: fp.candidates(chunk, plan), CHUNK, 7)
    cand = fp.candidates(chunk, plan)
    t_conf = CHUNK / _rate(lambda: fast.batch.confirm(cand, plan, False), CHUNK, 7)

    # one state a call, as OMPL's planners ask (per call: the pair tables, the pass, fcl)
    one = Q[valid][:300]
    assert all(fast.check_batch(q[None])[0] for q in one[:20])
    t_one = 1e6 / _rate(lambda: [fast.check_batch(q[None]) for q in one], len(one), 5)

    # motion validation: straight motions from free states, 0.02 rad/m per step
    free = Q[valid][:200]
    goal = free + rng.normal(size=free.shape) * 0.15
    goal = np.clip(goal, model.lower, model.upper)
    length = float(np.linalg.norm(goal - free, axis=1).sum())
    t = time.perf_counter()
    motions = [fast.check_motion(a, b) for a, b in zip(free, goal)]
    motion_time = time.perf_counter() - t
    steps = sum(m.steps for m in motions)
    assert any(m.valid for m in motions) and any(not m.valid for m in motions)

    us = 1e6 / CHUNK
    print(f"\n| measure (PR2, 23 dof, mobile base; 4 tables + 20 sticks) | value |\n|---|---|\n"
          f"| random states (base in ±1.3 m, joints uniform) | {N_STATES} |\n"
          f"| states in collision | {(~valid).mean():.1%} |\n"
          f"| exact fcl, `check_batch(first_pass=False)` | {exact_rate:,.0f} states/s |\n"
          f"| exact fcl, `check(q)` with every pair named | {report_rate:,.0f} states/s |\n"
          f"| batched: sphere pass + fcl on candidates | {batch_rate:,.0f} states/s |\n"
          f"| ratio batched / exact | {batch_rate / exact_rate:.1f}x |\n"
          f"| states settled by the pass alone (free, no fcl call) | "
          f"{st.settled / st.states:.1%} |\n"
          f"| pairs per state: after balls, boxes, tables / covers / hulls (to fcl) | "
          f"{st.coarse_pairs / st.states:.1f} / {st.cover_pairs / st.states:.1f} / "
          f"{st.fine_pairs / st.states:.1f} |\n"
          f"| colliding states found with no fcl query (a hull vertex deep in a box) | "
          f"{st.sure / st.states:.1%} |\n"
          f"| exact fcl queries per state (a state's likeliest pairs first) | "
          f"{st.queries / st.states:.2f} |\n"
          f"| time per state ({CHUNK}-state chunks): FK (compiled loop) | {t_fk * us:.1f} µs |\n"
          f"| time per state: pass (FK + balls + covers) | {t_pass * us:.1f} µs |\n"
          f"| FK per state at 16 / 128 / 1024 states a call, compiled loop | "
          + " / ".join(f"{v:.1f}" for v in fk_curve.values()) + " µs |\n"
          "| the same, the artifact's JAX kernel | "
          + " / ".join(f"{v:.1f}" for v in jax_curve.values()) + " µs |\n"
          f"| time per state: fcl confirmation of candidates | {t_conf * us:.1f} µs |\n"
          f"| one free state a call (OMPL's validity checks) | {t_one:.0f} µs a call |\n"
          f"| motion validation ({len(motions)} motions, {steps} steps) | "
          f"{1e3 * motion_time / length:.1f} ms per metre of joint-space path "
          f"({steps / length:.0f} steps/m) |")
