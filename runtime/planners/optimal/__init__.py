"""The ``optimal`` planner (thesis ch. 4, tmit-star's TMIT*): task plans from incremental SAT,
a multimodal random geometric graph grown in batches, lazy transitions, and an asymmetric
(reverse heuristic, forward lazy) search; anytime.

The package's rooms, each with its own account of its step:

* :mod:`tmpc.runtime.planners.optimal.tasks`: task plans, transitions and blockers
  (:class:`~tmpc.runtime.planners.optimal.tasks.TaskPlans`);
* :mod:`tmpc.runtime.planners.optimal.graph`: vertices ``(q, mode)``, modes, edges, the
  nearest-neighbour lists and the sparse graph the searches run on
  (:class:`~tmpc.runtime.planners.optimal.graph.ModeGraph`);
* :mod:`tmpc.runtime.planners.optimal.sampling`: batches of samples and the transition attempts
  from them (:class:`~tmpc.runtime.planners.optimal.sampling.TransitionSampler`);
* :mod:`tmpc.runtime.planners.optimal.escapes`: escape stubs out of portal vertices
  (:class:`~tmpc.runtime.planners.optimal.escapes.Escapes`);
* :mod:`tmpc.runtime.planners.optimal.search`: the reverse Dijkstra and the forward lazy A*
  (:func:`~tmpc.runtime.planners.optimal.search.lazy_astar`,
  :class:`~tmpc.runtime.planners.optimal.search.Searcher`);
* :mod:`tmpc.runtime.planners.optimal.improve` and :mod:`tmpc.runtime.planners.optimal.refine`:
  shortcuts, transition refinement and the unified seed
  (:class:`~tmpc.runtime.planners.optimal.improve.Improver`);
* :mod:`tmpc.runtime.planners.optimal.planner`: the loop that composes them
  (:class:`~tmpc.runtime.planners.optimal.planner.OptimalPlanner`).

Costs are tmit-star's composite path length
(:meth:`tmpc.runtime.problem.PlanningProblem.cost`), so plan costs compare across the two
planners.

Differences from tmit-star (docs/planning.md "Where it differs"): the reverse search is
recomputed per batch rather than repaired incrementally (LPA*); blockers are used (tmit-star
declares ``blocked_steps`` and never reads it); each mode's entries are joined to its exits and
half of its samples are drawn around them (``portals``, ``corridor``; a mode entered but not
yet left: a tenth around its entries, ``entry_share``); a portal vertex one of whose edges
failed gets short free motions out of it (escape stubs; every portal, when a search finds no
path); edges are checked in batches, coarse first, a found path's at the full resolution
(``coarse``); the search before a first solution is inflated (``inflation``) and a search gives
up after ``search_budget`` edge checks until the next batch; the absolute cap grows while there
is no solution (``cap_growth``: tmit-star's never does); anytime runs shortcut and refine their
solutions and start from the unified planner's plan (``shortcut_*``, ``refine_sweeps``,
``seed_unified``).
"""

from __future__ import annotations

from tmpc.runtime.planners.optimal.graph import ModeGraph
from tmpc.runtime.planners.optimal.options import BestSolution, OptimalOptions, OptimalResult
from tmpc.runtime.planners.optimal.planner import OptimalPlanner
from tmpc.runtime.planners.optimal.search import lazy_astar
from tmpc.runtime.planners.optimal.tasks import Transition

__all__ = ["OptimalPlanner", "OptimalOptions", "OptimalResult", "Transition", "lazy_astar",
           "ModeGraph", "BestSolution"]
