"""One motion in one mode with OMPL's planners or tmpc's own, and OMPL's path simplifier on
every motion of a plan.

:func:`plan_motion` is what ``tmpc motion`` and the decoupled planner call: ``ompl:NAME``
plans with that OMPL planner through :class:`~tmpc.runtime.planners.decoupled.space.MotionSpace`
(tmpc's checks), ``tmpc`` with :func:`~tmpc.runtime.planners.decoupled.lazyprm.lazy_prm` and
its shortcuts. :func:`simplify_result` runs OMPL's ``PathSimplifier`` on each mode segment of a
planner's final path (``--simplify ompl``); each result is checked by tmpc's motion checker and
the original segment kept where the check fails. An unknown planner name is E850 with the
closest known ones.
"""

from __future__ import annotations

import dataclasses
import difflib
import time
from dataclasses import dataclass

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.planners.decoupled import MOTION_PLANNERS, OMPL_NAMES
from tmpc.runtime.planners.decoupled.lazyprm import lazy_prm, shortcut
from tmpc.runtime.planners.decoupled.space import MotionSpace, motion_seed, path_cost
from tmpc.runtime.problem import Mode, PlanningProblem


@dataclass
class MotionResult:
    """A motion: its path (k, n) (None: none found), why not (``status``: ``exact`` when
    found), the seconds it took and its composite length."""

    path: np.ndarray | None
    status: str
    seconds: float
    length: float | None
    planner: str


def check_motion_planner(name: str) -> str:
    """``name`` if it is a motion planner
    (:data:`tmpc.runtime.planners.decoupled.MOTION_PLANNERS`); E850 with the closest names
    otherwise."""
    if name in MOTION_PLANNERS:
        return name
    close = difflib.get_close_matches(name, MOTION_PLANNERS, n=3, cutoff=0.5)
    bare = [f"ompl:{n}" for n in OMPL_NAMES if n.lower() == name.split(":")[-1].lower()]
    close = list(dict.fromkeys(bare + close))
    hint = (f"did you mean {' or '.join(f'`{c}`' for c in close)}? " if close else "") + \
        "motion planners: " + ", ".join(MOTION_PLANNERS)
    raise InputError(error("E850", f"unknown motion planner `{name}`", None, hint))


def ompl_space(problem: PlanningProblem, resolution: float = 0.05) -> MotionSpace:
    """The problem's OMPL space (E857 when OMPL cannot be imported)."""
    try:
        return MotionSpace(problem, resolution)
    except ImportError as exc:
        raise InputError(error("E857", f"OMPL cannot be imported: {exc}", None,
                               "install it: pip install 'ompl>=2'")) from None


def plan_motion(problem: PlanningProblem, mode: Mode, q0: np.ndarray, q1: np.ndarray,
                planner: str = "ompl:RRTConnect", time_limit: float = 10.0, seed: int = 0,
                space: MotionSpace | None = None, resolution: float = 0.05,
                fixed: np.ndarray | None = None, checks: int | None = None) -> MotionResult:
    """A collision-free path q0 -> q1 in ``mode`` within ``time_limit`` seconds (both ends
    exact, every segment valid by tmpc's motion checker) with ``planner`` (``ompl:NAME`` or
    ``tmpc``); deterministic from ``seed``, and for an OMPL planner given ``checks`` (at most
    that many of tmpc's checks: :meth:`MotionSpace.plan`) whatever the machine's speed.
    ``space``: an OMPL space of ``problem`` to reuse. ``fixed``: a mask of joints ``q0`` and
    ``q1`` share that an OMPL planner holds there (it plans in the others alone; tmpc's
    planner plans in all)."""
    check_motion_planner(planner)
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    t = time.perf_counter()
    if np.abs(problem.difference(q1, q0)).max() <= 1e-12:
        return MotionResult(np.stack([q0, q1]), "exact", 0.0, 0.0, planner)
    if planner == "tmpc":
        rng = np.random.default_rng(seed)
        Q = lazy_prm(problem, mode, q0, q1, rng, t + time_limit, resolution)
        status = "exact" if Q is not None else "timeout"
        if Q is not None:
            Q = shortcut(problem, mode, Q, rng, resolution=resolution)
    else:
        space = space or ompl_space(problem, resolution)
        space.mode = mode
        Q, status = space.plan(q0, q1, planner.split(":", 1)[1], time_limit, seed, fixed,
                               checks)
    seconds = round(time.perf_counter() - t, 4)
    return MotionResult(Q, status, seconds, None if Q is None else path_cost(problem, Q),
                        planner)


def mode_segments(path: list) -> list[list]:
    """A plan's ``(q, mode, action)`` states cut into its motions: a state with an action ends
    one (the next state, at the same configuration, begins the next)."""
    out, seg = [], []
    for item in path:
        seg.append(item)
        if item[2] is not None:
            out.append(seg)
            seg = []
    if seg:
        out.append(seg)
    return out


def simplify_path(problem: PlanningProblem, path: list, seed: int = 0,
                  budget: float = 1.0, space: MotionSpace | None = None) -> tuple[list, dict]:
    """OMPL's ``PathSimplifier`` on each motion of ``path`` (``(q, mode, action)`` states) in
    its mode, ``budget`` seconds each; returns the new path and what it did (motions
    simplified, kept because the check failed or nothing was gained, lengths before/after)."""
    space = space or ompl_space(problem)
    out, stats = [], {"motions": 0, "simplified": 0, "kept": 0}
    before = after = 0.0
    for k, seg in enumerate(mode_segments(path)):
        Q = np.array([q for q, _, _ in seg], float)
        mode = seg[0][1]
        before += path_cost(problem, Q)
        stats["motions"] += 1
        new = Q
        if len(Q) >= 3:
            space.mode = mode
            new = space.simplify(Q, budget, motion_seed(seed, k))
            if new is Q or not space.path_valid(new, mode):
                stats["kept"] += 1
                new = Q
            else:
                stats["simplified"] += 1
        after += path_cost(problem, new)
        last = seg[-1][2]
        out.extend((q.copy(), mode, None) for q in new[:-1])
        out.append((new[-1].copy(), seg[-1][1], last))
    stats.update(length_before=round(before, 6), length_after=round(after, 6))
    return out, stats


def simplify_result(problem: PlanningProblem, result, seed: int = 0, budget: float = 1.0):
    """``result`` (a planner's) with its path simplified by :func:`simplify_path` when solved;
    its ``stats`` get ``simplify`` and the new ``cost``."""
    if result.status != "solved" or not result.path:
        return result
    t = time.perf_counter()
    path, stats = simplify_path(problem, result.path, seed, budget)
    stats["seconds"] = round(time.perf_counter() - t, 4)
    new_stats = dict(result.stats, simplify=stats,
                     **{f"simplify_{k}": v for k, v in stats.items()})   # flat: bench's counts
    if new_stats.get("cost") is not None:
        new_stats["cost"] = stats["length_after"]
    changes = {"path": path, "stats": new_stats}
    if hasattr(result, "cost"):
        changes["cost"] = stats["length_after"]
    return dataclasses.replace(result, **changes)


class OmplSimplified:
    """A planner whose final solution goes through :func:`simplify_result` (``--simplify
    ompl``); everything else is the wrapped planner's."""

    def __init__(self, planner, problem: PlanningProblem, seed: int, budget: float = 1.0):
        object.__setattr__(self, "inner", planner)
        object.__setattr__(self, "problem", problem)
        object.__setattr__(self, "seed", seed)
        object.__setattr__(self, "budget", budget)

    def solve(self, time_limit: float, progress=None):
        result = self.inner.solve(time_limit, progress)
        return simplify_result(self.problem, result, self.seed, self.budget)

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def __setattr__(self, name, value):
        setattr(self.inner, name, value)
