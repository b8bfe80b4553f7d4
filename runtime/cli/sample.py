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

from tmpc.compiler.artifact import open_world
from tmpc.compiler.compile import compile_world
from tmpc.compiler.state import state_to_json
from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.cli.exits import EXIT_NOT_FOUND, EXIT_OK
from tmpc.runtime.collision import collision_world
from tmpc.runtime.probe import read_state, sample_states


def run_sample(args) -> int:
    world = open_world(args.input)
    if world.program is None:
        raise InputError(error("E585", "`tmpc sample` needs a domain: pass a run configuration "
                               "(manifest TOML, planet TOML or tmit-star spec)", None))
    compiled = compile_world(world)
    if compiled.model is None:
        raise InputError(error("E584", "the scene has no robot to move", None))
    name, names = (args.predicate or args.action)[0], (args.predicate or args.action)[1:]
    formula = compiled.action(name) if args.action else compiled.predicate(name)
    ids = compiled.bind_args(formula, names)
    state = read_state(world, compiled.model, args.state)
    checker = None if args.allow_collisions else collision_world(world, compiled)
    got = sample_states(compiled, formula, ids, state, args.n, np.random.default_rng(args.seed),
                        args.iterations, args.max_starts, checker)
    for q in got.found:
        sys.stdout.write(json.dumps(state_to_json(replace(state, q=q), compiled.model,
                                                  compiled.fk(q))) + "\n")
    sys.stderr.write(f"{len(got.found)} of {args.n} state(s) from {got.tried} starts; rejected: "
                     f"{got.unconverged} did not converge, {got.colliding} in collision\n")
    return EXIT_OK if got.found else EXIT_NOT_FOUND
