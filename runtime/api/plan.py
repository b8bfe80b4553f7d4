"""A plan as the Python API returns it: the plan document (docs/plan-format.md) with its status,
actions, states, statistics, cost and, without a plan, the "why no plan" report."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from tmpc.runtime.plans import write_json_atomic


class Plan:
    """The result of :meth:`tmpc.runtime.api.World.plan`; no exception for "no plan":
    ``solved`` is false and ``explanation`` says why."""

    def __init__(self, document: dict[str, Any], cost: float | None,
                 explanation: dict[str, Any] | None, symbolic: list[int] | None = None,
                 replanned: bool = False) -> None:
        self.document = document
        self.cost = cost
        self.explanation = explanation
        #: planned from a start other than the scene's (validated from its first state)
        self.replanned = replanned
        #: the symbolic state (ground bitset, geometric symbols included) of each state
        self.symbolic = symbolic or []

    @property
    def status(self) -> str:
        """``solved``, ``partial`` (no plan within the limits), ``interrupted``, ..."""
        return str(self.document["status"])

    @property
    def solved(self) -> bool:
        return self.status == "solved"

    @property
    def actions(self) -> list[str]:
        """The actions, in order, as ``(pick stick1 table1)``."""
        return list(self.document["actions"])

    @property
    def states(self) -> list[dict[str, Any]]:
        """The states as state JSON (each a valid ``start`` for another ``plan()``)."""
        return list(self.document["states"])

    @property
    def stats(self) -> dict[str, Any]:
        """The planner's statistics (time, iterations, ...) and the setup seconds."""
        return dict(self.document["stats"])

    def to_json(self) -> str:
        """The ``tmpc-plan/1`` document as JSON text (what ``tmpc run -o`` writes; the dict
        is :attr:`document`)."""
        return json.dumps(self.document, indent=1)

    def write(self, path: str | Path) -> None:
        """Write the plan file (atomically), as ``tmpc run -o`` does."""
        write_json_atomic(path, self.document)

    def __repr__(self) -> str:
        cost = "" if self.cost is None else f", cost {self.cost:.4g}"
        return f"<Plan {self.status}: {len(self.document['actions'])} actions{cost}>"


def plan_cost(result: Any, problem: Any) -> float | None:
    """The plan's composite path length (tmit-star's cost), None without a plan."""
    if result.status != "solved" or not result.path:
        return None
    cost = getattr(result, "cost", None)
    if cost is not None and math.isfinite(cost):
        return float(cost)
    total = 0.0
    for (a, _, _), (b, _, _) in zip(result.path, result.path[1:]):
        total += float(problem.cost(b[None], a)[0])
    return total
