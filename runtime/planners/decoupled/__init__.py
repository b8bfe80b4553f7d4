"""The ``decoupled`` planner (the classical TAMP baseline: a task plan first, then a motion
planner for each of its steps, backtracking on failure), single motions with OMPL's planners or
tmpc's own, and OMPL's path simplifier on tmpc's plans.

The package's rooms:

* :mod:`tmpc.runtime.planners.decoupled.space`: OMPL on tmpc's worlds, a state space over the
  robot's configuration whose validity and motion checks are tmpc's batched collision checks in
  one mode (:class:`~tmpc.runtime.planners.decoupled.space.MotionSpace`);
* :mod:`tmpc.runtime.planners.decoupled.lazyprm`: tmpc's own single-motion planner, a lazy
  PRM on batched checks (:func:`~tmpc.runtime.planners.decoupled.lazyprm.lazy_prm`);
* :mod:`tmpc.runtime.planners.decoupled.motion`: one motion with either planner
  (:func:`~tmpc.runtime.planners.decoupled.motion.plan_motion`), the path simplifier on a
  plan (:func:`~tmpc.runtime.planners.decoupled.motion.simplify_path`);
* :mod:`tmpc.runtime.planners.decoupled.planner`: the planner's loop
  (:class:`~tmpc.runtime.planners.decoupled.planner.DecoupledPlanner`).

This door is light (the CLI's parser reads :data:`MOTION_PLANNERS` for ``--help``): OMPL,
numpy and the planner load on first use of the names below (PEP 562 ``__getattr__``).
"""

from __future__ import annotations

from tmpc.runtime.lazy import lazy_getattr

#: OMPL's geometric planners the Python bindings expose that plan one motion between two
#: states with nothing but tmpc's checks (``ompl:NAME``), and tmpc's own lazy PRM (``tmpc``)
OMPL_NAMES = ("AORRTC", "BFMT", "BITstar", "BKPIECE1", "FMT", "InformedRRTstar", "KPIECE1",
              "LBKPIECE1", "PRM", "PRMstar", "RRT", "RRTConnect", "RRTstar", "SORRTstar")
MOTION_PLANNERS = tuple(f"ompl:{n}" for n in OMPL_NAMES) + ("tmpc",)
DEFAULT_MOTION_PLANNER = "ompl:RRTConnect"
#: the ways ``--simplify`` shortens a final plan's motions: the planner's own (tmpc's
#: shortcuts and refinement, nothing added) or OMPL's PathSimplifier after them
SIMPLIFIERS = ("tmpc", "ompl")
DEFAULT_SIMPLIFIER = "tmpc"

#: heavy names of this package, imported on first access
_LAZY = {
    "MotionSpace": "tmpc.runtime.planners.decoupled.space",
    "lazy_prm": "tmpc.runtime.planners.decoupled.lazyprm",
    "plan_motion": "tmpc.runtime.planners.decoupled.motion",
    "MotionResult": "tmpc.runtime.planners.decoupled.motion",
    "simplify_path": "tmpc.runtime.planners.decoupled.motion",
    "simplify_result": "tmpc.runtime.planners.decoupled.motion",
    "check_motion_planner": "tmpc.runtime.planners.decoupled.motion",
    "OmplSimplified": "tmpc.runtime.planners.decoupled.motion",
    "mode_segments": "tmpc.runtime.planners.decoupled.motion",
    "DecoupledPlanner": "tmpc.runtime.planners.decoupled.planner",
    "DecoupledOptions": "tmpc.runtime.planners.decoupled.planner",
}


__getattr__ = lazy_getattr(__name__, _LAZY)


__all__ = ["OMPL_NAMES", "MOTION_PLANNERS", "DEFAULT_MOTION_PLANNER", "SIMPLIFIERS",
           "DEFAULT_SIMPLIFIER", *_LAZY]
