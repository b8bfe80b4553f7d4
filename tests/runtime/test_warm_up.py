"""The warm-up's kernel loads (tmpc.runtime.problem.KernelLoads): every call runs once, on the
background thread or on the caller's once it helps, and an error reaches the caller."""

from __future__ import annotations

import threading

import pytest

from tmpc.runtime.problem import KernelLoads


def test_each_load_runs_once_and_the_caller_takes_what_is_left():
    ran, started = [], threading.Event()
    lock = threading.Lock()

    def call(i):
        def run():
            if i == 0:                 # the background thread holds the first until the
                started.set()          # caller has taken one of its own
                assert helped.wait(10)
            with lock:
                ran.append((i, threading.current_thread().name))
            if threading.current_thread().name != "tmpc-warm-up":
                helped.set()
        return run

    helped = threading.Event()
    loads = KernelLoads([call(i) for i in range(5)])
    assert started.wait(10)
    seen = []
    loads.finish(seen.append)
    assert sorted(i for i, _ in ran) == list(range(5))
    assert {name for _, name in ran} == {"tmpc-warm-up", threading.current_thread().name}
    assert seen and seen == sorted(seen) and len(loads) == 5


def test_an_error_in_a_load_is_raised_by_finish():
    def bad():
        raise RuntimeError("no executable")

    loads = KernelLoads([bad, lambda: None])
    with pytest.raises(RuntimeError, match="no executable"):
        loads.finish()


def test_the_optimal_planners_task_planner_is_built_by_the_warm_up(clutter_world):
    """A run hands the warm-up the planner's own set-up (``warm_up_calls``): the optimal
    planner's SAT task planner exists before planning starts, and the plan is the one a
    planner building it inside planning finds (same seed)."""
    import numpy as np

    from tmpc.runtime.planners import make_planner
    from tmpc.runtime.problem import PlanningProblem
    problem = PlanningProblem(clutter_world)
    warmed = make_planner("optimal", problem, 3, {"first_solution": True})
    problem.start_warm_up(np.random.default_rng(0), warmed.warm_up_calls())
    problem.warm_up(np.random.default_rng(0))
    assert warmed.tp is not None
    cold = make_planner("optimal", problem, 3, {"first_solution": True})
    assert cold.tp is None
    a, b = warmed.solve(60.0), cold.solve(60.0)
    assert a.status == b.status == "solved"
    assert [act for _, _, act in a.path] == [act for _, _, act in b.path]
    assert all(np.array_equal(qa, qb) for (qa, _, _), (qb, _, _) in zip(a.path, b.path))


def test_calls_added_later_run_once_even_after_the_thread_ran_out():
    """``add``: calls given after the loads began run once each, on a new background thread
    when the first had already finished its calls, and ``finish`` waits for all of them."""
    ran = []
    lock = threading.Lock()
    pause = threading.Event()

    def call(i):
        def run():
            with lock:
                ran.append((i, threading.current_thread().name))
        return run

    loads = KernelLoads([call(0)])
    for _ in range(500):                       # the first thread runs out of calls
        if ran and not loads._working:
            break
        pause.wait(0.01)
    assert [i for i, _ in ran] == [0] and not loads._working
    loads.add([call(1), call(2)])
    loads.add([])
    for _ in range(500):                       # taken without finish(): a new thread
        if len(ran) == 3:
            break
        pause.wait(0.01)
    loads.finish()
    assert sorted(i for i, _ in ran) == [0, 1, 2] and len(loads) == 3
    assert {name for _, name in ran} == {"tmpc-warm-up"}
