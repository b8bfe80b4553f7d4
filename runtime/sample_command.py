"""`tmpc sample INPUT (--predicate NAME ARG... | --action NAME ARG...) -n N [--seed S]`.

States where a geometric predicate (or an action's geometric precondition) holds, found by the
projection sampler from uniformly random start configurations, collision-free unless
``--allow-collisions``. Prints one state JSON per line; reports on stderr how many starts were
tried and why the others were rejected. Exit 3 when no state was found within the limits.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace

import numpy as np

from tmpc.lang.diagnostics import InputError, error

EXIT_NOT_FOUND = 3


def run_sample(args) -> int:
    from tmpc.compiler.compile import CompiledProgram
    from tmpc.compiler.jaxgen import state_inputs
    from tmpc.compiler.project import make_projector, uniform_starts
    from tmpc.compiler.state import state_to_json
    from tmpc.runtime.eval_command import read_state
    from tmpc.runtime.world import load_world
    world = load_world(args.input)
    if world.program is None:
        raise InputError(error("E582", "`tmpc sample` needs a domain: pass a run configuration "
                               "(manifest TOML, planet TOML or tmit-star spec)", None))
    if world.model is None:
        raise InputError(error("E584", "the scene has no robot to move", None))
    compiled = CompiledProgram(world.program, world.scene, world.model,
                               external=load_external(world))
    name, names = (args.predicate or args.action)[0], (args.predicate or args.action)[1:]
    formula = compiled.action(name) if args.action else compiled.predicate(name)
    ids = compiled.bind_args(formula, names)
    kernel, _ = compiled.kernels(formula)
    state = read_state(world, args.state)
    q0, obj_T, parent = state_inputs(compiled.world, state)
    model = world.model
    project = make_projector(kernel, model.lower, model.upper, iterations=args.iterations)
    checker = None if args.allow_collisions else world.collision()
    rng = np.random.default_rng(args.seed)
    found, tried, unconverged, colliding = [], 0, 0, 0
    batch = max(64, min(1024, 8 * args.n))
    while len(found) < args.n and tried < args.max_starts:
        Q0 = uniform_starts(rng, model.lower, model.upper, batch)
        Q, holds, _ = (np.asarray(x) for x in project(Q0, obj_T, parent, ids))
        tried += batch
        unconverged += int((~holds).sum())
        Q = Q[holds]
        if checker is not None and len(Q):
            ok = np.asarray(checker.check_batch(Q, poses=state.poses, attached=state.held))
            colliding += int((~ok).sum())
            Q = Q[ok]
        found.extend(Q[: args.n - len(found)])
    for q in found:
        sys.stdout.write(json.dumps(state_to_json(replace(state, q=q), model, world.fk(q))) + "\n")
    sys.stderr.write(f"{len(found)} of {args.n} state(s) from {tried} starts; rejected: "
                     f"{unconverged} did not converge, {colliding} in collision\n")
    return 0 if found else EXIT_NOT_FOUND


def load_external(world) -> dict:
    """IR of the Lua predicates named by the run configuration, if the Lua front end is there."""
    cfg = world.config
    if cfg is None or cfg.semantics is None:
        return {}
    from tmpc.compiler.compile import external_predicates
    return external_predicates(cfg.semantics, world.program)
