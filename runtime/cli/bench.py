"""`tmpc bench INPUT... [--planners A,B] [--seeds N] [--time-limit S] [-o R.json|R.jsonl]
[--ompl-log R.log] [--backend local|ray] [--workers N] [--param NAME=V,...] [--resume]`:
planners x problems x seeds (x parameter points), in this process or as tasks on a backend;
`tmpc bench report R.jsonl -o DIR`: plots and an HTML report of a results file; `tmpc bench report
--docs DIR -o FILE.md`: the performance document of a folder of results files (docs/bench.md).
Exit 0; 70 if a plan failed validation; 130 when interrupted (what was collected is still
written)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from tmpc.compiler.artifact import open_world
from tmpc.lang.diagnostics import InputError, TmpcError, error
from tmpc.lang.fileio import atomic_write_text
from tmpc.runtime.bench import (BACKENDS, Bench, Dispatch, ParamError, Stop, check_output,
                                parse_params, problem_names, render_performance, write_report)
from tmpc.runtime.cli.exits import EXIT_ERROR, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE
from tmpc.runtime.interrupts import interruptible, writing
from tmpc.runtime.planners import PLANNERS, unknown_planner


def run_bench(args) -> int:
    if args.inputs[0] == "report" and not Path("report").exists():
        return run_report(args)
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
    if distributed(args):
        return run_dispatch(args, planners)
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


def distributed(args) -> bool:
    """Runs are tasks on a backend when a backend option or a results file (.jsonl) says so;
    otherwise the sweep runs in this process (``tmpc-bench/1``), as it always did."""
    return bool(getattr(args, "backend", None) or getattr(args, "workers", None)
                or getattr(args, "param", None) or getattr(args, "resume", False)
                or str(args.output or "").endswith(".jsonl"))


def run_dispatch(args, planners: list[str]) -> int:
    args.backend = args.backend or "local"
    try:
        grid = parse_params(getattr(args, "param", None), planners)
    except ParamError as exc:
        sys.stderr.write(f"tmpc bench: {exc}\n")
        return EXIT_USAGE
    if args.resume and not str(args.output or "").endswith(".jsonl"):
        sys.stderr.write("tmpc bench: --resume continues a results file: give -o R.jsonl\n")
        return EXIT_USAGE
    if args.output and str(args.output).endswith(".jsonl") and not args.resume \
            and Path(args.output).is_file() and Path(args.output).stat().st_size:
        sys.stderr.write(f"tmpc bench: {args.output} has results: --resume continues it "
                         "(or remove it)\n")
        return EXIT_USAGE
    if args.backend not in BACKENDS:
        sys.stderr.write(f"tmpc bench: unknown backend {args.backend}\n")
        return EXIT_USAGE
    BACKENDS[args.backend].check_installed()
    names = problem_names(args.inputs)
    for path in args.inputs:                           # bad input fails before any planning
        open_world(path)
    dispatch = Dispatch(args, planners, names, grid)
    bench = dispatch.bench
    try:
        with interruptible():
            dispatch.run()
    except (KeyboardInterrupt, Stop):
        bench.interrupted = True
        sys.stderr.write("\ninterrupted: the runs in flight were cancelled; every finished run "
                         "is kept\n")
    with writing():
        bench.finish()
    if dispatch.results is not None:
        sys.stderr.write(f"wrote {dispatch.results.path}\n")
    sys.stdout.write(bench.table() + "\n")
    code = exit_code(bench)
    return EXIT_ERROR if code == EXIT_OK and dispatch.lost else code


def run_report(args) -> int:
    """`tmpc bench report R.jsonl [R2.jsonl ...] -o DIR`, or `tmpc bench report --docs DIR -o
    FILE.md` (``-o -``: stdout): the performance document of a folder of results files."""
    files = args.inputs[1:]
    if getattr(args, "docs", None):
        return run_docs(args, files)
    if not files or not args.output:
        sys.stderr.write("tmpc bench report: give the results file(s) and -o DIR\n")
        return EXIT_USAGE
    for f in files:
        if not Path(f).is_file():
            raise InputError(error("E010", f"no such file: {f}", None))
    written = write_report(files, args.output)
    for path in written:
        sys.stderr.write(f"wrote {path}\n")
    return EXIT_OK


def run_docs(args, files) -> int:
    """`tmpc bench report --docs DIR -o FILE.md`."""
    if files or not args.output:
        sys.stderr.write("tmpc bench report --docs DIR: give only the folder and -o FILE.md\n")
        return EXIT_USAGE
    if not Path(args.docs).is_dir():
        raise InputError(error("E010", f"no such folder: {args.docs}", None))
    try:
        text = render_performance(args.docs)
    except ValueError as exc:                          # ResultsError, or JSON that is not
        raise InputError(error("E010", f"{exc}", None)) from exc
    if args.output == "-":
        sys.stdout.write(text)
        return EXIT_OK
    with writing():
        atomic_write_text(Path(args.output), text)
    sys.stderr.write(f"wrote {args.output}\n")
    return EXIT_OK
