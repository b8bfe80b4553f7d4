"""The ``optimal`` planner's loop: batches, task plans, searches and improvements composed
over one graph, anytime until the time limit.

:class:`OptimalPlanner` owns the parts (:class:`~tmpc.runtime.planners.optimal.graph.ModeGraph`,
:class:`~tmpc.runtime.planners.optimal.tasks.TaskPlans`,
:class:`~tmpc.runtime.planners.optimal.escapes.Escapes`,
:class:`~tmpc.runtime.planners.optimal.sampling.TransitionSampler`,
:class:`~tmpc.runtime.planners.optimal.search.Searcher`,
:class:`~tmpc.runtime.planners.optimal.improve.Improver`), which share one random number
generator, one counter dict and one :class:`~tmpc.runtime.planners.optimal.options.BestSolution`.
A new task plan is asked for when no transition has budget left, or when a batch tried a
transition and the batch budget (5) is spent. After the first solution, batches go on until the
time limit; each improved solution is reported (``on_solution``: the CLI writes it atomically)
and recorded in the cost-over-time trace. ``first_solution`` stops at the first one (tmit-star
without ``-o``); ``until_converged`` stops once the last ``converged_solutions`` searches' best
costs lie within ``converged_ratio`` of each other. Ctrl-C keeps the best plan.
"""

from __future__ import annotations

import math
import time

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.planners.optimal.escapes import Escapes
from tmpc.runtime.planners.optimal.graph import ModeGraph, load_graphs
from tmpc.runtime.planners.optimal.improve import Improver
from tmpc.runtime.planners.optimal.options import (TASK_PLANNERS, BestSolution, OptimalOptions,
                                                   OptimalResult)
from tmpc.runtime.planners.optimal.sampling import TransitionSampler
from tmpc.runtime.planners.optimal.search import Searcher
from tmpc.runtime.planners.optimal.tasks import TaskPlans
from tmpc.runtime.problem import PlanningProblem


class OptimalPlanner:
    """Anytime TMIT* (thesis ch. 4) over ``problem``; ``solve(time_limit, progress=None)``."""

    def __init__(self, problem: PlanningProblem, seed: int = 0,
                 options: OptimalOptions = OptimalOptions()):
        self.p = problem
        self.opt = options
        self.rng = np.random.default_rng(seed)
        self.seed = seed
        self.counts = {"batches": 0, "task_plans": 0, "samples": 0, "projections": 0,
                       "transitions": 0, "transition_failures": 0, "edges_checked": 0,
                       "edges_confirmed": 0, "edges_invalid": 0, "searches": 0,
                       "searches_cut": 0, "evidence": 0, "escapes": 0, "shortcuts": 0}
        self.best = BestSolution()
        self.graph = ModeGraph(problem, options)
        self.tasks = TaskPlans(problem, options, self.counts)
        self.escapes = Escapes(problem, options, self.graph, self.rng, self.counts)
        self.sampler = TransitionSampler(problem, options, self.graph, self.tasks, self.escapes,
                                         self.best, self.rng, self.counts)
        self.searcher = Searcher(problem, options, self.graph, self.escapes, self.best,
                                 self.counts)
        self.improver = Improver(problem, options, self.graph, self.tasks, self.best, self.rng,
                                 self.counts, seed)
        #: the best cost after each search since the first solution (``until_converged``)
        self.search_costs: list[float] = []
        self.on_solution = None          # callback(result) at every improved solution

    @classmethod
    def from_options(cls, problem: PlanningProblem, seed: int = 0,
                     overrides: dict | None = None) -> "OptimalPlanner":
        """The registry's factory: ``batch_size``, ``batch_budget``, ``min_steps``,
        ``max_steps``, ``projection_iterations``, ``confirm_resolution``, ``task_planner`` from
        the run configuration (a tmit-star spec or a manifest's [planner]); the command line's
        ``batch_size``, ``rewire``, ``first_solution``, ``until_converged``,
        ``confirm_resolution`` and ``task_planner`` (``tmpc bench --param``) win. E825 for a
        value out of range (:meth:`read_options`)."""
        return cls(problem, seed=seed, options=cls.read_options(problem, overrides))

    @staticmethod
    def read_options(problem: PlanningProblem, overrides: dict | None = None) -> OptimalOptions:
        """:meth:`from_options`' options, each checked by kind and range (E825)."""
        config = problem.world.config
        params = dict(config.params) if config is not None else {}
        over = {k: v for k, v in (overrides or {}).items() if v is not None}
        base = OptimalOptions()
        raw = dict(
            batch_size=over.get("batch_size", params.get("batch_size", base.batch_size)),
            batch_budget=params.get("batch_budget", base.batch_budget),
            rewire=over.get("rewire", base.rewire),
            first_solution=over.get("first_solution", False),
            until_converged=over.get("until_converged", False),
            min_steps=params.get("min_steps", base.min_steps),
            max_steps=params.get("max_steps", base.max_steps),
            projection_iterations=params.get("projection_iterations",
                                             base.projection_iterations),
            confirm_resolution=over.get("confirm_resolution", params.get(
                "confirm_resolution", base.confirm_resolution)),
            task_planner=over.get("task_planner", params.get("task_planner",
                                                             base.task_planner)),
            task_weight=over.get("task_weight", params.get("task_weight", base.task_weight)))
        task_planner = str(raw["task_planner"])
        if task_planner not in TASK_PLANNERS:
            raise InputError(error("E825", f"task planner {task_planner!r} is unknown",
                                   None, f"one of {', '.join(TASK_PLANNERS)}"))
        # (name, kind, lowest): whole numbers and numbers at least / above their bound, flags
        checks = (("batch_size", int, 1), ("batch_budget", int, 1), ("min_steps", int, 0),
                  ("max_steps", int, 1), ("projection_iterations", int, 1),
                  ("rewire", float, 0.0), ("confirm_resolution", float, 0.0),
                  ("first_solution", bool, None), ("until_converged", bool, None),
                  ("task_weight", float, 0.0))
        values = {}
        for name, kind, low in checks:
            value = 0.0 if name == "task_weight" and _checked(raw[name], int, 0) == 0 else \
                _checked(raw[name], kind, low)
            if value is None:
                bound = {int: f"a whole number >= {low}", float: "a finite number > 0",
                         bool: "true or false"}[kind]
                raise InputError(error("E825", f"{name.replace('_', ' ')} {raw[name]!r} is out "
                                       "of range", None, f"{name} takes {bound}"))
            values[name] = value
        return OptimalOptions(task_planner=task_planner, **values)

    # ---- what the run and its progress line read ---------------------------------------------
    @property
    def tp(self):
        """The SAT task planner (None until built: by the warm-up or the first task plan)."""
        return self.tasks.tp

    @property
    def node_mode(self) -> list[int]:
        return self.graph.node_mode

    @property
    def modes(self) -> list:
        return self.graph.modes

    @property
    def best_cost(self) -> float:
        return self.best.cost

    @property
    def best_path(self) -> list[int] | None:
        return self.best.path

    @property
    def trace(self) -> list[tuple[float, float]]:
        return self.best.trace

    def warm_up_calls(self) -> list:
        """Set-up a run makes beside its kernel loads (:meth:`PlanningProblem.start_warm_up`):
        the SAT task planner (Z3's import and context, the encoding's first layers), which
        the first task plan would otherwise build inside planning time, and scipy's graphs."""
        return [self.tasks.task_planner, load_graphs]

    # ---- the loop ----------------------------------------------------------------------------
    def solve(self, time_limit: float, progress=None) -> OptimalResult:
        p, G, best = self.p, self.graph, self.best
        best.t0 = start = time.perf_counter()
        deadline = self.searcher.deadline = start + time_limit
        G.add_mode(p.initial, 0)
        root = G.add_vertex(p.q0, p.initial)
        status = "partial"
        try:
            if G.is_goal_mode(p.initial) and (p.goal_formula() is None
                                              or p.holds(p.initial, None, p.q0)):
                G.goals.add(root)
                best.cost, best.path = 0.0, [root]
                best.trace.append((0.0, 0.0))
            else:
                if self.improver.seed_from_unified(deadline):
                    self.report()
                    self.improver.improve_solution(deadline, self.report)
                self.next_task_plan(deadline)
                self.sampler.new_batch()
            while best.path != [root] and time.perf_counter() < deadline:
                done = self.sampler.sample_modes(deadline)
                if not self.searcher.fits(deadline):
                    break         # no time for a search (its graph first)
                found = self.searcher.search()
                if not found and best.path is None and self.escapes.release_all():
                    # no path: stubs out of every portal not escaped from yet, then again
                    self.escapes.escape()
                    if self.searcher.fits(deadline):
                        found = self.searcher.search()
                if found:
                    self.report()
                    if self.opt.first_solution:
                        break
                    self.improver.improve_solution(deadline, self.report)
                if best.path is not None:
                    self.search_costs.append(best.cost)
                    if self.converged():
                        break
                if done:
                    if self.sampler.needs_task_plan() or self.tasks.hopeless():
                        self.next_task_plan(deadline)
                    self.sampler.new_batch()
                if progress is not None:
                    progress(self)
        except KeyboardInterrupt:
            status = "interrupted"
            self.counts["interrupted"] = True
        return self.result(status, time.perf_counter() - start)

    def next_task_plan(self, deadline: float) -> bool:
        """The next task plan (:meth:`TaskPlans.next_plan`); a new one gets the full batch
        budget."""
        if not self.tasks.next_plan(deadline):
            return False
        self.sampler.batch_budget = self.opt.batch_budget
        return True

    def converged(self) -> bool:
        """``until_converged``: do the last ``converged_solutions`` searches' best costs lie
        within ``converged_ratio`` of each other?"""
        n = self.opt.converged_solutions
        if not self.opt.until_converged or len(self.search_costs) < n:
            return False
        last = self.search_costs[-n:]
        return max(last) - min(last) <= self.opt.converged_ratio * min(last)

    def report(self) -> None:
        """The best solution to ``on_solution``, if set."""
        if self.on_solution is not None:
            self.on_solution(self.result("solved", time.perf_counter() - self.best.t0))

    def result(self, status: str, seconds: float) -> OptimalResult:
        """The best path as ``(q, mode, action to the next state)`` states with the run's
        statistics; with no solution, the path to the deepest vertex a search reached."""
        G, best = self.graph, self.best
        solved = best.path is not None
        ids = best.path if solved else self.searcher.progress
        path = []
        for k, v in enumerate(ids):
            nxt = ids[k + 1] if k + 1 < len(ids) else None
            b = G.bridge.get(v)
            action = b[1] if b is not None and b[0] == nxt else None
            path.append((G.Q[v].copy(), G.mode_of(v), action))
        stats = dict(self.counts, seconds=round(seconds, 4), nodes=len(G.node_mode),
                     modes=len(G.modes), cost=round(best.cost, 6) if solved else None,
                     cost_trace=[list(x) for x in best.trace],
                     first_solution_seconds=best.trace[0][0] if best.trace else None,
                     time=self.p.timers.as_dict())
        if solved:
            status = "solved"
        return OptimalResult(status, path, stats, best.cost)


def _checked(value, kind: type, low):
    """``value`` as ``kind`` if it is one and in range (``int``: a whole number >= ``low``;
    ``float``: finite and > ``low``; ``bool``: a flag), else None (E825). A manifest's TOML and
    `tmpc bench --param` give typed values; the command line's strings are read as numbers."""
    if kind is bool:
        return value if isinstance(value, bool) else None
    if isinstance(value, bool):
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    if not math.isfinite(number):
        return None
    if kind is int:
        return int(number) if number.is_integer() and number >= low else None
    return number if number > low else None
