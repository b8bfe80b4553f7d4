"""The classical planning engines of `tmpc plan` and their portfolio.

:data:`ENGINES` maps a name to an :class:`EngineSpec`; `tmpc plan --engine`'s choices and the
engine test read it.

* ``sat``: the incremental SAT planner (:mod:`tmpc.runtime.planners.taskplan`): length-optimal;
  action costs are not minimized. Honours ``--min-steps``/``--max-steps``.
* ``astar``: A* with LM-cut (:mod:`tmpc.runtime.planners.astar`): cost-optimal (length-optimal
  without action costs). Ignores the step limits; an exhausted search proves that no plan exists at
  all.
* ``auto``: both at once in two forked processes within the time limit; the first *decisive*
  answer wins and the other process is stopped. Decisive: a plan proven optimal for the task
  (either engine without action costs; only A*'s with them), or A*'s proof that no plan exists.
  A SAT plan of a task with costs is kept while A* runs on, and returned if A* runs out of time.
  With ``--min-steps`` only SAT can answer, so ``auto`` is ``sat``.

Results cross the process boundary, so :class:`EngineResult` holds ground action *ids*.
"""

from __future__ import annotations

import multiprocessing as mp
import multiprocessing.connection
import os
import time
import traceback
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:       # the CLI's parser reads ENGINES: this module imports nothing heavy
    from tmpc.compiler.ground import GroundProblem

SOLVED, EXHAUSTED, TIMEOUT, UNREACHABLE = "solved", "exhausted", "timeout", "unreachable"


@dataclass(frozen=True)
class Limits:
    time_limit: float
    min_steps: int = 0
    max_steps: int = 200


@dataclass
class EngineResult:
    """What one engine found. ``optimal``: what the plan is proven optimal in (``length`` or
    ``cost``; ``""`` for a SAT plan of at least ``--min-steps`` steps that may not be shortest).
    ``detail``: the SAT planner's :class:`~tmpc.runtime.planners.taskplan.PlanResult` (actions
    removed) and setup figures, or A*'s :class:`~tmpc.runtime.planners.astar.SearchStats`.
    ``others``: the results of the portfolio's other engines (``auto``)."""

    engine: str
    status: str
    actions: list[int] | None
    optimal: str
    seconds: float
    detail: object = None
    setup: dict = field(default_factory=dict)
    others: list["EngineResult"] = field(default_factory=list)

    @property
    def solved(self) -> bool:
        return self.status == SOLVED


@dataclass(frozen=True)
class EngineSpec:
    """``run(problem, limits) -> EngineResult``."""

    run: Callable[[GroundProblem, Limits], EngineResult]
    summary: str


def run_sat(problem: GroundProblem, limits: Limits) -> EngineResult:
    from dataclasses import replace

    from tmpc.runtime.planners.taskplan import TaskPlanner
    t0 = time.perf_counter()
    planner = TaskPlanner(problem, analysis_budget=min(1.0, limits.time_limit / 10))
    setup = {"lower_bound": planner.lower_bound,
             "landmarks": planner.landmarks.bound if planner.landmarks else 0,
             "bound_s": planner.bound_seconds,
             "mutexes": None if planner.mutexes is None else len(planner.mutexes),
             "template_s": planner.template_seconds,
             "per_step": (planner.encoding.sizes["step"][0], planner.encoding.sizes["layer"][0])}
    left = limits.time_limit - (time.perf_counter() - t0)
    r = planner.plan(limits.max_steps, max(left, 0.001), limits.min_steps)
    ids = [a.id for a in r.actions] if r.actions is not None else None
    shortest = r.solved and r.impossible_below >= r.horizon
    return EngineResult("sat", r.status, ids, "length" if shortest else "",
                        time.perf_counter() - t0, replace(r, actions=None), setup)


def run_astar(problem: GroundProblem, limits: Limits) -> EngineResult:
    from tmpc.runtime.planners.astar import AStarPlanner
    t0 = time.perf_counter()
    # the limit is the search's: the planner's setup loads the compiled LM-cut, compiled (seconds
    # of CPU) the first time on a machine
    r = AStarPlanner(problem).plan(limits.time_limit)
    ids = [a.id for a in r.actions] if r.actions is not None else None
    return EngineResult("astar", r.status, ids, "cost" if problem.uses_costs else "length",
                        time.perf_counter() - t0, r.stats)


def run_auto(problem: GroundProblem, limits: Limits) -> EngineResult:
    if limits.min_steps > 0:
        return run_sat(problem, limits)
    from tmpc.compiler.ground import load_kernel
    load_kernel()                   # once, before the fork: the A* process inherits it
    return _race(problem, limits, ("astar", "sat"))


ENGINES: dict[str, EngineSpec] = {
    "sat": EngineSpec(run_sat, "incremental SAT on Z3: length-optimal, proves every shorter "
                               "length impossible first (action costs are not minimized)"),
    "astar": EngineSpec(run_astar, "A* with LM-cut: cost-optimal, as Fast Downward's "
                                   "astar(lmcut())"),
    "auto": EngineSpec(run_auto, "both in parallel (two processes); the first proven-optimal "
                                 "plan wins"),
}


def _decisive(r: EngineResult, problem: GroundProblem) -> bool:
    if r.solved:
        return r.optimal == "cost" or (r.optimal == "length" and not problem.uses_costs)
    return r.engine == "astar" and r.status == EXHAUSTED


def _child(name: str, problem: GroundProblem, limits: Limits, conn) -> None:
    try:
        conn.send(("ok", ENGINES[name].run(problem, limits)))
    except BaseException:               # noqa: BLE001 - reported by the parent
        conn.send(("error", traceback.format_exc()))
    finally:
        conn.close()
        os._exit(0)                     # no atexit handlers or buffers of the parent


def _race(problem: GroundProblem, limits: Limits, names: tuple[str, ...]) -> EngineResult:
    """Run the engines ``names`` in forked processes; see the module docstring."""
    t0 = time.perf_counter()
    ctx = mp.get_context("fork")
    running = {}
    for name in names:
        recv, send = ctx.Pipe(duplex=False)
        p = ctx.Process(target=_child, args=(name, problem, limits, send), daemon=True)
        with warnings.catch_warnings():
            # fork is what shares the ground problem (its compiled conditions do not pickle);
            # Python warns when JAX was imported first (tests, TMP runs): the children run no
            # JAX code, so its threads' locks are never taken there
            warnings.simplefilter("ignore", RuntimeWarning)
            p.start()
        send.close()
        running[recv] = (name, p)
    done: list[EngineResult] = []
    grace = 5.0                         # for the children to notice their own deadline
    try:
        while running:
            left = limits.time_limit + grace - (time.perf_counter() - t0)
            ready = mp.connection.wait(list(running), timeout=max(left, 0))
            if not ready:
                break
            for conn in ready:
                name, proc = running.pop(conn)
                try:
                    kind, value = conn.recv()
                except EOFError:
                    kind, value = "error", f"the {name} engine's process died"
                proc.join()
                if kind == "error":
                    raise RuntimeError(f"the {name} engine failed:\n{value}")
                done.append(value)
                if _decisive(value, problem):
                    return _pick(done, value)
    finally:
        for conn, (_, proc) in running.items():
            proc.kill()
            proc.join()
            conn.close()
    return _pick(done, None)


def _pick(done: list[EngineResult], winner: EngineResult | None) -> EngineResult:
    """The decisive result, else a SAT plan (costs not minimized), else the last result."""
    if winner is None:
        winner = next((r for r in done if r.solved), None)
    if winner is None:
        winner = next((r for r in done if r.status == EXHAUSTED), None)
    if winner is None:
        winner = done[-1] if done else EngineResult("auto", TIMEOUT, None, "", 0.0)
    winner.others = [r for r in done if r is not winner]
    return winner


__all__ = ["ENGINES", "EngineSpec", "EngineResult", "Limits", "run_sat", "run_astar",
           "run_auto", "SOLVED", "EXHAUSTED", "TIMEOUT", "UNREACHABLE"]
