"""The ``unified`` planner (thesis ch. 2, planet): an RRT in the composite space of robot
configurations and modes whose sampler is Algorithm 1.

The tree's nodes are ``(q, mode)``. Distance is mode-aware and directed: a node can only be
extended toward a configuration *in its own mode*; a mode is entered only through a logged action
(a transition node: same configuration, the successor mode), so across modes without a known
transition the distance is infinite.

Each iteration draws, with probability ``heuristic_bias`` (planet's ``coin_bias``), a
**heuristic sample**: a ``(mode, action)`` entry chosen with probability proportional to its
scaled priority ``P / (1 + fails + gamma * successes)`` among the entries of every reached mode
(priorities from the FF heuristic's helpful actions, requested once per reached symbolic state),
then a batch of projections onto the action's geometric precondition in that mode (starts near the
mode's nodes and uniform ones), collision-free results only. The projected configuration stays in
the old mode — a *target*: the tree connects to it by a straight motion from its nearest node in
the mode, and when it does the transition is realised (the action's effects give the new mode,
kinematic effects attach or release objects at that configuration). Otherwise (a **normal
sample**) the tree grows in a known mode, toward a pending target (goal bias) or a uniform random
configuration, by the longest collision-free prefix of the straight motion (RRT "extend" up to
``step``).

Every random choice comes from the seed. The loop stops at the goal (a node whose mode satisfies
the goal's discrete part and, at its configuration, the goal's geometric literals), at the time
limit, or on Ctrl-C; the result then carries the best progress (the reached mode with the
smallest heuristic value) with status ``partial``. The solution path is shortcut within each mode
(straight motions re-checked), then every motion is re-checked at the output resolution.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.planners.heuristic import FFHeuristic, ScaledPriorities
from tmpc.runtime.problem import PROJECTION_BATCH, Mode, PlanningProblem


@dataclass(frozen=True)
class UnifiedOptions:
    heuristic_bias: float = 0.4        # planet coin_bias as shipped
    gamma: float = 100.0               # planet success scale
    goal_weight: float = 4.0           # planet's "goal reached" entry
    step: float = 2.0                  # longest extension toward a uniform sample (rad/m, L2)
    resolution: float = 0.05           # motion-check resolution (largest coordinate step)
    target_bias: float = 0.5           # normal samples that go for a pending target
    near_starts: float = 0.5           # share of projection starts near the mode's nodes
    shortcut_tries: int = 60           # shortcut attempts per mode segment of the solution
    max_targets: int = 64              # pending targets kept
    #: tmpc's focus on progress: an entry's weight is also multiplied by exp(-focus * (h' -
    #: min h')), h' the heuristic value after its action. 0 reproduces planet (1/h'^2 alone,
    #: whose ratios flatten as h grows: 1/16^2 vs 1/17^2 differ by 13%, so 8 sticks explored
    #: every order of picks breadth-first); 1 makes a step backward e times less likely.
    focus: float = 1.0


@dataclass
class UnifiedResult:
    status: str                        # solved | partial | interrupted
    path: list[tuple[np.ndarray, Mode, object | None]]   # (q, mode, action executed there)
    stats: dict = field(default_factory=dict)


@dataclass(eq=False)
class _Target:
    q: np.ndarray
    mode: Mode
    action: object | None              # None: the goal
    entry: int
    tries: int = 0


class UnifiedPlanner:
    def __init__(self, problem: PlanningProblem, seed: int = 0,
                 options: UnifiedOptions = UnifiedOptions()):
        self.p = problem
        self.opt = options
        self.rng = np.random.default_rng(seed)
        self.h = FFHeuristic(problem.ground)
        self.modes: list[Mode] = []
        self.mode_nodes: dict[int, list[int]] = {}
        self.by_sym: dict[int, list[int]] = {}
        # nodes
        self.Q = np.zeros((1024, problem.model.dof))
        self.node_mode: list[int] = []
        self.node_parent: list[int] = []
        self.node_action: list[object | None] = []   # action executed at the parent to get here
        # heuristic entries (symbolic state, action or None, base priority) with their Fail/
        # Success counts: Algorithm 1's table (planet's success_scale is taken unchecked)
        self.table = ScaledPriorities(gamma=options.gamma, focus=options.focus, strict=False)
        self.targets: list[_Target] = []
        self.goal_node: int | None = None
        self.counts = {"iterations": 0, "heuristic_samples": 0, "normal_samples": 0,
                       "projections": 0, "projected_valid": 0, "transitions": 0,
                       "connect_failures": 0}

    @classmethod
    def from_options(cls, problem: PlanningProblem, seed: int = 0,
                     overrides: dict | None = None) -> "UnifiedPlanner":
        """The registry's factory: options from the run configuration's parameters (planet's
        ``coin_bias``, ``success_scale``, ``goal_weight``), ``overrides`` (the command line's
        ``heuristic_bias``; None = not given) winning. E825 for a bias outside [0, 1]."""
        config = problem.world.config
        params = dict(config.params) if config is not None else {}
        bias = (overrides or {}).get("heuristic_bias")
        if bias is None:
            bias = params.get("coin_bias", UnifiedOptions.heuristic_bias)
        if not 0.0 <= bias <= 1.0:
            raise InputError(error("E825", f"heuristic bias {bias} must be within [0, 1]", None))
        opts = UnifiedOptions(heuristic_bias=float(bias),
                              gamma=float(params.get("success_scale", UnifiedOptions.gamma)),
                              goal_weight=float(params.get("goal_weight",
                                                           UnifiedOptions.goal_weight)))
        return cls(problem, seed=seed, options=opts)

    # ---- tree ----------------------------------------------------------------------------------
    def _add_node(self, q: np.ndarray, mode: Mode, parent: int, action=None) -> int:
        i = len(self.node_mode)
        if i == len(self.Q):
            self.Q = np.concatenate([self.Q, np.zeros_like(self.Q)])
        self.Q[i] = q
        self.node_mode.append(mode.id)
        self.node_parent.append(parent)
        self.node_action.append(action)
        self.mode_nodes[mode.id].append(i)
        return i

    def _add_mode(self, mode: Mode) -> None:
        self.modes.append(mode)
        self.mode_nodes[mode.id] = []
        if mode.sym in self.by_sym:
            self.by_sym[mode.sym].append(mode.id)
            return
        # entries are per symbolic state (Algorithm 1's Fail/Success count per state and
        # action), so a second mode with the same symbolic state does not duplicate them
        self.by_sym[mode.sym] = [mode.id]
        t = time.perf_counter()
        suggestions = self.h.suggest(mode.sym)
        for action, pri in suggestions:
            if action is None:
                pri, after = self.opt.goal_weight, 0.0
            else:
                after = self.h.h(self.p.ground.apply(mode.sym, action))
            self.table.add(mode.sym, action, pri, after)
        self.p.timers.heuristic += time.perf_counter() - t

    def _nearest(self, mode: Mode, q: np.ndarray) -> int:
        nodes = self.mode_nodes[mode.id]
        d = self.p.distance(self.Q[nodes], q)
        return nodes[int(np.argmin(d))]

    def _h(self, sym: int) -> float:
        t = time.perf_counter()
        v = self.h.h(sym)
        self.p.timers.heuristic += time.perf_counter() - t
        return v

    # ---- the loop ------------------------------------------------------------------------------
    def solve(self, time_limit: float, progress=None) -> UnifiedResult:
        p = self.p
        start = time.perf_counter()
        self._add_mode(p.initial)
        root = self._add_node(p.q0, p.initial, -1)
        status = "partial"
        try:
            if self._reached_goal(root):
                status = "solved"
            while status != "solved" and time.perf_counter() - start < time_limit:
                self.counts["iterations"] += 1
                if self.rng.random() < self.opt.heuristic_bias or not self.targets:
                    self._heuristic_sample()
                else:
                    self._normal_sample()
                if self.goal_node is not None:
                    status = "solved"
                if progress is not None:
                    progress(self)
        except KeyboardInterrupt:
            status = "interrupted"
            self.counts["interrupted"] = True     # callers stop a sweep even if it solved
        seconds = time.perf_counter() - start
        end = self.goal_node if self.goal_node is not None else self._best_node()
        path = self._path(end)
        if self.goal_node is not None:
            t = time.perf_counter()
            path = self._shortcut(path)
            self.counts["shortcut_seconds"] = round(time.perf_counter() - t, 4)
        stats = dict(self.counts, seconds=round(seconds, 4), nodes=len(self.node_mode),
                     modes=len(self.modes), time=p.timers.as_dict())
        return UnifiedResult("solved" if self.goal_node is not None else
                             ("interrupted" if status == "interrupted" else "partial"), path, stats)

    def _heuristic_sample(self) -> None:
        p = self.p
        self.counts["heuristic_samples"] += 1
        e = self.table.choose(self.rng)
        if e is None:
            self._normal_sample(uniform_only=True)
            return
        sym, action, _ = self.table.entries[e]
        modes = self.by_sym[sym]
        # the newest mode of that symbolic state half of the time, else any of them
        mode = self.modes[modes[-1] if self.rng.random() < 0.5 else
                          modes[int(self.rng.integers(len(modes)))]]
        if action is not None and not p.has_geometry(action):
            # a purely discrete action happens wherever the robot already is in that mode
            nodes = self.mode_nodes[mode.id]
            node = nodes[int(self.rng.integers(len(nodes)))]
            self.table.record_success(e)
            self._transition(node, mode, action)
            return
        t = time.perf_counter()
        starts = self._starts(mode)
        p.timers.sampling += time.perf_counter() - t
        self.counts["projections"] += 1
        found = p.project(mode, action, starts)
        if not len(found):
            self.table.record_failure(e)
            return
        self.counts["projected_valid"] += 1
        # the projected configuration nearest to the mode's tree becomes the target
        nodes = self.mode_nodes[mode.id]
        dists = np.array([self.p.distance(self.Q[nodes], q).min() for q in found])
        q = p.wrap(found[int(np.argmin(dists))])
        target = _Target(q, mode, action, e)
        if not self._connect(target):
            self.targets.append(target)
            if len(self.targets) > self.opt.max_targets:
                self.targets.pop(0)

    def _starts(self, mode: Mode) -> np.ndarray:
        p, n = self.p, PROJECTION_BATCH
        k = int(round(n * self.opt.near_starts))
        nodes = self.mode_nodes[mode.id]
        near = self.Q[self.rng.choice(nodes, size=k)]
        near = near + self.rng.normal(0.0, 0.3, near.shape) * (p.upper - p.lower) / \
            np.maximum(p.upper - p.lower, 1.0)
        return np.concatenate([p.wrap(near), p.uniform(self.rng, n - k)])

    def _normal_sample(self, uniform_only: bool = False) -> None:
        self.counts["normal_samples"] += 1
        if self.targets and not uniform_only and self.rng.random() < self.opt.target_bias:
            # goal bias toward a pending target, recent ones first
            k = len(self.targets)
            w = np.arange(1, k + 1, dtype=float)
            target = self.targets[int(self.rng.choice(k, p=w / w.sum()))]
            if self._connect(target):
                self.targets.remove(target)
            elif target.tries > 20:
                self.targets.remove(target)
                self.table.record_failure(target.entry)
            return
        t = time.perf_counter()
        mode = self._pick_mode()
        q = self.p.uniform(self.rng, 1)[0]
        self.p.timers.sampling += time.perf_counter() - t
        self._extend(mode, q, self.opt.step)

    def _pick_mode(self) -> Mode:
        """A reached mode, with the weight of its best scaled entry (modes near the goal and with
        untried actions first); uniform when no entry has weight."""
        if self.targets and self.rng.random() < 0.5:
            return self.targets[int(self.rng.integers(len(self.targets)))].mode
        best: dict[int, float] = {}
        for (sym, _, _), s in zip(self.table.entries, self.table.weights()):
            best[sym] = max(best.get(sym, 0.0), s)
        w = np.array([best.get(m.sym, 0.0) for m in self.modes])
        w += 1e-3 * (w.max() if w.max() > 0 else 1.0)
        return self.modes[int(self.rng.choice(len(w), p=w / w.sum()))]

    def _extend(self, mode: Mode, q: np.ndarray, step: float | None) -> tuple[int, bool]:
        """Grow from the nearest node of ``mode`` toward ``q`` (at most ``step`` far); returns
        (the last node, reached q)."""
        p = self.p
        near = self._nearest(mode, q)
        q0 = self.Q[near]
        d = p.difference(q, q0)
        length = float(np.linalg.norm(d))
        if length < 1e-9:
            return near, True
        full = step is None or length <= step
        goal = q0 + d * (1.0 if full else step / length)
        frac = p.motion(mode, q0, goal, self.opt.resolution)
        if frac >= 1.0:
            return self._add_node(p.wrap(goal), mode, near), full
        if frac * min(length, step or length) > 0.05:
            return self._add_node(p.wrap(q0 + (goal - q0) * frac), mode, near), False
        return near, False

    def _connect(self, target: _Target) -> bool:
        """Try to reach a target; on arrival realise its transition (or the goal)."""
        target.tries += 1
        node, reached = self._extend(target.mode, target.q, None)
        if not reached:
            self.counts["connect_failures"] += 1
            return False
        self.table.record_success(target.entry)
        if target.action is None:
            if self.p.holds(target.mode, None, self.Q[node]):
                self.goal_node = node
            return True
        self._transition(node, target.mode, target.action)
        return True

    def _transition(self, node: int, mode: Mode, action) -> None:
        p = self.p
        q = self.Q[node].copy()
        new = p.successor_mode(mode, action, q, len(self.modes))
        self.counts["transitions"] += 1
        self._add_mode(new)
        child = self._add_node(q, new, node, action)
        self._reached_goal(child)

    def _reached_goal(self, node: int) -> bool:
        mode = self.modes[self.node_mode[node]]
        if not self.p.ground.goal.holds(mode.sym):
            return False
        if self.p.goal_formula() is None or self.p.holds(mode, None, self.Q[node]):
            self.goal_node = node
            return True
        return False

    # ---- results -------------------------------------------------------------------------------
    def _best_node(self) -> int:
        """The node of the reached mode closest to the goal (smallest h, then deepest)."""
        best, key = 0, (math.inf, 0)
        for m in self.modes:
            nodes = self.mode_nodes[m.id]
            if not nodes:
                continue
            k = (self._h(m.sym), -m.id)
            if k < key:
                best, key = nodes[0], k
        return best

    def _path(self, end: int) -> list[tuple[np.ndarray, Mode, object | None]]:
        chain = []
        i = end
        while i >= 0:
            chain.append(i)
            i = self.node_parent[i]
        chain.reverse()
        out = []
        for k, i in enumerate(chain):
            nxt = chain[k + 1] if k + 1 < len(chain) else None
            action = self.node_action[nxt] if nxt is not None else None
            out.append((self.Q[i].copy(), self.modes[self.node_mode[i]], action))
        return out

    def _shortcut(self, path):
        """Random shortcuts inside each mode segment (the configurations where actions happen
        stay)."""
        out, seg = [], []
        for item in path:
            seg.append(item)
            if item[2] is not None:
                out.extend(self._shortcut_segment(seg))
                seg = []
        out.extend(self._shortcut_segment(seg))
        return out

    def _shortcut_segment(self, seg):
        if len(seg) <= 2:
            return seg
        seg = list(seg)
        for _ in range(self.opt.shortcut_tries):
            if len(seg) <= 2:
                break
            i, j = sorted(self.rng.choice(len(seg), size=2, replace=False))
            if j - i < 2:
                continue
            mode = seg[i][1]
            if self.p.motion(mode, seg[i][0], seg[j][0], self.opt.resolution) >= 1.0:
                seg = seg[:i + 1] + seg[j:]
        return seg


__all__ = ["UnifiedPlanner", "UnifiedOptions", "UnifiedResult"]
