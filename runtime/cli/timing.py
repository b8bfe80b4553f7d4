"""`tmpc time INPUT PLAN [-o OUT] [--max-accel A] [--dt S]`: a plan with a time-optimal timing
(toppra; docs/robot-export.md); the timed plan to OUT, else stdout."""

from __future__ import annotations

import json
import sys

from tmpc.compiler.artifact import open_world
from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.cli.exits import EXIT_OK
from tmpc.runtime.plans import check_plan_fits, read_plan, write_json_atomic
from tmpc.runtime.timing import time_world_plan


def run_time(args) -> int:
    plan = read_plan(args.plan)
    if plan.form != "tmpc-plan/1":
        raise InputError(error("E832", f"{args.plan} is a bare state array; `tmpc time` times "
                               "tmpc-plan/1 files", None, "plan with `tmpc run -o PLAN.json`"))
    world = open_world(args.input, with_program=False)
    check_plan_fits(world, plan, args.input)
    with open(args.plan, encoding="utf-8") as f:
        doc = json.load(f)
    timed(world, doc, args)
    if args.output:
        write_json_atomic(args.output, doc)
        sys.stderr.write(f"wrote {args.output}\n")
    else:
        sys.stdout.write(json.dumps(doc, indent=1) + "\n")
    return EXIT_OK


def timed(world, doc: dict, args) -> dict:
    """Time ``doc`` in place (``--max-accel``, ``--dt``) and say so on stderr."""
    block = time_world_plan(world, doc, getattr(args, "max_accel", None),
                            getattr(args, "dt", None) or 0.05)
    ms = block["ms_per_motion"]
    sys.stderr.write(f"timed: {len(block['motions'])} motions, {block['duration']:.2f} s in all "
                     f"(toppra, {max(ms, default=0.0):.1f} ms per motion at most)\n")
    return block
