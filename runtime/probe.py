"""What ``tmpc eval`` and ``tmpc sample`` compute at states: a state read from JSON, a geometric
predicate's truth, distance and gradient from its compiled kernel, and states found by the
projection sampler."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tmpc.compiler.kernels import state_inputs, uniform_starts
from tmpc.compiler.state import initial_state, state_from_json
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
    kernel, _ = compiled.kernels(formula)
    q, obj_T, parent = state_inputs(compiled.tables, state)
    truth, dist = kernel(q, obj_T, parent, ids)
    grad = compiled.distance_grad(formula)(q, obj_T, parent, ids)[1] if len(q) else []
    names = compiled.model.q_names if compiled.model is not None else ()
    return {"value": bool(truth), "distance": float(dist),
            "gradient": {n: float(g) for n, g in zip(names, grad)}}


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
