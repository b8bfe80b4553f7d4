"""The types a planner satisfies: :class:`Planner` (what :data:`tmpc.runtime.planners.PLANNERS`
builds, and what a third-party planner registered under the ``tmpc.planners`` entry point group
returns) and its result."""

from __future__ import annotations

from typing import Any, Callable, Protocol, runtime_checkable

#: ``progress(planner)``: called by a planner now and then while it plans
Progress = Callable[[Any], None]


@runtime_checkable
class PlannerResult(Protocol):
    """What ``solve`` returns: ``status`` (``solved``, ``partial``, ``interrupted``), ``path``
    = [(configuration, mode, action executed there or None)] and ``stats`` (JSON-able)."""

    status: str
    path: list[tuple[Any, Any, Any]]
    stats: dict[str, Any]


@runtime_checkable
class Planner(Protocol):
    """A planner built by a factory ``factory(problem, seed, overrides)`` for one
    :class:`~tmpc.runtime.problem.PlanningProblem`. An anytime planner may also have an
    ``on_solution`` attribute (called with each improved result) and ``warm_up_calls()``
    (set-up to run before planning)."""

    def solve(self, time_limit: float, progress: Progress | None = None) -> PlannerResult:
        ...


#: ``factory(problem, seed, overrides) -> Planner``: what an entry point of the group
#: ``tmpc.planners`` names (or a :class:`tmpc.runtime.planners.PlannerSpec`)
PlannerFactory = Callable[[Any, int, dict[str, Any]], Planner]
