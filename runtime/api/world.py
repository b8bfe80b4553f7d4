"""A loaded world for Python callers: plan (again, from any start, without loading anything
twice), validate, view, evaluate and sample; :func:`load`, :func:`check` and :func:`compile`."""

from __future__ import annotations

import json
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any, Callable

import numpy as np

from tmpc.compiler.artifact import open_world
from tmpc.compiler.compile import compile_world
from tmpc.compiler.export import build_artifact
from tmpc.compiler.state import WorldState, initial_state, state_from_json, state_to_json
from tmpc.lang.diagnostics import Diagnostic, InputError, TmpcError, error
from tmpc.lang.inputs import World as LoadedWorld
from tmpc.lang.program import check_paths
from tmpc.lang.source import SourceFile
from tmpc.runtime.api.plan import Plan, plan_cost
from tmpc.runtime.api.symbolic import start_symbols
from tmpc.runtime.collision import collision_world
from tmpc.runtime.explain import explain
from tmpc.runtime.plans import parse_plan, plan_document
from tmpc.runtime.probe import predicate_at, sample_states, sample_target, sampled_state
from tmpc.runtime.problem import PlanningProblem, register_run_kernels
from tmpc.runtime.solve import open_input, plan_problem, replan
from tmpc.runtime.validate import validate_plan
from tmpc.runtime.viewer import write_html, write_png

#: a start: one of a plan's ``states``, a state JSON value or file (as ``tmpc eval --state``
#: reads it), or None for the scene's start
Start = dict[str, Any] | str | Path | None


class World:
    """A world loaded by :func:`load`. The first :meth:`plan` sets up the planning problem
    (kernel loads, collision world); later calls reuse it, from any start."""

    def __init__(self, world: LoadedWorld, path: str | Path, opened: dict[str, Any]) -> None:
        self.world = world
        self.path = str(path)
        #: seconds loading (``load``) or compiling (``compile``) took, and how (``kernels``)
        self.opened = opened
        self.problem: PlanningProblem | None = None
        #: seconds from the last :meth:`plan` call to its planner's ``solve``
        self.last_overhead: float | None = None

    def __repr__(self) -> str:
        return f"<tmpc.World {self.path}>"

    # ---- compile ------------------------------------------------------------------------------
    def compile(self, out: str | Path | None = None) -> Path | None:
        """Compile the world's kernels (done at most once per world); with ``out``, write them
        as a self-contained artifact (``tmpc compile``) and return its path."""
        if self.world.program is None:
            raise InputError(error("E585", f"{self.path}: a scene alone cannot be compiled; give "
                                   "a run configuration that names the domain and problem", None))
        if out is None:
            compile_world(self.world)
            return None
        build_artifact(self.world, str(out), register_run_kernels)
        return Path(out)

    # ---- states -------------------------------------------------------------------------------
    def state(self, start: Start = None) -> dict[str, Any]:
        """A state as state JSON (the scene's start by default), mode atoms included."""
        st = self.start_state(start)
        compiled = compile_world(self.world)
        out = state_to_json(st, compiled.model)
        gp = compiled.ground if self.world.program is not None and \
            self.world.program.problem is not None else None
        if gp is not None:
            sym = start_symbols(compiled, st, start is not None)
            out["mode"] = {"atoms": gp.shown_atoms(sym),
                           "held": {o: f for o, (f, _) in sorted(st.held.items())}}
        return out

    def start_state(self, start: Start = None) -> WorldState:
        """``start`` read over the scene's start (:class:`~tmpc.compiler.state.WorldState`)."""
        model = compile_world(self.world).model
        base = initial_state(self.world.scene, model)
        if start is None:
            return base
        if isinstance(start, (str, Path)):
            try:
                data = json.loads(Path(start).read_text(encoding="utf-8"))
            except OSError as exc:
                raise InputError(error("E010", f"cannot read {start}: {exc.strerror}",
                                       None)) from None
            except json.JSONDecodeError as exc:
                raise InputError(error("E580", f"{start}:{exc.lineno}:{exc.colno}: not valid "
                                       f"JSON: {exc.msg}", None)) from None
            return state_from_json(data, self.world.scene, model, base, str(start))
        return state_from_json(dict(start), self.world.scene, model, base)

    def evaluate(self, predicate: str, args: Iterable[str] = (),
                 state: Start = None) -> dict[str, Any]:
        """A geometric predicate at a state: ``value`` (truth), ``distance`` and ``gradient``
        (d distance / d q by configuration name), as ``tmpc eval --predicate``."""
        compiled = compile_world(self.world)
        return predicate_at(compiled, self.start_state(state), [predicate, *args])

    def sample(self, predicate: str, args: Iterable[str] = (), n: int = 1, seed: int = 0,
               action: bool = False, state: Start = None, collisions: bool = False,
               iterations: int = 30, max_starts: int = 20000) -> list[dict[str, Any]]:
        """Up to ``n`` states (state JSON) where the geometric predicate (with ``action``: the
        action's geometric precondition) holds, collision-free unless ``collisions``; as
        ``tmpc sample``. Fewer (or none) when ``max_starts`` starts found no more."""
        compiled = compile_world(self.world)
        if compiled.model is None:
            raise InputError(error("E584", "the scene has no robot to move", None))
        formula, ids = sample_target(compiled, [predicate, *args], action)
        st = self.start_state(state)
        checker = None if collisions else collision_world(self.world, compiled)
        got = sample_states(compiled, formula, ids, st, n, np.random.default_rng(seed),
                            iterations, max_starts, checker)
        return [sampled_state(compiled, st, q) for q in got.found]

    # ---- planning -----------------------------------------------------------------------------
    def plan(self, planner: str | None = None, seed: int = 0, time_limit: float | None = None,
             start: Start = None, first_solution: bool | None = None,
             options: dict[str, Any] | None = None,
             progress: Callable[[Any], None] | None = None,
             simplify: str | None = None) -> Plan:
        """Plan from ``start`` (None: the scene's start) with the registered ``planner`` (None:
        the manifest's ``[planner] name``, else ``optimal``, as ``tmpc run``); a :class:`Plan`
        whether or not one was found. ``time_limit``: the seconds to plan (and, for an
        anytime planner, to improve its plan); None: the manifest's ``time_limit``, else
        120 s, stopping at the first plan. ``first_solution``: an anytime planner stops at
        its first plan (default: when no ``time_limit`` is given); ``options``: the planner's
        other options (``tmpc run``'s flags, e.g. ``{"batch_size": 200}``). The first call
        sets up the planning problem; later calls reuse it (no load, no compile) and time
        their set-up in :attr:`last_overhead`. ``simplify="ompl"``: OMPL's path simplifier on
        the final plan's motions (``tmpc run --simplify ompl``; default ``"tmpc"``: the
        planner's own)."""
        t0 = time.perf_counter()
        overrides = dict(options or {})
        if simplify is not None:
            overrides["simplify"] = simplify
        if first_solution is None and time_limit is None:
            first_solution = True
        if first_solution is not None:
            overrides["first_solution"] = first_solution
        config = self.world.config
        if planner is None:
            planner = config.planner if config is not None and config.planner else "optimal"
        if time_limit is None:
            time_limit = config.time_limit if config is not None and config.time_limit \
                else 120.0
        if self.problem is None and start is None:
            problem, result, setup = plan_problem(self.world, planner, seed, time_limit,
                                                  overrides, progress)
            self.problem = problem
        else:
            if self.problem is None:
                self.problem = plan_problem_setup(self.world, planner, seed)
            problem = self.problem
            state, sym = None, None
            if start is not None:
                state = self.start_state(start)
                sym = start_symbols(problem.compiled, state, True)
            result, setup = replan(problem, planner, seed, time_limit, overrides, state, sym,
                                   progress)
        self.last_overhead = setup
        doc = plan_document(problem, result, planner=planner, seed=seed,
                            input_path=self.path, setup_seconds=setup)
        doc["stats"]["plan_seconds"] = round(time.perf_counter() - t0, 4)
        why = None if result.status == "solved" else explain(problem, result.status)
        return Plan(doc, plan_cost(result, problem), why,
                    [mode.sym for _, mode, _ in result.path], replanned=start is not None)

    def validate(self, plan: Plan | dict[str, Any] | str | Path, strict: bool = False,
                 start: str | None = None) -> Any:
        """The independent validator's report on ``plan`` (a :class:`Plan`, a plan document or
        a plan file): ``valid``, ``violations`` (each with ``state``, ``kind``, ``message``),
        ``warnings``, ``summary()`` and ``text()``. ``start``: ``"scene"`` (the plan must start
        at the scene's start) or ``"plan"`` (its first state is the start, as for a plan made
        by replanning from an observed state); default: ``"plan"`` for a :class:`Plan` planned
        from another start, else ``"scene"``."""
        if start is None:
            start = "plan" if isinstance(plan, Plan) and plan.replanned else "scene"
        if isinstance(plan, (str, Path)):
            return validate_plan(self.world, str(plan), strict=strict, start=start)
        doc = plan.document if isinstance(plan, Plan) else plan
        parsed = parse_plan(SourceFile("<plan>", json.dumps(doc)))
        return validate_plan(self.world, parsed, strict=strict, start=start)

    def view(self, plan: Plan | dict[str, Any], html: str | Path | None = None,
             png: str | Path | None = None) -> None:
        """Write the animated viewer page (``html``) and/or a PNG of the last state (``png``),
        as ``tmpc view``."""
        doc = plan.document if isinstance(plan, Plan) else plan
        if html is not None:
            write_html(self.world, doc, str(html))
        if png is not None:
            write_png(self.world, doc, str(png))


def plan_problem_setup(world: LoadedWorld, planner: str, seed: int) -> PlanningProblem:
    """A planning problem set up as the first :meth:`World.plan` sets it up, without planning
    (a first call with a ``start``)."""
    problem, _, _ = plan_problem(world, planner, seed, 0.0, {"first_solution": True})
    return problem


def load(path: str | Path) -> World:
    """A run configuration (manifest TOML, planet TOML, tmit-star spec), an artifact (``.tmpa``)
    or a scene, loaded as ``tmpc run`` loads it (through the artifact cache: compiled on a
    machine's first load). Bad input raises :class:`~tmpc.lang.diagnostics.TmpcError` with
    its diagnostics."""
    world, opened = open_input(str(path))
    return World(world, path, opened)


def compile(path: str | Path, out: str | Path) -> Path:  # noqa: A001 - the API's name
    """Compile ``path`` into the artifact ``out`` (``tmpc compile``); returns ``out``."""
    world = open_world(str(path))
    if world.program is None:
        raise InputError(error("E585", f"{path}: a scene alone cannot be compiled; give a run "
                               "configuration that names the domain and problem", None))
    build_artifact(world, str(out), register_run_kernels)
    return Path(out)


def check(paths: str | Path | Iterable[str | Path]) -> list[Diagnostic]:
    """Parse and check files (``tmpc check``'s front end: domains, problems, scenes, run
    configurations): the diagnostics, each with ``code``, ``severity``, ``message``, ``span``
    and ``hint``; empty when all is well."""
    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    try:
        return list(check_paths([str(p) for p in items]).diagnostics)
    except TmpcError as exc:
        return list(exc.diagnostics)
