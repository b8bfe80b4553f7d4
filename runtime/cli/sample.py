"""`tmpc sample INPUT (--predicate NAME ARG... | --action NAME ARG...) -n N [--seed S]`.

States where a geometric predicate (or an action's geometric precondition) holds, found by the
projection sampler from uniformly random start configurations, collision-free unless
``--allow-collisions``. Prints one state JSON per line; reports on stderr how many starts were
tried and why the others were rejected. Exit 3 when no state was found within the limits.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from tmpc.compiler.artifact import open_world
from tmpc.runtime.cli.exits import EXIT_NOT_FOUND, EXIT_OK
from tmpc.runtime.collision import collision_world
from tmpc.runtime.probe import (
    read_state,
    sample_states,
    sample_target,
    sampled_state,
    sampling_program,
)


def run_sample(args) -> int:
    world = open_world(args.input)
    compiled = sampling_program(world)
    formula, ids = sample_target(compiled, args.predicate or args.action, bool(args.action))
    state = read_state(world, compiled.model, args.state)
    checker = None if args.allow_collisions else collision_world(world, compiled)
    got = sample_states(compiled, formula, ids, state, args.n, np.random.default_rng(args.seed),
                        args.iterations, args.max_starts, checker)
    for q in got.found:
        sys.stdout.write(json.dumps(sampled_state(compiled, state, q)) + "\n")
    sys.stderr.write(f"{len(got.found)} of {args.n} state(s) from {got.tried} starts; rejected: "
                     f"{got.unconverged} did not converge, {got.colliding} in collision\n")
    return EXIT_OK if got.found else EXIT_NOT_FOUND
