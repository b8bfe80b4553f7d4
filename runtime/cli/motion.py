"""`tmpc motion INPUT --from S1 --to S2 [--planner ompl:NAME|tmpc] [--mode M] [--seed N] [--json]`.

One collision-free motion in one mode of a world, with one of OMPL's planners or tmpc's own
(:func:`tmpc.runtime.planners.decoupled.plan_motion`). S1 and S2 are each a state file (as
``tmpc eval --state`` reads it: only its configuration is used), ``start`` (the scene's start)
or ``random`` (a collision-free random configuration in the mode, from ``--seed``). The mode (where
the objects are, which ones the robot holds) is ``--mode``: ``start`` or a state file's objects
and held objects; by default, the --from state file's, else the scene's start. Exit 0 with a
motion (``--json``: the path, its length and the time), 3 when the planner found none within
the time limit (the reason on stderr), 1 for bad input (E850-E857).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from tmpc.compiler.state import initial_state
from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.cli.exits import EXIT_NOT_FOUND, EXIT_OK
from tmpc.runtime.collision import prepare_kernel
from tmpc.runtime.planners import check_motion_planner, plan_motion
from tmpc.runtime.probe import read_state
from tmpc.runtime.problem import PlanningProblem
from tmpc.runtime.solve import open_input

#: how many uniform draws `random` tries before E854
RANDOM_TRIES = 100 * 64


def run_motion(args) -> int:
    check_motion_planner(args.planner)
    for flag, value in (("--from", args.start), ("--to", args.goal), ("--mode", args.mode)):
        if value is not None and value not in ("start", "random") and value != "-" and \
                not Path(value).is_file():
            raise InputError(error("E852", f"{flag} {value}: not `start`, `random` or a state "
                                   "file", None, "give `start`, `random` (--from/--to) or the "
                                   "path of a state JSON file (as `tmpc eval --state` reads)"))
    if args.mode == "random":
        raise InputError(error("E852", "--mode random: a mode is `start` or a state file", None))
    prepare_kernel()
    world, _ = open_input(args.input)
    p = PlanningProblem(world)
    model = p.model
    mode_file = args.mode if args.mode not in (None, "start") else \
        (args.start if args.mode is None and args.start not in ("start", "random") else None)
    state = read_state(world, model, mode_file) if mode_file else initial_state(world.scene,
                                                                                 model)
    mode = p.make_mode(0, p.ground.init, dict(state.poses), dict(state.held))
    rng = np.random.default_rng(args.seed)
    q0 = _end(p, world, mode, args.start, "--from", rng)
    q1 = _end(p, world, mode, args.goal, "--to", rng)
    res = plan_motion(p, mode, q0, q1, args.planner, args.time_limit, args.seed)
    if res.path is None:
        sys.stderr.write(f"tmpc motion: no motion found by {args.planner} within "
                         f"{args.time_limit:g} s ({res.status}): the goal may be unreachable "
                         "in this mode, or need more time (--time-limit)\n")
        return EXIT_NOT_FOUND
    if args.json:
        sys.stdout.write(json.dumps({
            "planner": res.planner, "status": "solved", "seed": args.seed,
            "joints": list(model.q_names), "path": [[float(x) for x in q] for q in res.path],
            "states": len(res.path), "length": round(res.length, 6),
            "seconds": res.seconds}, indent=2) + "\n")
    else:
        sys.stdout.write(f"motion: {len(res.path)} states, length {res.length:.4f}, "
                         f"{res.seconds:.3f} s ({res.planner})\n")
    return EXIT_OK


def _end(p: PlanningProblem, world, mode, spec: str, flag: str, rng) -> np.ndarray:
    """The configuration ``spec`` names, checked: within the joint limits and collision-free
    in ``mode`` (E853), or a random one (E854 when none is found)."""
    if spec == "random":
        for _ in range(RANDOM_TRIES // 64):
            Q = p.uniform(rng, 64)
            ok = np.nonzero(p.valid_batch(mode, Q))[0]
            if len(ok):
                return Q[ok[0]]
        raise InputError(error("E854", f"{flag} random: no collision-free state found in "
                               f"{RANDOM_TRIES} draws", None))
    state = initial_state(world.scene, p.model) if spec == "start" else \
        read_state(world, p.model, spec)
    q = np.asarray(state.q, float)
    outside = [n for n, v, lo, hi in zip(p.model.q_names, q, p.lower, p.upper)
               if not lo - 1e-9 <= v <= hi + 1e-9]
    if outside:
        raise InputError(error("E853", f"{flag} {spec}: outside the joint limits: "
                               + ", ".join(outside), None))
    report = p.collision.check(q, poses=mode.poses, attached=mode.held)
    if not report.valid:
        pairs = ", ".join(f"{a} <-> {b}" for a, b, _ in report.pairs[:5])
        raise InputError(error("E853", f"{flag} {spec}: in collision in this mode ({pairs})",
                               None, "choose a collision-free state, or the mode (--mode) "
                               "it belongs to"))
    return q
