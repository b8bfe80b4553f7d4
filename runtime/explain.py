"""Why a run found no plan: what the planner tried, in order of blame, as a JSON-able report.

:class:`Evidence` is filled while planning by :class:`~tmpc.runtime.problem.PlanningProblem`,
whatever the planner (both call its projection and its successor modes): per ground action (and
the goal) how many configurations were projected onto its geometric precondition, how many
reached it, the best unsatisfaction distance and a few configurations at either; which
transitions happened; which discrete atoms some reached mode made true; and task plans a
planner reports (:meth:`Evidence.task_plan`). :func:`explain` turns it into the report `tmpc run`
summarises and writes with ``--explain FILE``, after the run, so planning pays only for the
bookkeeping:

1. goal atoms no reached mode made true (symbolic), and the actions that add them;
2. actions (and the goal) whose geometric precondition was never reached, with the literal that
   stays farthest from holding at the best configuration: the predicate and its objects;
3. actions whose precondition held but whose configurations all collide, with the colliding
   pairs (exact fcl at the kept configurations);
4. task plans tried and the first step each never realised.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field

import numpy as np

from tmpc.compiler.ground import SYMBOL

#: configurations kept per action (the best non-holding one, and this many holding ones)
KEEP = 3


@dataclass
class Attempts:
    """Projections onto one action's geometric precondition (or the goal's)."""

    tried: int = 0
    held: int = 0
    best: float = float("inf")
    best_q: tuple | None = None              # (mode, q) at the best distance
    holding: list = field(default_factory=list)   # [(mode, q)] where it held

    def record(self, mode, Q: np.ndarray, holds: np.ndarray, dist: np.ndarray) -> None:
        self.tried += len(Q)
        self.held += int(np.count_nonzero(holds))
        if len(dist):
            i = int(np.argmin(dist))
            if dist[i] < self.best:
                self.best, self.best_q = float(dist[i]), (mode, np.array(Q[i]))
        for k in np.flatnonzero(holds)[:max(0, KEEP - len(self.holding))]:
            self.holding.append((mode, np.array(Q[k])))


class Evidence:
    """What a run tried (see the module docstring); ``None`` keys are the goal."""

    def __init__(self) -> None:
        self.attempts: dict[object, Attempts] = collections.defaultdict(Attempts)
        self.actions: dict[object, object] = {}          # key -> ground action (None: goal)
        self.transitions: collections.Counter = collections.Counter()
        self.reached_atoms = 0                            # OR of the reached modes' atoms
        self.task_plans: list[dict] = []

    def projected(self, mode, action, Q, holds, dist) -> None:
        key = None if action is None else action.name
        self.actions.setdefault(key, action)
        self.attempts[key].record(mode, np.asarray(Q), np.asarray(holds, bool),
                                  np.asarray(dist, float))

    def reached(self, sym: int, action=None) -> None:
        self.reached_atoms |= sym
        if action is not None:
            self.transitions[action.name] += 1

    def task_plan(self, actions: list[str], failed_at: int | None, why: str = "") -> None:
        """A planner's task plan, and the index of its first step never realised (None: all
        were)."""
        if len(self.task_plans) < 20:
            self.task_plans.append({"actions": actions, "failed_at": failed_at, "why": why})


def explain(problem, status: str) -> dict:
    """The report (module docstring) for a run of ``problem`` that ended with ``status``."""
    ev: Evidence = problem.evidence
    ground = problem.ground
    culprits: list[dict] = []
    culprits += _unreached_goal_atoms(problem, ev)
    for key, att in sorted(ev.attempts.items(), key=lambda kv: -kv[1].tried):
        action = ev.actions.get(key)
        name = "the goal" if key is None else key
        if att.held == 0:
            culprits.append(_never_held(problem, action, name, att))
        elif key is not None and ev.transitions[key] == 0 or key is None and status != "solved":
            pairs = _collisions(problem, att)
            if pairs:
                culprits.append({
                    "kind": "collides", "action": name,
                    "message": f"{name}: its precondition held at {att.held} of {att.tried} "
                               f"projected configurations, but they collide: "
                               + ", ".join(f"{a} with {b}" for a, b in pairs[:3]),
                    "collisions": [list(p) for p in pairs]})
    plans = [{"actions": p["actions"], "failed_at": p["failed_at"],
              "failed_action": None if p["failed_at"] is None
              else p["actions"][p["failed_at"]], "why": p["why"]} for p in ev.task_plans]
    return {
        "status": status,
        "summary": culprits[0]["message"] if culprits else
        "no single culprit: every sampled precondition held somewhere and no reached "
        "configuration collided; the planner may need more time",
        "culprits": culprits,
        "task_plans": plans,
        "reached_atoms": ground.shown_atoms(ev.reached_atoms),
        "transitions": dict(ev.transitions),
        "projections": {("goal" if k is None else k): {"tried": a.tried, "held": a.held,
                                                       "best_distance": _num(a.best)}
                        for k, a in ev.attempts.items()},
    }


def _num(x: float):
    return None if not np.isfinite(x) else round(float(x), 6)


def _unreached_goal_atoms(problem, ev: Evidence) -> list[dict]:
    ground = problem.ground
    out = []
    for i in sorted(ground.goal.pos):
        if ev.reached_atoms >> i & 1:
            continue
        shown = ground.atom_name(i).replace(SYMBOL, "")
        # as plans name them: a geometric symbol's variants show as their action, once
        adders = list(dict.fromkeys(
            a.name for a in ground.actions
            if a.add_mask >> i & 1 or any(ce.add_mask >> i & 1 for ce in a.conditional)))
        why = (f": the actions that make it true ({', '.join(adders[:3])}) were never applied"
               if adders else ": no action makes it true")
        out.append({"kind": "goal-atom", "atom": shown,
                    "message": f"the goal atom {shown} was never reached{why}",
                    "adders": adders, "adders_tried": [n for n in adders if n in ev.attempts]})
    return out


def _never_held(problem, action, name: str, att: Attempts) -> dict:
    out = {"kind": "never-held", "action": name, "tried": att.tried,
           "best_distance": _num(att.best)}
    worst = _worst_literal(problem, action, att.best_q) if att.best_q is not None else None
    if worst is not None:
        pred, args, d = worst
        out.update(predicate=pred, objects=list(args), literal_distance=_num(d))
        out["message"] = (f"{name}: its geometric precondition was never reached in {att.tried} "
                          f"projections; ({' '.join((pred, *args))}) stays farthest "
                          f"(distance {d:.3g} at the best configuration)")
    else:
        out["message"] = (f"{name}: its geometric precondition was never reached in "
                          f"{att.tried} projections (best distance {att.best:.3g})")
    return out


def _worst_literal(problem, action, best):
    """(predicate, args, distance) of the geometric literal of ``action``'s precondition (the
    goal's for None) farthest from holding at the kept best configuration."""
    mode, q = best
    lits = problem.ground.goal.geometric if action is None else action.pre_geometric
    worst = None
    for lit in lits:
        formula = problem.compiled.predicate(lit.predicate)
        kernel, _ = problem.compiled.kernels(formula)
        ids = problem.compiled.bind_args(formula, list(lit.args))
        truth, dist = kernel(q, mode.obj_T, mode.obj_parent, ids)
        d = float(dist) if lit.positive else (0.0 if not bool(truth) else 1.0)
        if worst is None or d > worst[2]:
            worst = (lit.predicate, tuple(lit.args), d)
    return worst


def _collisions(problem, att: Attempts) -> list[tuple[str, str]]:
    """Colliding pairs at the kept holding configurations, most frequent first."""
    seen: collections.Counter = collections.Counter()
    for mode, q in att.holding:
        rep = problem.collision.check(q, poses=mode.poses, attached=mode.held)
        for a, b, _ in rep.pairs:
            seen[(a, b)] += 1
    return [p for p, _ in seen.most_common()]


def summary_lines(report: dict, limit: int = 4) -> list[str]:
    """A few lines for the terminal: the culprits, most to blame first."""
    lines = [f"why no plan: {report['summary']}"]
    for c in report["culprits"][1:limit]:
        lines.append(f"  also: {c['message']}")
    if len(report["culprits"]) > limit:
        lines.append(f"  ({len(report['culprits']) - limit} more in the --explain report)")
    return lines
