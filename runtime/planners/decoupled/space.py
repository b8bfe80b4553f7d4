"""OMPL on a tmpc world: a real-vector state space over the robot's configuration whose state
validity and motion checks are tmpc's batched collision checks in one mode.

:class:`MotionSpace` owns one OMPL ``SpaceInformation`` per problem; :attr:`MotionSpace.mode`
says in which mode (objects' poses, held objects) the checks run, so one space serves every
motion of a plan. A motion check is one call of
:meth:`tmpc.runtime.problem.PlanningProblem.motions_valid` (every interpolated state of the
straight motion in one batched check, at the validator's resolution), so OMPL's plans and
simplified paths are valid by the same checker the other planners use. Wrapping coordinates
(a base's yaw, continuous joints) are bounded reals to OMPL; tmpc's motion check goes the
short way round, as the plans' motions do, and every returned path is checked again here
segment by segment (:meth:`MotionSpace.path_valid`).

OMPL's random numbers are seeded per motion (``ompl.util.RNG.setSeed``, before the planner
and its samplers are made), so a motion is a function of its seed for the planners that stop
at their first solution; the optimizing ones are told that any solution satisfies them (a cost
threshold of infinity), so they stop there too. A motion's budget is counted in tmpc's checks
(:attr:`MotionSpace.checks`, OMPL's state and motion checks), not in seconds, so whether it
is found does not depend on the machine's speed or load either (:meth:`MotionSpace.plan`).
"""

from __future__ import annotations

import atexit
import gc
import time
import weakref

import numpy as np

from tmpc.runtime.problem import Mode, PlanningProblem


def ompl_modules():
    """``(ompl.base, ompl.geometric, ompl.util)``, imported on first use (tmpc's start-up and
    `tmpc check` never load OMPL)."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou
    return ob, og, ou


def seed_ompl(seed: int) -> None:
    """Seed OMPL's random number generator (its seed generator: planners and samplers made
    after this draw from it). OMPL refuses 0 and logs an error when reseeded after its first
    use; both are harmless here (the log is silenced for the call)."""
    _, _, ou = ompl_modules()
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(1 + int(seed) % 2_147_483_000)
    finally:
        ou.setLogLevel(level)


def motion_seed(seed: int, k: int) -> int:
    """The OMPL seed of a run's ``k``-th motion (distinct per run seed and motion)."""
    return (int(seed) * 1_000_003 + 7919 * int(k)) % 2_147_483_000


#: the spaces alive, released before the interpreter exits (:func:`release_all`)
_LIVE: weakref.WeakSet = weakref.WeakSet()


def release_all() -> None:
    """Drop every live space's OMPL objects (registered with ``atexit``): OMPL's bindings
    report the objects still alive at exit as leaks, a screenful of noise after a normal run."""
    for space in list(_LIVE):
        space.release()
    gc.collect()


class MotionSpace:
    """OMPL's view of ``problem``'s configuration space, checked by tmpc in :attr:`mode`."""

    def __init__(self, problem: PlanningProblem, resolution: float = 0.05):
        ob, og, ou = ompl_modules()
        ou.setLogLevel(ou.LOG_ERROR)
        if not _LIVE:
            atexit.register(release_all)
        _LIVE.add(self)
        self.p = problem
        self.resolution = resolution
        self.dim = n = len(problem.lower)
        #: the longest edge OMPL's planners grow a tree by (``setRange``; 0: theirs, a fifth
        #: of the space's extent)
        self.range = 0.0
        self.mode: Mode = problem.initial
        self.counts = {"ompl_states_checked": 0, "ompl_motions_checked": 0}
        self.space = ob.RealVectorStateSpace(n)
        self.space.setBounds(self.bounds())
        self.si = ob.SpaceInformation(self.space)
        # the checker objects must outlive the space information (kept as attributes)
        self.validity = _validity_checker(ob, self)
        self.motions = _motion_validator(ob, self)
        self.si.setStateValidityChecker(self.validity)
        self.si.setMotionValidator(self.motions)
        self.si.setup()

    def release(self) -> None:
        """Drop the OMPL objects (the space is unusable after)."""
        self.si = self.space = self.validity = self.motions = None

    # ---- states and arrays --------------------------------------------------------------------
    def to_array(self, state) -> np.ndarray:
        return np.array([state[i] for i in range(self.dim)], float)

    def to_state(self, q: np.ndarray):
        s = self.si.allocState()
        for i, v in enumerate(np.asarray(q, float)):
            s[i] = float(v)
        return s

    def path_array(self, path) -> np.ndarray:
        return np.array([self.to_array(s) for s in path.getStates()], float).reshape(-1, self.dim)

    def geometric_path(self, Q: np.ndarray):
        _, og, _ = ompl_modules()
        path = og.PathGeometric(self.si)
        for q in Q:
            path.append(self.to_state(q))
        return path

    # ---- tmpc's checks ------------------------------------------------------------------------
    @property
    def checks(self) -> int:
        """OMPL's calls of tmpc's checks so far, states and motions alike: the unit of a
        motion's budget (:meth:`plan`)."""
        return self.counts["ompl_states_checked"] + self.counts["ompl_motions_checked"]

    def valid(self, q: np.ndarray) -> bool:
        self.counts["ompl_states_checked"] += 1
        return bool(self.p.valid_batch(self.mode, np.asarray(q, float)[None])[0])

    def motion_valid(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        self.counts["ompl_motions_checked"] += 1
        return bool(self.p.motions_valid(self.mode, q0[None], q1[None], self.resolution,
                                         ends=True)[0])

    def path_valid(self, Q: np.ndarray, mode: Mode | None = None) -> bool:
        """Is every straight segment of ``Q`` (k, n), its states included, valid in ``mode``
        (default :attr:`mode`)? One batched check."""
        Q = np.asarray(Q, float)
        if len(Q) < 2:
            return len(Q) == 1 and bool(self.p.valid_batch(mode or self.mode, Q)[0])
        return bool(self.p.motions_valid(mode or self.mode, Q[:-1], Q[1:], self.resolution,
                                         ends=True).all())

    # ---- planning and simplifying -------------------------------------------------------------
    def bounds(self, fixed: np.ndarray | None = None, at: np.ndarray | None = None):
        """OMPL's bounds of the space: the problem's joint limits, or with the joints of the
        mask ``fixed`` held at their values in ``at`` (an interval of 1e-9 wide: OMPL wants
        low < high)."""
        ob, _, _ = ompl_modules()
        bounds = ob.RealVectorBounds(self.dim)
        for i, (lo, hi) in enumerate(zip(self.p.lower, self.p.upper)):
            lo, hi = float(lo), float(hi)
            if fixed is not None and fixed[i]:
                lo = hi = float(at[i])
            bounds.setLow(i, lo)
            bounds.setHigh(i, hi if hi > lo else lo + 1e-9)
        return bounds

    def bound(self, fixed: np.ndarray | None = None, at: np.ndarray | None = None) -> None:
        """Set the space's bounds (:meth:`bounds`) and set the space up again."""
        self.space.setBounds(self.bounds(fixed, at))
        self.si.setup()

    def plan(self, q0: np.ndarray, q1: np.ndarray, name: str, budget: float,
             seed: int, fixed: np.ndarray | None = None,
             checks: int | None = None) -> tuple[np.ndarray | None, str]:
        """A path q0 -> q1 (k, n), both ends exact and every segment valid by tmpc, from OMPL's
        planner ``name`` (a class of ``ompl.geometric``) within ``budget`` seconds and, when
        given, ``checks`` of tmpc's checks (:attr:`checks`); (None, OMPL's status) when it
        found none. Within its checks a motion is a function of its seed (OMPL's planners
        heed the budget between iterations); ``budget`` may be ``inf``. ``fixed``: a mask of
        joints the path holds where ``q0`` has them (``q1`` has them there too): OMPL plans
        in the others alone."""
        if fixed is not None and fixed.any():
            self.bound(fixed, q0)
            try:
                Q, status = self.plan(q0, q1, name, budget, seed, checks=checks)
            finally:
                self.bound()
            if Q is not None:
                Q[:, fixed] = q0[fixed]
            return Q, status
        ob, og, _ = ompl_modules()
        seed_ompl(seed)
        setup = og.SimpleSetup(self.si)
        setup.setStartAndGoalStates(self.to_state(q0), self.to_state(q1))
        objective = ob.PathLengthOptimizationObjective(self.si)
        objective.setCostThreshold(objective.infiniteCost())     # the first solution will do
        setup.setOptimizationObjective(objective)
        planner = getattr(og, name)(self.si)
        if self.range > 0 and hasattr(planner, "setRange"):
            planner.setRange(float(self.range))
        setup.setPlanner(planner)
        status = setup.solve(self.termination(budget, checks))
        if not setup.haveExactSolutionPath():
            return None, str(status)
        Q = self.path_array(setup.getSolutionPath())
        Q = _exact_ends(Q, q0, q1)
        if not self.path_valid(Q):
            return None, "invalid path"
        return Q, "exact"

    def termination(self, budget: float, checks: int | None = None):
        """OMPL's termination condition of a plan: ``budget`` seconds gone, or ``checks`` more
        of tmpc's checks made (None: seconds alone)."""
        ob, _, _ = ompl_modules()
        if checks is None:
            return ob.timedPlannerTerminationCondition(float(budget))
        end = self.checks + int(checks)
        stop = time.perf_counter() + float(budget)
        return ob.PlannerTerminationCondition(
            lambda: self.checks >= end or time.perf_counter() >= stop)

    def simplify(self, Q: np.ndarray, budget: float, seed: int) -> np.ndarray:
        """OMPL's ``PathSimplifier`` on the path ``Q`` (k, n) within ``budget`` seconds; the
        result keeps both ends and is checked by tmpc (``Q`` itself when the check fails or
        the result is no shorter)."""
        _, og, _ = ompl_modules()
        if len(Q) < 3 and (len(Q) < 2 or self.p.cost(Q[1:], Q[0]).sum() == 0):
            return Q
        seed_ompl(seed)
        path = self.geometric_path(Q)
        og.PathSimplifier(self.si).simplify(path, float(budget))
        out = self.path_array(path)
        if len(out) < 2 or np.abs(self.p.difference(out[0], Q[0])).max() > 1e-9 or \
                np.abs(self.p.difference(out[-1], Q[-1])).max() > 1e-9:
            return Q
        out[0], out[-1] = Q[0], Q[-1]
        if path_cost(self.p, out) >= path_cost(self.p, Q) - 1e-12 or not self.path_valid(out):
            return Q
        return out


def path_cost(p: PlanningProblem, Q: np.ndarray) -> float:
    """tmit-star's composite length of the path ``Q`` (k, n)."""
    Q = np.asarray(Q, float)
    return float(sum(p.cost(Q[i + 1:i + 2], Q[i])[0] for i in range(len(Q) - 1)))


def _exact_ends(Q: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """``Q`` starting at exactly q0 and ending at exactly q1 (an end off by more than 1e-9 gets
    the exact one appended: the segment to it is then checked with the rest)."""
    Q = np.asarray(Q, float)
    Q = Q if np.abs(Q[0] - q0).max() <= 1e-9 else np.vstack([q0, Q])
    Q = Q if np.abs(Q[-1] - q1).max() <= 1e-9 else np.vstack([Q, q1])
    Q[0], Q[-1] = q0, q1
    return Q


def _validity_checker(ob, space: MotionSpace):
    class Validity(ob.StateValidityChecker):
        def isValid(self, state) -> bool:
            return space.valid(space.to_array(state))
    return Validity(space.si)


def _motion_validator(ob, space: MotionSpace):
    class Motions(ob.MotionValidator):
        def checkMotion(self, s1, s2, *rest) -> bool:
            return space.motion_valid(space.to_array(s1), space.to_array(s2))
    return Motions(space.si)


def elapsed(t0: float) -> float:
    return round(time.perf_counter() - t0, 4)
