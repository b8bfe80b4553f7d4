"""`tmpc view INPUT|ART PLAN.json [--html OUT.html] [--png OUT.png] [--state I]`."""

from __future__ import annotations

import sys
from pathlib import Path

from tmpc.compiler.artifact import open_world
from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.cli.exits import EXIT_OK, EXIT_USAGE
from tmpc.runtime.plans import check_plan_fits, read_plan
from tmpc.runtime.viewer import write_html, write_png


def run_view(args) -> int:
    if not args.html and not args.png:
        sys.stderr.write("tmpc view: give --html OUT.html and/or --png OUT.png\n")
        return EXIT_USAGE
    plan = read_plan(args.plan)
    world = open_world(args.input, with_program=False)
    check_plan_fits(world, plan, args.input)
    for out in (args.html, args.png):
        if out and not Path(out).resolve().parent.is_dir():
            raise InputError(error("E815", f"cannot write {out}: no such directory", None))
    if args.png:
        write_png(world, plan, args.png, args.state)
        sys.stderr.write(f"wrote {args.png}\n")
    if args.html:
        size = write_html(world, plan, args.html)
        sys.stderr.write(f"wrote {args.html} ({size / 1e6:.2f} MB)\n")
    return EXIT_OK
