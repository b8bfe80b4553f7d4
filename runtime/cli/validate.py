"""`tmpc validate INPUT|ART PLAN.json [--resolution R] [--tolerance T] [--convention C]
[--json]`: the independent plan check (docs/validate.md). Exit 0 valid; 1 with the
violations."""

from __future__ import annotations

import json
import sys

from tmpc.compiler.artifact import open_world
from tmpc.runtime.cli.exits import EXIT_ERROR, EXIT_OK
from tmpc.runtime.cli.simulate import physics
from tmpc.runtime.plans import check_plan_fits, file_digest, read_plan
from tmpc.runtime.validate import check_numbers, validate_plan


def run_validate(args) -> int:
    check_numbers(args.tolerance, args.resolution)
    plan = read_plan(args.plan)
    world = open_world(args.input)
    check_plan_fits(world, plan, args.input)
    report = validate_plan(world, plan, args.tolerance, args.resolution,
                           getattr(args, "convention", "auto"), args.strict,
                           "plan" if getattr(args, "from_plan_start", False) else "scene")
    made_for = (plan.meta.get("input") or {}).get("digest") if isinstance(
        plan.meta.get("input"), dict) else None
    if made_for and made_for != file_digest(args.input):
        report.notes.append(f"the plan was made for a different version of {args.input} "
                            "(its input digest differs)")
    if args.json:
        sys.stdout.write(json.dumps(report.as_json(), indent=2) + "\n")
    else:
        sys.stdout.write(report.text() + "\n")
    if getattr(args, "physics", False):
        args.strict = True
        return physics(world, args) if report.valid else EXIT_ERROR
    return EXIT_OK if report.valid else EXIT_ERROR
