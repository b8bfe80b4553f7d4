"""What ``tmpc eval`` and ``tmpc sample`` compute at states: a state read from JSON, a geometric
predicate's truth, distance and gradient from its compiled kernel, the goal's truth, and states
found by the projection sampler (and the state JSON they print)."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from tmpc.compiler.compile import compile_world
from tmpc.compiler.kernels import state_inputs, uniform_starts
from tmpc.compiler.state import initial_state, state_from_json, state_to_json
from tmpc.lang.diagnostics import InputError, error


def read_state(world, model, path: str | None):
    """The state in JSON file ``path`` (``-``: stdin) over the scene's start; None: the start."""
    base = initial_state(world.scene, model)
    if path is None:
        return base
    try:
        text = sys.stdin.read() if path == "-" else Path(path).read_text(encoding="utf-8")
        data = json.loads(text)
    except OSError as exc:
        raise InputError(error("E010", f"cannot read {path}: {exc.strerror}", None)) from None
    except json.JSONDecodeError as exc:
        raise InputError(error("E580", f"{path}:{exc.lineno}:{exc.colno}: not valid JSON: "
                               f"{exc.msg}", None)) from None
    return state_from_json(data, world.scene, model, base, path)


def predicate_at(compiled, state, request: list[str]) -> dict:
    """Truth, distance and gradient (by configuration name) of the geometric predicate
    ``request = [name, arg...]`` at ``state``, from its compiled kernel."""
    if compiled.program is None:
        raise InputError(error("E585", "--predicate needs a domain: pass a run configuration "
                               "(manifest TOML, planet TOML or tmit-star spec)", None))
    formula = compiled.predicate(request[0])
    ids = compiled.bind_args(formula, request[1:])
    truth, dist = condition_at(compiled, state, formula, ids)
    q, obj_T, parent = state_inputs(compiled.tables, state)
    grad = compiled.distance_grad(formula)(q, obj_T, parent, ids)[1] if len(q) else []
    names = compiled.model.q_names if compiled.model is not None else ()
    return {"value": truth, "distance": dist,
            "gradient": {n: float(g) for n, g in zip(names, grad)}}


def condition_at(compiled, state, formula, ids) -> tuple[bool, float]:
    """(truth, unsatisfaction distance) of ``formula`` bound to entity ids ``ids (k,)`` at
    ``state``, from its compiled condition kernel."""
    kernel, _ = compiled.kernels(formula)
    q, obj_T, parent = state_inputs(compiled.tables, state)
    truth, dist = kernel(q, obj_T, parent, ids)
    return bool(truth), float(dist)


def goal_at(compiled, state) -> dict:
    """The goal at ``state``: ``holds`` (discrete atoms by the problem's initial state, with
    derived atoms and geometric literals decided at ``state``), ``distance`` (of the goal's
    geometric literals, 0.0 when it has none) and ``unmet`` (the goal's top-level discrete
    literals that are false, as ``(p a b)`` / ``(not (p a b))``)."""
    gp = compiled.ground

    def geo(pred: str, args: tuple[str, ...]) -> bool:
        formula = compiled.predicate(pred)
        return condition_at(compiled, state, formula, compiled.bind_args(formula, list(args)))[0]
    atoms = gp.evaluate_derived(gp.init, geo)
    distance = 0.0
    if compiled.goal is not None:
        distance = condition_at(compiled, state, compiled.goal, np.zeros(0, np.int64))[1]
    unmet = [gp.atom_name(i) for i in sorted(gp.goal.pos) if not atoms >> i & 1]
    unmet += [f"(not {gp.atom_name(i)})" for i in sorted(gp.goal.neg) if atoms >> i & 1]
    return {"holds": bool(gp.goal_satisfied(atoms, geo)), "distance": distance, "unmet": unmet}


def sampling_program(world):
    """The compiled program of ``world`` for sampling: E585 without a domain, E584 without a
    robot to move."""
    if world.program is None:
        raise InputError(error("E585", "`tmpc sample` needs a domain: pass a run configuration "
                               "(manifest TOML, planet TOML or tmit-star spec)", None))
    compiled = compile_world(world)
    if compiled.model is None:
        raise InputError(error("E584", "the scene has no robot to move", None))
    return compiled


def sample_target(compiled, request: list[str], action: bool = False):
    """(formula, entity ids) of ``request = [name, arg...]``: a geometric predicate, or with
    ``action`` an action schema's geometric precondition."""
    name, names = request[0], list(request[1:])
    formula = compiled.action(name) if action else compiled.predicate(name)
    return formula, compiled.bind_args(formula, names)


def sampled_state(compiled, state, q) -> dict:
    """The state JSON ``tmpc sample`` prints for configuration ``q (n,)`` in ``state``'s mode
    (``tmpc eval --state`` reads it back)."""
    return state_to_json(replace(state, q=q), compiled.model, compiled.fk(q))


@dataclass
class Samples:
    """Configurations found, and why the other starts were rejected."""

    found: list
    tried: int = 0
    unconverged: int = 0
    colliding: int = 0


def sample_states(compiled, formula, ids, state, n: int, rng: np.random.Generator,
                  iterations: int, max_starts: int, checker=None) -> Samples:
    """Up to ``n`` configurations where ``formula`` (bound to entity ids ``ids``) holds in
    ``state``'s mode, projected from uniform starts in batches; with a collision ``checker``,
    only collision-free ones."""
    model = compiled.model
    _, obj_T, parent = state_inputs(compiled.tables, state)
    project = compiled.projector(formula)
    steps = np.int64(iterations)
    out = Samples([])
    batch = max(64, min(1024, 8 * n))
    while len(out.found) < n and out.tried < max_starts:
        Q0 = uniform_starts(rng, model.lower, model.upper, batch)
        Q, holds, _ = (np.asarray(x) for x in project(Q0, obj_T, parent, ids, steps))
        out.tried += batch
        out.unconverged += int((~holds).sum())
        Q = Q[holds]
        if checker is not None and len(Q):
            ok = np.asarray(checker.check_batch(Q, poses=state.poses, attached=state.held))
            out.colliding += int((~ok).sum())
            Q = Q[ok]
        out.found.extend(Q[: n - len(out.found)])
    return out
