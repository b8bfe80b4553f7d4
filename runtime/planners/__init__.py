"""The planner registry and the planners: unified (ch. 2), optimal (ch. 4, the package
:mod:`tmpc.runtime.planners.optimal`), the FF heuristic, the incremental-SAT task planner, A* with
LM-cut and the registry of `tmpc plan`'s engines (:data:`ENGINES`,
:mod:`tmpc.runtime.planners.engines`).

:data:`PLANNERS` maps a name to a :class:`PlannerSpec`: its factory and a one-line summary. The
CLI's ``--planner`` choices, ``tmpc bench --planners`` and the registry test all read it; there
is no other list of planners.

Installed distributions add planners under the entry point group ``tmpc.planners``
(:func:`load_entry_points`, run at import: ``--planner`` lists them).

The registry is light (the CLI's parser reads it); the planners themselves and the task planner
are imported on first use (PEP 562 ``__getattr__`` below), so importing this package costs nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Callable, Mapping

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.lazy import lazy_getattr
from tmpc.runtime.planners.engines import ENGINES as ENGINES
from tmpc.runtime.planners.engines import EngineResult as EngineResult
from tmpc.runtime.planners.engines import EngineSpec as EngineSpec
from tmpc.runtime.planners.engines import Limits as Limits
from tmpc.runtime.planners.decoupled import DEFAULT_MOTION_PLANNER as DEFAULT_MOTION_PLANNER
from tmpc.runtime.planners.decoupled import DEFAULT_SIMPLIFIER as DEFAULT_SIMPLIFIER
from tmpc.runtime.planners.decoupled import MOTION_PLANNERS as MOTION_PLANNERS
from tmpc.runtime.planners.decoupled import SIMPLIFIERS as SIMPLIFIERS


@dataclass(frozen=True)
class PlannerSpec:
    """``factory(problem, seed, overrides)`` builds a planner with ``solve(time_limit,
    progress=None)``; ``overrides`` are the command line's planner options (None = not given),
    which win over the run configuration's ``[planner]`` parameters."""

    factory: Callable[..., object]
    summary: str
    #: the ``overrides`` the factory reads: the names ``tmpc bench --param NAME=...`` may sweep
    parameters: tuple[str, ...] = ()


def _unified(problem, seed: int, overrides: dict):
    # imported when a planner is built: `tmpc --help` reads this registry for `--planner`'s
    # choices and must not import numpy, JAX or Z3
    from tmpc.runtime.planners.unified import UnifiedPlanner
    return UnifiedPlanner.from_options(problem, seed, overrides)


def _optimal(problem, seed: int, overrides: dict):
    from tmpc.runtime.planners.optimal import OptimalPlanner
    return OptimalPlanner.from_options(problem, seed, overrides)


def _decoupled(problem, seed: int, overrides: dict):
    from tmpc.runtime.planners.decoupled import DecoupledPlanner
    return DecoupledPlanner.from_options(problem, seed, overrides)


PLANNERS: dict[str, PlannerSpec] = {
    "unified": PlannerSpec(_unified, "composite-space RRT with the Algorithm 1 sampler "
                           "(thesis ch. 2, planet)", ("heuristic_bias", "simplify")),
    "optimal": PlannerSpec(_optimal, "anytime TMIT*: SAT (or greedy) task plans, lazy "
                           "transitions, "
                           "asymmetric search over a multimodal graph (thesis ch. 4, tmit-star)",
                           ("batch_size", "rewire", "first_solution", "until_converged",
                            "task_planner", "task_weight", "confirm_resolution",
                            "simplify")),
    "decoupled": PlannerSpec(_decoupled, "the classical baseline: SAT task plans, projected "
                             "transitions, each motion by an OMPL planner (--motion-planner), "
                             "backtracking", ("motion_planner", "motion_budget", "motion_checks",
                                              "samples", "task_planner", "simplify")),
}


#: the entry point group third-party planners register under (docs/api.md, "Planners")
ENTRY_POINT_GROUP = "tmpc.planners"


def load_entry_points() -> list[str]:
    """Add the planners installed distributions register under :data:`ENTRY_POINT_GROUP` (an
    entry point's name is the planner's; it names a :class:`PlannerSpec` or a factory,
    loaded when the planner is first built); built-in names win. Returns the names added."""
    added = []
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in PLANNERS:
            continue
        dist = getattr(ep.dist, "name", None) or ep.value
        PLANNERS[ep.name] = PlannerSpec(_entry_point_factory(ep),
                                        f"third-party planner ({dist}: {ep.value})")
        added.append(ep.name)
    return added


def _entry_point_factory(ep):
    def factory(problem, seed: int, overrides: dict):
        target = ep.load()
        make = target.factory if isinstance(target, PlannerSpec) else target
        return make(problem, seed, overrides)
    return factory


load_entry_points()


def make_planner(name: str, problem, seed: int = 0, overrides: Mapping | None = None):
    """The registered planner ``name`` for ``problem``; E826 names the registry when unknown."""
    spec = PLANNERS.get(name)
    if spec is None:
        raise unknown_planner(name)
    simplify = (overrides or {}).get("simplify")
    if simplify is not None and simplify not in SIMPLIFIERS:
        raise InputError(error("E855", f"unknown simplifier `{simplify}`", None,
                               "simplifiers: " + ", ".join(SIMPLIFIERS)))
    algo = spec.factory(problem, seed, dict(overrides or {}))
    if simplify == "ompl":
        # --simplify ompl: OMPL's PathSimplifier on the final plan's motions (issue Q)
        from tmpc.runtime.planners.decoupled import OmplSimplified
        algo = OmplSimplified(algo, problem, seed)
    return algo


def unknown_planner(name: str) -> InputError:
    return InputError(error("E826", f"unknown planner `{name}`", None,
                            "planners: " + ", ".join(sorted(PLANNERS))))


#: heavy names of this package, imported on first access
_LAZY = {
    "UnifiedPlanner": "tmpc.runtime.planners.unified",
    "UnifiedOptions": "tmpc.runtime.planners.unified",
    "UnifiedResult": "tmpc.runtime.planners.unified",
    "OptimalPlanner": "tmpc.runtime.planners.optimal",
    "OptimalOptions": "tmpc.runtime.planners.optimal",
    "OptimalResult": "tmpc.runtime.planners.optimal",
    "FFHeuristic": "tmpc.runtime.planners.heuristic",
    "TaskPlanner": "tmpc.runtime.planners.taskplan", "simulate": "tmpc.runtime.planners.taskplan",
    "SOLVED": "tmpc.runtime.planners.taskplan", "TIMEOUT": "tmpc.runtime.planners.taskplan",
    "EXHAUSTED": "tmpc.runtime.planners.taskplan",
    "UNREACHABLE": "tmpc.runtime.planners.taskplan",
    "AStarPlanner": "tmpc.runtime.planners.astar",
    "DecoupledPlanner": "tmpc.runtime.planners.decoupled",
    "plan_motion": "tmpc.runtime.planners.decoupled",
    "check_motion_planner": "tmpc.runtime.planners.decoupled",
    "simplify_result": "tmpc.runtime.planners.decoupled",
}


__getattr__ = lazy_getattr(__name__, _LAZY)


__all__ = ["PLANNERS", "PlannerSpec", "ENTRY_POINT_GROUP", "load_entry_points", "ENGINES", "EngineSpec", "EngineResult", "Limits",
           "MOTION_PLANNERS", "DEFAULT_MOTION_PLANNER", "SIMPLIFIERS", "DEFAULT_SIMPLIFIER",
           "make_planner", "unknown_planner", *_LAZY]
