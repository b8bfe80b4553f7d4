"""A* with LM-cut against brute force: optimal costs equal to a Dijkstra over the whole state
space, the same lengths as the SAT planner, LM-cut admissible (also from a parent's landmarks)
on every fixture state, deterministic plans that replay; the compiled LM-cut (A*'s) equal to the
Python definition (the SAT bound's) on sampled states."""

from __future__ import annotations

import heapq
import random
from functools import lru_cache

import pytest

from tests.bench.gen import GRIPPER_DOMAIN, gripper_problem
from tests.support import EXAMPLES, FIXTURES
from tmpc.compiler.ground import LMCut, ground
from tmpc.compiler.ground.lmcut import unpack
from tmpc.compiler.smt import lmcut
from tmpc.lang.program import load_checked
from tmpc.runtime.planners import AStarPlanner, TaskPlanner, simulate

INF = float("inf")
MAX_STATES = 20_000

TASKS = [(EXAMPLES / "blocksworld", "p01")] + [
    (d, p.stem) for d in sorted((FIXTURES / "classical").iterdir())
    for p in sorted(d.glob("p*.pddl"))]


def _id(task) -> str:
    return f"{task[0].name}-{task[1]}"


@lru_cache(maxsize=None)
def _ground(folder, name):
    return ground(load_checked([folder / "domain.pddl", folder / f"{name}.pddl"]))


@lru_cache(maxsize=None)
def _space(folder, name):
    """Every reachable state with its edges ``(action, successor, cost)``, and the optimal
    cost-to-go of each (a Dijkstra backwards from the goal states); None if too large."""
    gp = _ground(folder, name)
    edges: dict[int, list] = {}
    todo = [gp.init]
    edges[gp.init] = []
    while todo:
        s = todo.pop()
        out = edges[s]
        for a, t in gp.successors(s):
            out.append((a, t, a.cost if gp.uses_costs else 1))
            if t not in edges:
                if len(edges) >= MAX_STATES:
                    return None
                edges[t] = []
                todo.append(t)
    back: dict[int, list] = {s: [] for s in edges}
    for s, out in edges.items():
        for _, t, c in out:
            back[t].append((s, c))
    dist = {s: 0 for s in edges if gp.goal_satisfied(s)}
    heap = [(0, s) for s in dist]
    while heap:
        d, t = heapq.heappop(heap)
        if d > dist[t]:
            continue
        for s, c in back[t]:
            if d + c < dist.get(s, INF):
                dist[s] = d + c
                heapq.heappush(heap, (d + c, s))
    return edges, dist


@pytest.mark.parametrize("task", TASKS, ids=_id)
def test_astar_is_optimal_and_replays(task):
    gp = _ground(*task)
    r = AStarPlanner(gp).plan(30)
    assert r.status == "solved"
    ok, why = simulate(gp, r.actions)
    assert ok, why
    cost = sum(a.cost for a in r.actions) if gp.uses_costs else len(r.actions)
    assert cost == r.cost
    space = _space(*task)
    if space is not None:
        assert cost == space[1][gp.init]
    if not gp.uses_costs:       # the SAT engine is length-optimal: the same length
        assert len(r.actions) == TaskPlanner(gp).plan(60, 30).horizon


@pytest.mark.parametrize("task", TASKS, ids=_id)
def test_lmcut_is_admissible_on_every_state(task):
    space = _space(*task)
    if space is None:
        pytest.skip("state space too large for brute force")
    edges, dist = space
    gp = _ground(*task)
    h = LMCut(gp)
    rng = random.Random(0)
    states = sorted(edges)
    for s in rng.sample(states, min(len(states), 400)):
        lms: list = []
        hs, complete = h.cuts(s, lms)
        assert complete
        assert hs <= dist.get(s, INF), gp.state_atoms(s)
        assert hs < INF or s not in dist            # a relaxed dead end is a dead end
        assert hs == sum(m for m, _ in lms) or hs == INF
        for a, t, _ in edges[s]:                    # from the parent's landmarks
            ht = h.cuts(t, None, None, lms, a.id)[0]
            assert ht <= dist.get(t, INF)


def _sampled_states(gp, task, rng, n=150):
    """Up to ``n`` states with their successors: all reachable ones by brute force when small,
    else random walks from the initial state."""
    space = _space(*task)
    if space is not None:
        edges = space[0]
        states = sorted(edges)
        return [(s, edges[s]) for s in rng.sample(states, min(len(states), n))]
    out, s = [], gp.init
    while len(out) < n:
        succ = [(a, t, 0) for a, t in gp.successors(s)]
        out.append((s, succ))
        s = rng.choice(succ)[1] if succ and rng.random() < 0.95 else gp.init
    return out


@pytest.mark.parametrize("unit", [None, True], ids=["costs", "unit"])
@pytest.mark.parametrize("task", TASKS, ids=_id)
def test_the_compiled_lmcut_equals_the_python_definition(task, unit):
    """The numba kernel gives the same value and the same landmarks (costs and operator sets,
    in the same order) as :meth:`LMCut.cuts`, plain and from each parent's landmarks."""
    gp = _ground(*task)
    h = LMCut(gp, unit=unit)
    if not h.compiled:
        pytest.skip("non-integral costs: the Python version only")
    for s, succ in _sampled_states(gp, task, random.Random(1)):
        lms: list = []
        hs = h.cuts(s, lms)[0]
        packed = h.packed(s)
        assert unpack(packed) == _finite(hs, lms), gp.state_atoms(s)
        for a, t, _ in succ[:4]:
            child: list = []
            ht = h.cuts(t, child, None, lms, a.id)[0]
            assert unpack(h.packed(t, packed, a.id)) == _finite(ht, child), gp.state_atoms(t)


def _finite(h, landmarks):
    """A dead end's landmarks are none in the kernel's answer (the Python version keeps the
    parent's it had reused; A* drops both)."""
    return (h, landmarks if h < INF else [])


def test_the_compiled_lmcut_grows_a_small_workspace(monkeypatch):
    """A workspace too small for a state makes the kernel answer [-2]; the call retries with
    one twice as large until it fits, and the answer is the same."""
    from tmpc.compiler.ground import lmcut_kernel

    task = (EXAMPLES / "blocksworld", "p01")
    gp = _ground(*task)
    reference = LMCut(gp)
    monkeypatch.setattr(lmcut_kernel, "workspace_sizes",
                        lambda t, n_ops, scale: lmcut_kernel.np.full(5, scale, "int64"))
    h = LMCut(gp)
    for s, _ in _sampled_states(gp, task, random.Random(2), 20):
        assert unpack(h.packed(s)) == unpack(reference.packed(s))
    assert h._scale > 4


def test_incremental_and_plain_lmcut_find_the_same_costs():
    for task in TASKS:
        gp = _ground(*task)
        a = AStarPlanner(gp, incremental=True).plan(30)
        b = AStarPlanner(gp, incremental=False).plan(30)
        assert a.cost == b.cost, _id(task)


def test_the_sat_bound_is_lmcut_with_unit_costs():
    for task in TASKS:
        gp = _ground(*task)
        lm = lmcut(gp)
        assert lm.bound == LMCut(gp, unit=True)(gp.init), _id(task)


def test_plans_are_deterministic():
    for task in TASKS[:6]:
        gp = _ground(*task)
        plans = {tuple(a.id for a in AStarPlanner(gp).plan(30).actions) for _ in range(3)}
        assert len(plans) == 1, _id(task)


@pytest.mark.parametrize("balls,length", [(2, 5), (4, 11), (6, 17)])
def test_gripper(tmp_path, balls, length):
    d, p = tmp_path / "domain.pddl", tmp_path / "p.pddl"
    d.write_text(GRIPPER_DOMAIN)
    p.write_text(gripper_problem(balls))
    gp = ground(load_checked([d, p]))
    r = AStarPlanner(gp).plan(30)
    assert r.status == "solved" and len(r.actions) == length and simulate(gp, r.actions)[0]
    assert r.stats.expanded > 0 and r.stats.h_seconds <= r.stats.seconds


def test_no_plan_exhausts_the_state_space(tmp_path):
    d, p = tmp_path / "domain.pddl", tmp_path / "p.pddl"
    d.write_text("""(define (domain once) (:requirements :strips)
      (:predicates (token) (x) (y))
      (:action ax :precondition (token) :effect (and (x) (not (token))))
      (:action ay :precondition (token) :effect (and (y) (not (token)))))""")
    p.write_text("(define (problem p) (:domain once) (:init (token)) (:goal (and (x) (y))))")
    gp = ground(load_checked([d, p]))
    r = AStarPlanner(gp).plan(10)
    assert r.status == "exhausted" and r.actions is None
    assert r.stats.evaluated == 3 and r.stats.dead_ends == 2


def test_time_limit(tmp_path):
    d, p = tmp_path / "domain.pddl", tmp_path / "p.pddl"
    d.write_text(GRIPPER_DOMAIN)
    p.write_text(gripper_problem(12))
    r = AStarPlanner(ground(load_checked([d, p]))).plan(0.05)
    assert r.status == "timeout" and 0 < r.stats.expanded and r.stats.seconds < 1
