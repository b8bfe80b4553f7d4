"""The optimal planner's options, its result and its best solution so far.

:class:`OptimalOptions` holds every tunable of the planner (tmit-star's defaults where it has
them, the rest tmpc's additions, docs/planning.md "Where it differs"); :class:`OptimalResult` is
what :meth:`tmpc.runtime.planners.optimal.planner.OptimalPlanner.solve` returns;
:class:`BestSolution` is the incumbent every part of the planner reads (the searches' bound,
the caps' growth) and the cost-over-time trace.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from tmpc.lang.world import PARAM_CHOICES
from tmpc.runtime.problem import Mode


#: the values of ``OptimalOptions.task_planner`` (a manifest's ``[planner] task_planner``)
TASK_PLANNERS = PARAM_CHOICES["task_planner"]


@dataclass(frozen=True)
class OptimalOptions:
    batch_size: int = 50               # uniform samples per mode per batch (tmit-star: 50)
    batch_budget: int = 5              # batches per task plan (tmit-star: 5)
    rewire: float = 1.0                # k-nearest rewire factor
    resolution: float = 0.05           # motion-check resolution (the validator's default)
    #: the edges of a path found are confirmed at this resolution (at most ``resolution``):
    #: a hand 0.8 m from the shoulder moves 4 cm per 0.05 rad, and plans valid at 0.05 grazed
    #: blocks, glasses and sticks by millimetres at 0.005 (docs/benchmarks.md); 0.01 makes
    #: first solutions valid at 0.01, at a cost not measured over the suite yet, so the
    #: default stays the resolution
    confirm_resolution: float = 0.05
    coarse: float = 8.0                # the search checks edges at coarse x resolution first
    inflation: float = 2.0             # heuristic weight of the searches before a first solution
    deflation: float = 0.5             # ... its excess over 1 shrinks by this per later search
    mode_caps: int = 0                 # > 0: caps per source mode, this many times the absolute
    portals: bool = True               # join each mode's entries to its exits (tmpc's addition)
    corridor: float = 0.5              # share of samples around entry-exit segments (tmpc's)
    corridor_sigma: float = 0.05       # their noise, as a fraction of each coordinate's range
    #: a mode with entries but no exit yet: this share of samples around its entries (tmpc's)
    entry_share: float = 0.1
    search_budget: int = 3000          # edges one search may check before it waits for a batch
    escape_tries: int = 16             # short motions tried out of each new portal (tmpc's; 0: off)
    escape_rounds: int = 2             # ... and again out of the free ends kept
    escape_keep: int = 2               # free ends kept per vertex and round
    #: Cartesian escapes: straight hand motions (up, back, both) of this many steps of
    #: ``cartesian_step`` metres out of each portal escaped from (tmpc's; 0: off)
    cartesian_steps: int = 8
    cartesian_step: float = 0.025
    #: escape only out of portals one of whose edges failed (at the next sampling, or at once
    #: when a search before the first solution found no path)
    escape_lazy: bool = True
    #: their lengths: the largest coordinate step, as fractions of each coordinate's range
    escape_steps: tuple = (0.005, 0.02, 0.06)
    #: anytime runs start from the unified planner's plan (tmpc's; not with first_solution)
    seed_unified: bool = True
    shortcut_tries: int = 32           # shortcuts tried per mode segment of a new solution (tmpc's)
    shortcut_points: int = 16          # ... between points cutting its edges into this many pieces
    shortcut_rounds: int = 3           # ... and again on the shortened segment
    #: sweeps of transition refinement per new solution (tmpc's; 0: off;
    #: :mod:`tmpc.runtime.planners.optimal.refine`)
    refine_sweeps: int = 200
    absolute_cap: int = 5              # successes per transition, ever (tmit-star: 5)
    #: projector steps per transition attempt (the unified planner takes the problem's 15):
    #: tmit-star's putdowns need more, and fewer batches pay for them (docs/planning.md)
    projection_iterations: int = 30
    #: > 0: with no solution yet, the absolute cap grows by its first value every this many
    #: batches (tmpc's; tmit-star's caps never grow)
    cap_growth: int = 10
    cap_increment: int = 1             # the per-batch success cap grows by this much
    first_solution: bool = False       # stop at the first solution (tmit-star without -o)
    #: with ``first_solution``: seconds the task planner may spend on one horizon before it
    #: tries the next (a plan, not a proof that none is shorter; tmpc's; None: off)
    horizon_cap: float | None = 1.0
    #: the task planner: ``sat`` (the shortest plan consistent with what was learnt), or
    #: ``greedy`` (the SAT planner while its encoding is small, else greedy best-first search,
    #: with blocker rules: :mod:`tmpc.runtime.planners.greedy`); ``auto``: greedy to a first
    #: solution, else sat
    task_planner: str = "auto"
    #: the greedy task planner's plan is shortened by weighted A* (depth + this x h_FF) when a
    #: search of at most 4 times its expansions finds a shorter one (tmpc's; 0: off). Blocks
    #: World E's greedy plans had 24-28 steps where 16 do (docs/planning.md)
    task_weight: float = 2.0
    #: a grasp never reached (a real miss,
    #: :attr:`~tmpc.runtime.planners.optimal.tasks.Transition.missed`) has the same grasp of
    #: every other object not moved yet probed at once:
    #: :data:`~tmpc.runtime.planners.optimal.tasks.RULE_FAILURES` projections where it
    #: stands, and a miss there too is ruled out until it moves
    #: (:meth:`~tmpc.runtime.planners.optimal.tasks.TaskPlans.probe_alike`; tmpc's; the
    #: decoupled planner's ``probe_reach``)
    probe_reach: bool = False
    until_converged: bool = False
    converged_solutions: int = 10
    converged_ratio: float = 0.10
    min_steps: int = 0
    max_steps: int = 100               # tmit-star's default


@dataclass
class OptimalResult:
    status: str                        # solved | partial | interrupted
    path: list[tuple[np.ndarray, Mode, object | None]]
    stats: dict = field(default_factory=dict)
    cost: float = math.inf


class BestSolution:
    """The best path of graph vertices found so far (None: none yet), its cost, and the
    ``(seconds since t0, cost)`` trace of every improvement."""

    def __init__(self) -> None:
        self.cost = math.inf
        self.path: list[int] | None = None
        self.trace: list[tuple[float, float]] = []
        self.t0 = time.perf_counter()

    def record_solution(self, cost: float, path: list[int]) -> None:
        """A new best solution, recorded in the cost-over-time trace."""
        self.cost, self.path = cost, path
        self.trace.append((round(time.perf_counter() - self.t0, 4), round(cost, 6)))
