"""Load, check and plan: the one path from an input to a planner's result that ``tmpc run`` and
``tmpc bench`` share."""

from __future__ import annotations

import gc
import time
from contextlib import contextmanager

import numpy as np

from tmpc.compiler.export import open_for_run
from tmpc.lang.inputs import World
from tmpc.runtime.collision import prepare_kernel
from tmpc.runtime.interrupts import interruptible
from tmpc.runtime.planners import make_planner
from tmpc.runtime.problem import PlanningProblem, register_run_kernels
from tmpc.runtime.setup_checks import raise_setup_errors


def open_input(path, on_compile=None, progress=None) -> tuple[World, dict]:
    """The world to plan in (:func:`~tmpc.compiler.export.open_for_run`: an artifact, or a
    configuration through the artifact cache) and the seconds spent: ``load``, and ``compile``
    when the cache had no artifact of these sources. ``progress(phase, done, total, detail)``
    hears the compile's phases."""
    t = time.perf_counter()
    world, how = open_for_run(path, register_run_kernels, on_compile=on_compile,
                              progress=progress, before_compile=raise_setup_errors)
    spent = time.perf_counter() - t
    return world, {"kernels": how, ("compile" if how == "compiled" else "load"): spent}


def plan_problem(input_path, planner: str = "unified", seed: int = 0, time_limit: float = 120.0,
                 overrides: dict | None = None, progress=None, on_solution=None,
                 setup_progress=None):
    """Load (``input_path``: a path or a loaded :class:`World`), check and plan; returns
    (problem, result, setup seconds). ``problem.setup`` has the split: ``problem`` (grounding,
    the collision world, the pre-checks), ``deserialize`` (exported kernels read) and
    ``first_call`` (their first calls: XLA compiles or loads them from its cache), plus
    ``load``/``compile`` and ``kernels`` from :func:`open_input` when given a path.
    ``on_solution(problem, result, setup)``: called by an anytime planner at every improved
    solution. ``setup_progress(phase, done, total, detail)`` hears the setup's phases (the
    planner's own ``progress`` hears planning)."""
    t0 = time.perf_counter()
    prepare_kernel()         # a machine's first run: the collision kernels build meanwhile
    with _fewer_collections():
        problem, algo = _set_up(input_path, planner, seed, overrides, setup_progress)
    setup = time.perf_counter() - t0
    if on_solution is not None and hasattr(algo, "on_solution"):
        algo.on_solution = lambda result: on_solution(problem, result, setup)
    with interruptible():               # Ctrl-C / SIGTERM: the best progress, not an exit
        result = algo.solve(time_limit, progress)
    return problem, result, setup


def replan(problem: PlanningProblem, planner: str = "unified", seed: int = 0,
           time_limit: float = 120.0, overrides: dict | None = None, start=None,
           sym: int | None = None, progress=None, on_solution=None):
    """Plan again in ``problem`` (from :func:`plan_problem`), from the state ``start`` with the
    symbolic state ``sym`` (None: the scene's start; :meth:`PlanningProblem.restart`): nothing
    is loaded or compiled again. Returns (result, setup seconds: ``plan`` entry to the planner's
    ``solve``), the split in ``problem.setup``."""
    t0 = time.perf_counter()
    problem.restart(start, sym)
    algo = make_planner(planner, problem, seed, overrides)
    for call in getattr(algo, "warm_up_calls", list)():
        call()
    problem.check_start()
    setup = time.perf_counter() - t0
    problem.setup = {"problem": setup, "deserialize": 0.0, "first_call": 0.0, "traced": []}
    if on_solution is not None and hasattr(algo, "on_solution"):
        algo.on_solution = lambda result: on_solution(problem, result, setup)
    with interruptible():
        result = algo.solve(time_limit, progress)
    return result, setup


@contextmanager
def _fewer_collections():
    """Python's cycle collector runs far less often during setup (its thresholds restored
    after): setup allocates many long-lived objects (JAX's modules, kernels, the grounding),
    and the collections they trigger free next to nothing while costing a share of setup's
    CPU. Not off: tracing a cold compile leaves cyclic garbage."""
    thresholds = gc.get_threshold()
    gc.set_threshold(max(thresholds[0], 100_000), *thresholds[1:])
    try:
        yield
    finally:
        gc.set_threshold(*thresholds)


def _set_up(input_path, planner, seed, overrides, setup_progress):
    """:func:`plan_problem`'s setup: (problem, planner); the split in ``problem.setup``."""
    split: dict = {}
    if isinstance(input_path, World):
        world = input_path
    else:
        world, split = open_input(input_path)
    t = time.perf_counter()
    if setup_progress is not None:
        setup_progress("preparing the planner", 0, 0, "")
    # the kernel loads begin as soon as the kernels exist: the collision world and the
    # planner are made meanwhile
    problem = PlanningProblem(world, warm_rng=np.random.default_rng(seed))
    algo = make_planner(planner, problem, seed, overrides)
    # the planner's own set-up (the optimal planner's SAT task planner: importing Z3, its
    # context and encoding) runs beside the kernel loads, not in planning time
    problem.start_warm_up(np.random.default_rng(seed),
                          getattr(algo, "warm_up_calls", list)())
    problem.check_goal_reachable()
    problem.check_start()
    split["problem"] = time.perf_counter() - t
    bank = problem.compiled.bank.stats
    before = bank.seconds_deserialize
    warm = problem.warm_up(np.random.default_rng(seed), setup_progress)
    split["deserialize"] = bank.seconds_deserialize - before
    split["first_call"] = warm - split["deserialize"]
    split["traced"] = list(bank.traced_keys)
    if problem.collision_pass is not None:
        split["collision_pass"] = problem.collision_pass
    if setup_progress is not None:
        setup_progress("planning", 0, 0, "")
    problem.setup = split
    return problem, algo
