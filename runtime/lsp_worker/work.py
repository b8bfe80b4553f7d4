"""The worker's requests as library functions: a witness state, evaluation at the start state,
the static checks. Each takes a run configuration path ``config`` (whatever ``tmpc sample`` and
``tmpc eval`` take as input) and returns plain JSON values.

They compute what the commands compute, through the same library functions
(:mod:`tmpc.runtime.probe`, :func:`~tmpc.compiler.smt.static_checks`,
:func:`~tmpc.runtime.geo_checks.geometric_checks`). Loaded worlds are kept in :data:`WORLDS`,
keyed by the configuration's path and the (mtime_ns, size) of every file it was loaded from, so
a second request on unchanged files reuses the compiled program and its jitted kernels, and an
edited file is loaded and compiled anew. Kernels the process has not compiled yet come from
XLA's persistent compilation cache (:mod:`tmpc.compiler.jaxcfg`), parsed URDFs from the robot
cache (:mod:`tmpc.compiler.cache`), as for ``tmpc sample``.
"""

from __future__ import annotations

import itertools
import os
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from math import prod
from pathlib import Path
from typing import Sequence

import numpy as np

from tmpc.compiler.artifact import open_world
from tmpc.compiler.compile import compile_world
from tmpc.compiler.smt import static_checks as smt_static_checks
from tmpc.lang.inputs import World
from tmpc.lang.scope import type_keys
from tmpc.runtime.collision import collision_world
from tmpc.runtime.lsp_worker.wire import diagnostic_to_json
from tmpc.runtime.geo_checks import geometric_checks
from tmpc.runtime.probe import (
    condition_at,
    goal_at,
    read_state,
    sample_states,
    sample_target,
    sampled_state,
    sampling_program,
)
from tmpc.runtime.viewer import write_html

#: groundings :func:`evaluate` evaluates at most for one action or predicate
MAX_GROUNDINGS = 2000

Stamp = tuple[int, int] | None


# ---- the cache of loaded worlds ------------------------------------------------------------
@dataclass(eq=False)
class Loaded:
    """A world loaded from a configuration and the stamps of the files it was read from. Its
    compiled program is the compiler's (one per world object); the collision checker and the
    static checks' results are kept here once computed."""

    world: World
    stamps: dict[str, Stamp]
    _checker: object = None
    static: dict = field(default_factory=dict)

    @property
    def compiled(self):
        return compile_world(self.world)

    def checker(self):
        """The collision checker ``tmpc sample`` uses (default tolerance), built once."""
        if self._checker is None:
            self._checker = collision_world(self.world, self.compiled)
        return self._checker

    def fresh(self) -> bool:
        """Are all the files it was loaded from unchanged?"""
        return all(_stamp(p) == s for p, s in self.stamps.items())


class WorldCache:
    """Loaded worlds by configuration path, at most ``size`` (least recently used dropped).
    ``loads`` counts the worlds loaded (a test can see that a second request loaded none)."""

    def __init__(self, size: int = 8):
        self.size = size
        self.loads = 0
        self._entries: OrderedDict[str, Loaded] = OrderedDict()

    def get(self, config: str | os.PathLike) -> Loaded:
        key = str(Path(config).resolve())
        hit = self._entries.get(key)
        if hit is not None and hit.fresh():
            self._entries.move_to_end(key)
            return hit
        self._entries.pop(key, None)
        before = _stamp(key)
        world = open_world(key)
        stamps = {p: _stamp(p) for p in input_files(world)}
        stamps[key] = before        # an edit while loading shows at the next request
        self._entries[key] = Loaded(world, stamps)
        self.loads += 1
        while len(self._entries) > self.size:
            self._entries.popitem(last=False)
        return self._entries[key]

    def clear(self) -> None:
        self._entries.clear()


#: the worker's loaded worlds
WORLDS = WorldCache()


def input_files(world: World) -> list[str]:
    """The files a loaded world was read from (absolute): every source it loaded (configuration,
    domain, problem, included modules, scene) and the configuration's Lua predicates and
    allowed-collision list."""
    names = {p for p in world.files if not str(p).startswith("<")}
    cfg = world.config
    if cfg is not None:
        names.update(str(p) for p in (cfg.path, cfg.domain, cfg.problem, cfg.scene,
                                      cfg.semantics, cfg.allowed_collisions) if p)
    return sorted({str(Path(p).resolve()) for p in names})


def _stamp(path: str) -> Stamp:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


# ---- requests ------------------------------------------------------------------------------
def witness(config, *, predicate: str | None = None, action: str | None = None,
            args: Sequence[str] | None = (), seed: int = 0, iterations: int = 30,
            max_starts: int = 20000) -> dict:
    """A collision-free state where geometric ``predicate`` (or ``action``'s geometric
    precondition) holds for ``args``, found as ``tmpc sample CONFIG --predicate NAME ARG... -n 1
    --seed SEED`` finds it (the same state for the same seed), in the scene's start mode.
    ``args=None``: the first grounding whose objects fit the parameter types (see
    :func:`evaluate`).

    Returns ``{"found", "args", "state" (the state JSON `tmpc sample` prints, or None),
    "joints" ({configuration name: value}), "distance" (the condition's unsatisfaction distance
    at the state, None when not found), "holds", "tried" (starts projected), "rejected":
    {"unconverged", "colliding"}}``.
    """
    name, is_action = _target(predicate, action, goal=False)
    loaded = WORLDS.get(config)
    compiled = sampling_program(loaded.world)
    if args is None:
        args = _first_grounding(compiled, name, is_action)
    formula, ids = sample_target(compiled, [name, *args], is_action)
    state = read_state(loaded.world, compiled.model, None)
    got = sample_states(compiled, formula, ids, state, 1, np.random.default_rng(seed),
                        iterations, max_starts, loaded.checker())
    out = {"found": bool(got.found), "args": list(args), "state": None, "joints": {},
           "distance": None, "holds": False, "tried": got.tried,
           "rejected": {"unconverged": got.unconverged, "colliding": got.colliding}}
    if got.found:
        q = np.asarray(got.found[0], float)
        holds, distance = condition_at(compiled, replace(state, q=q), formula, ids)
        out.update(state=sampled_state(compiled, state, q), holds=holds, distance=distance,
                   joints={n: float(v) for n, v in zip(compiled.model.q_names, q)})
    return out


def evaluate(config, *, predicate: str | None = None, action: str | None = None,
             args: Sequence[str] | None = None, goal: bool = False) -> dict:
    """Evaluate at the problem's start state (as ``tmpc eval CONFIG`` without ``--state``).

    * a predicate or action with ``args``: ``{"holds", "distance"}`` of the predicate (the
      action's geometric precondition);
    * ``goal=True``: ``{"holds", "distance", "unmet"}`` (:func:`~tmpc.runtime.probe.goal_at`);
    * a predicate or action with ``args=None``: every grounding whose objects fit the parameter
      types (objects in declaration order, the first parameter varying slowest), at most
      :data:`MAX_GROUNDINGS`: ``{"groundings" (how many fit), "evaluated", "skipped" (groundings
      naming an object that is neither a scene object nor a robot frame: not evaluated),
      "holding", "best": {"args", "holds", "distance"} (the smallest distance, the first on
      ties; None when none was evaluated), "truncated"}``.
    """
    name, is_action = _target(predicate, action, goal)
    loaded = WORLDS.get(config)
    compiled = sampling_program(loaded.world)
    state = read_state(loaded.world, compiled.model, None)
    if goal:
        return goal_at(compiled, state)
    if args is not None:
        holds, distance = condition_at(compiled, state,
                                       *sample_target(compiled, [name, *args], is_action))
        return {"holds": holds, "distance": distance}
    return _groundings(compiled, state, name, is_action)


def static_checks(config, budget: float = 2.0, geometry_budget: float = 20.0) -> list[dict]:
    """What ``tmpc check --static CONFIG`` adds to the plain check, as JSON diagnostics
    (:mod:`tmpc.runtime.lsp_worker.wire`): the SAT/relaxation checks of the configuration's program
    (W610-W613, within ``budget`` s) and the geometric ones (W614, within ``geometry_budget``
    s). Kept per loaded world: unchanged files are not checked again."""
    loaded = WORLDS.get(config)
    key = (float(budget), float(geometry_budget))
    if key not in loaded.static:
        world = loaded.world
        found = smt_static_checks(world.program, budget) if world.program is not None else []
        found = [*found, *geometric_checks(world, geometry_budget)]
        loaded.static[key] = [diagnostic_to_json(d) for d in found]
    return loaded.static[key]


def view(config, *, state: dict, out: str) -> dict:
    """The page ``tmpc view`` draws (:func:`~tmpc.runtime.viewer.write_html`, written
    atomically) of one state (a witness's state JSON) in the configuration's scene. Returns
    ``{"path", "bytes"}``."""
    loaded = WORLDS.get(config)
    if not isinstance(state, dict):
        raise ValueError("`state` must be a state object (what `tmpc sample` prints)")
    plan = {"format": "tmpc-plan/1", "status": "solved", "actions": [],
            "states": [{**state, "action": None}]}
    return {"path": str(out), "bytes": write_html(loaded.world, plan, out)}


# ---- helpers -------------------------------------------------------------------------------
def _target(predicate, action, goal: bool) -> tuple[str | None, bool]:
    """(name, is an action) of a request naming exactly one of predicate, action, goal."""
    given = [k for k, v in (("predicate", predicate), ("action", action), ("goal", goal)) if v]
    if len(given) != 1:
        raise ValueError("give exactly one of `predicate`, `action` and `goal`, not "
                         f"{' and '.join(given) or 'none'}")
    return (action, True) if action else (predicate, False)


def _candidates(compiled, formula) -> list[list[str]]:
    """Per parameter of ``formula``, the objects (declaration order) whose type fits it."""
    scope = compiled.program.scope
    return [[o.name.text for o in scope.objects.values()
             if scope.compatible(o.types, type_keys(p.type))] for p in formula.params]


def _first_grounding(compiled, name: str, is_action: bool) -> list[str]:
    """The first grounding of a predicate or action whose objects are all entities (the
    arguments :func:`witness` takes when given none); E588 through binding when none fits."""
    formula = compiled.action(name) if is_action else compiled.predicate(name)
    cands = [[n for n in c if compiled.tables.entity(n) is not None]
             for c in _candidates(compiled, formula)]
    return list(next(itertools.product(*cands), ()))


def _groundings(compiled, state, name: str, is_action: bool) -> dict:
    formula = compiled.action(name) if is_action else compiled.predicate(name)
    cands = _candidates(compiled, formula)
    usable = [[n for n in c if compiled.tables.entity(n) is not None] for c in cands]
    total, evaluable = prod(len(c) for c in cands), prod(len(c) for c in usable)
    holding, best = 0, None
    chosen = list(itertools.islice(itertools.product(*usable), MAX_GROUNDINGS))
    for args in chosen:
        holds, distance = condition_at(compiled, state, formula,
                                       compiled.bind_args(formula, list(args)))
        holding += holds
        if best is None or distance < best["distance"]:
            best = {"args": list(args), "holds": holds, "distance": distance}
    return {"groundings": total, "evaluated": len(chosen), "skipped": total - evaluable,
            "holding": holding, "best": best, "truncated": len(chosen) < evaluable}
