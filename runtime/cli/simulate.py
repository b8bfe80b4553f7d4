"""`tmpc simulate INPUT PLAN [--strict] [--json] [--html OUT]`: replay a plan in MuJoCo (an
untimed one is timed first) and report drift, contacts and the goal after settling
(docs/physics.md). Exit 0; 1 with --strict when a drift passes 1 cm, an object tips or the goal
no longer holds."""

from __future__ import annotations

import json
import sys

from tmpc.compiler.artifact import open_world
from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.cli.exits import EXIT_ERROR, EXIT_OK
from tmpc.runtime.plans import check_plan_fits, read_plan
from tmpc.runtime.simulate import simulate, write_sim_html
from tmpc.runtime.timing import time_world_plan


def run_simulate(args) -> int:
    plan = read_plan(args.plan)
    world = open_world(args.input)
    check_plan_fits(world, plan, args.input)
    return physics(world, args)


def physics(world, args) -> int:
    """The check itself (``tmpc validate --physics`` calls it after the kinematic one)."""
    if read_plan(args.plan).form != "tmpc-plan/1":
        raise InputError(error("E819", f"{args.plan} is a bare state array: it has no times",
                               None, "simulate a tmpc-plan/1 file"))
    with open(args.plan, encoding="utf-8") as f:
        doc = json.load(f)
    if "timing" not in doc or any(s.get("t") is None for s in doc["states"]):
        time_world_plan(world, doc, getattr(args, "max_accel", None),
                        getattr(args, "dt", None) or 0.05)
    html = getattr(args, "html", None)
    report = simulate(world, doc, getattr(args, "settle", 1.0), trace=bool(html))
    if html:
        size = write_sim_html(world, doc, report.trace, html)
        sys.stderr.write(f"wrote {html} ({size / 1e6:.1f} MB, {len(report.trace)} frames)\n")
    if getattr(args, "json", False) and not getattr(args, "physics", False):
        sys.stdout.write(json.dumps(report.as_json(), indent=2) + "\n")
    else:
        sys.stdout.write(report.text() + "\n")
    return EXIT_ERROR if getattr(args, "strict", False) and not report.ok() else EXIT_OK
