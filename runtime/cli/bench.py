"""`tmpc bench INPUT... [--planners A,B] [--seeds N] [--time-limit S] [-o R.json] [--ompl-log R.log]`:
planners x problems x seeds (docs/bench.md). Exit 0; 70 if a plan failed validation; 130 when
interrupted (what was collected is still written)."""

from __future__ import annotations

import math
import sys

from tmpc.compiler.artifact import open_world
from tmpc.lang.diagnostics import TmpcError
from tmpc.runtime.bench import Bench, Stop, check_output, problem_names
from tmpc.runtime.cli.exits import EXIT_ERROR, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE
from tmpc.runtime.interrupts import interruptible, writing
from tmpc.runtime.planners import PLANNERS, unknown_planner


def run_bench(args) -> int:
    if args.seeds < 1:
        sys.stderr.write("tmpc bench: --seeds must be >= 1\n")
        return EXIT_USAGE
    if not args.time_limit > 0 or not math.isfinite(args.time_limit):
        sys.stderr.write("tmpc bench: --time-limit must be a number > 0\n")
        return EXIT_USAGE
    planners = [p.strip() for p in args.planners.split(",") if p.strip()]
    if not planners:
        sys.stderr.write("tmpc bench: --planners names no planner\n")
        return EXIT_USAGE
    for name in planners:
        if name not in PLANNERS:
            raise unknown_planner(name)
    for out in (args.output, args.ompl_log):
        if out:
            check_output(out)
    names = problem_names(args.inputs)
    for path in args.inputs:                           # bad input fails before any planning
        open_world(path)
    bench = Bench(args, planners, names)
    try:
        with interruptible():         # Ctrl-C / SIGTERM end the sweep, not the process
            for path, name in zip(args.inputs, names):
                try:
                    bench.problem(path, name)
                except TmpcError as exc:
                    bench.failed_problem(path, name, exc)
    except (KeyboardInterrupt, Stop):
        bench.interrupted = True
        sys.stderr.write("\ninterrupted: writing what was collected\n")
    with writing():
        bench.finish()
    sys.stdout.write(bench.table() + "\n")
    return exit_code(bench)


def exit_code(bench) -> int:
    """130 interrupted; 70 when a plan failed validation (a planner bug); 1 when a problem
    failed its pre-checks; else 0."""
    if bench.interrupted:
        return EXIT_INTERRUPTED
    if bench.bugs:
        return EXIT_INTERNAL
    return EXIT_ERROR if bench.errors else EXIT_OK
