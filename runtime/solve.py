"""Load, check and plan: the one path from an input to a planner's result that ``tmpc run`` and
``tmpc bench`` share."""

from __future__ import annotations

import time

import numpy as np

from tmpc.compiler.artifact import open_world
from tmpc.lang.inputs import World
from tmpc.runtime.planners import make_planner
from tmpc.runtime.problem import TmpProblem


def plan_problem(input_path, planner: str = "unified", seed: int = 0, time_limit: float = 120.0,
                 overrides: dict | None = None, progress=None):
    """Load (``input_path``: a path or a loaded :class:`World`), check and plan; returns
    (problem, result, setup seconds)."""
    t0 = time.perf_counter()
    world = input_path if isinstance(input_path, World) else open_world(input_path)
    problem = TmpProblem(world)
    problem.check_goal_reachable()
    problem.check_start()
    algo = make_planner(planner, problem, seed, overrides)
    problem.warm_up(np.random.default_rng(seed))
    setup = time.perf_counter() - t0
    result = algo.solve(time_limit, progress)
    return problem, result, setup
