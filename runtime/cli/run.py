"""`tmpc run INPUT [--planner NAME] [--seed N] [--time-limit S] [-o plan.json] [--html plan.html]`.

Loads the world (run configuration or artifact), grounds and compiles the problem, checks that it
can be planned at all (start collision-free, every object of the geometric atoms in the scene,
the goal relaxed-reachable), runs the planner and writes the plan (docs/plan-format.md). Exit 0
with a plan; exit 3 when the time limit or Ctrl-C came first — the best progress is still
written, with status ``partial``.
"""

from __future__ import annotations

import sys
import time

from tmpc.compiler.artifact import is_artifact
from tmpc.lang.diagnostics import InputError, TmpcError, error
from tmpc.lang.fileio import unwritable
from tmpc.lang.world import is_run_config, load_config
from tmpc.runtime.cli.exits import EXIT_NOT_FOUND, EXIT_OK, EXIT_USAGE
from tmpc.runtime.cli.timing import timed
from tmpc.runtime.explain import explain, summary_lines
from tmpc.runtime.interrupts import writing
from tmpc.runtime.plans import legacy_states, plan_document, write_json_atomic
from tmpc.runtime.solve import open_input, plan_problem
from tmpc.runtime.viewer import write_html, write_png

DEFAULT_TIME_LIMIT = 120.0
#: the planner when none is named (it stops at its first solution)
DEFAULT_PLANNER = "optimal"


def run_run(args, imports: float = 0.0) -> int:
    """``imports``: the seconds importing this command took (reported by ``-v``)."""
    _check_outputs([(args.output, "E828"), (args.html, "E815"), (args.png, "E815"),
                    (getattr(args, "explain", None), "E828"),
                    (None if args.output else _configured_output(args.input), "E828")])
    phases = None if args.quiet else SetupProgress(sys.stderr, sys.stderr.isatty())
    world, opened = open_input(args.input, on_compile=None if phases is None else phases.start,
                               progress=phases)
    # the command line wins; else the configuration's time limit and output (planet's TOML
    # `timeout`/`output`, a manifest's [planner] time_limit/output); else 120 s and no file
    config = world.config
    if args.planner is None:
        # no --planner: the manifest's `[planner] name`, else the optimal planner; either to
        # its first solution (the optimal one's is as fast as unified's first plan on the
        # problems measured, and shorter); `--planner optimal` stays anytime
        args.planner = (config.planner if config is not None and config.planner
                        else DEFAULT_PLANNER)
        args.first_solution = args.first_solution or not args.until_converged
    time_limit = args.time_limit if args.time_limit is not None else \
        (config.time_limit if config is not None and config.time_limit else DEFAULT_TIME_LIMIT)
    output = args.output or (str(config.output) if config is not None and config.output
                             else None)
    if not time_limit > 0:
        sys.stderr.write("tmpc run: the time limit must be > 0\n")
        return EXIT_USAGE
    progress = None if args.quiet or not sys.stderr.isatty() else _Progress(time_limit)
    on_solution = _anytime_writer(args, output, opened) if output else None
    problem, result, setup = plan_problem(world, args.planner, args.seed, time_limit,
                                          planner_overrides(args), progress, on_solution,
                                          setup_progress=phases)
    if phases is not None:
        phases.done()
    split = {"imports": imports, **opened, **problem.setup}
    setup += opened.get("load", 0.0) + opened.get("compile", 0.0)
    t = time.perf_counter()
    if progress is not None:
        progress.done()
    doc = plan_document(problem, result, planner=args.planner, seed=args.seed,
                        input_path=args.input, setup_seconds=setup)
    if getattr(args, "timed", False) and result.status == "solved":
        timed(problem.world, doc, args)
    with writing():                     # a signal now waits until every output is complete
        _write_outputs(args, problem, doc, output)
    split["output"] = time.perf_counter() - t
    _report(doc, result, setup)
    _explain(args, problem, result)
    if args.verbose:
        _report_setup(split, result)
    return EXIT_OK if result.status == "solved" else EXIT_NOT_FOUND


def _explain(args, problem, result) -> None:
    """Without a plan, why (a few lines; the whole report with ``--explain FILE``)."""
    path = getattr(args, "explain", None)
    if result.status == "solved":
        if path:
            write_json_atomic(path, {"status": "solved", "summary": "solved", "culprits": []})
        return
    report = explain(problem, result.status)
    for line in summary_lines(report):
        sys.stderr.write(line + "\n")
    if path:
        write_json_atomic(path, report)
        sys.stderr.write(f"wrote {path}\n")


def _write_outputs(args, problem, doc, output) -> None:
    if output:
        data = legacy_states(doc, args.legacy_output) if args.legacy_output else doc
        write_json_atomic(output, data)
        sys.stderr.write(f"wrote {output}\n")
    if args.html or args.png:
        if args.html:
            write_html(problem.world, doc, args.html)
            sys.stderr.write(f"wrote {args.html}\n")
        if args.png:
            write_png(problem.world, doc, args.png)
            sys.stderr.write(f"wrote {args.png}\n")


def _anytime_writer(args, output, opened):
    """An anytime planner's ``on_solution``: every improved plan is written to ``output`` at
    once (atomically), so a run stopped later still leaves its best plan."""
    def write(problem, result, setup: float) -> None:
        setup += opened.get("load", 0.0) + opened.get("compile", 0.0)
        doc = plan_document(problem, result, planner=args.planner, seed=args.seed,
                            input_path=args.input, setup_seconds=setup)
        with writing():
            data = legacy_states(doc, args.legacy_output) if args.legacy_output else doc
            write_json_atomic(output, data)
    return write


def _configured_output(path):
    """The output a run configuration names (read without loading anything it names), if any."""
    if is_artifact(path) or not is_run_config(path):
        return None
    try:
        return load_config(path).output
    except TmpcError:
        return None           # open_input reports it, in context


def _check_outputs(outputs) -> None:
    """Before loading and planning, not after: a plan that cannot be written is lost."""
    for path, code in outputs:
        why = unwritable(path) if path else None
        if why:
            raise InputError(error(code, f"cannot write {path}: {why}", None,
                                   "give a path in an existing, writable folder"))


def planner_overrides(args) -> dict:
    """The planner options given on the command line (None where not given)."""
    flag = (lambda name: True if getattr(args, name, False) else None)
    return {"heuristic_bias": getattr(args, "heuristic_bias", None),
            "batch_size": getattr(args, "batch_size", None),
            "rewire": getattr(args, "rewire_factor", None),
            "first_solution": flag("first_solution"),
            "until_converged": flag("until_converged"),
            "motion_planner": getattr(args, "motion_planner", None),
            "motion_budget": getattr(args, "motion_budget", None),
            "motion_checks": getattr(args, "motion_checks", None),
            "simplify": getattr(args, "simplify", None)}


def _report_setup(split: dict, result) -> None:
    """`-v`: where the time went, in order."""
    kernels = {"artifact": "from the artifact", "cache": "from the artifact cache (no compile)",
               "compiled": "compiled into the artifact cache", "sources": "traced from sources"}
    w = sys.stderr.write
    w(f"kernels: {kernels.get(split.get('kernels'), split.get('kernels'))}; traced this run: "
      f"{len(split.get('traced', ()))}" + (f" ({', '.join(split['traced'])})"
                                            if split.get("traced") else "") + "\n")
    if split.get("collision_pass"):
        w(f"collision pass: {split['collision_pass']}\n")
    parts = [("imports", "imports"), ("load", "load"), ("compile", "compile"),
             ("problem", "problem"), ("deserialize", "deserialize"),
             ("first_call", "first-call compile")]
    line = ", ".join(f"{label} {split[k]:.2f} s" for k, label in parts if k in split)
    w(f"setup: {line}; planning {result.stats['seconds']:.2f} s; output "
      f"{split.get('output', 0.0):.2f} s\n")


def _report(doc, result, setup: float) -> None:
    s = result.stats
    w = sys.stderr.write
    if result.status == "solved":
        w(f"solved: {len(doc['actions'])} actions, {len(doc['states'])} states in "
          f"{s['seconds']:.2f} s of planning ({setup:.2f} s setup)\n")
        for a in doc["actions"]:
            w(f"  {a}\n")
    else:
        w(f"no plan ({result.status}) after {s['seconds']:.2f} s; best progress: "
          f"{len(doc['actions'])} actions toward the goal\n")
    t = s["time"]
    w(f"nodes {s['nodes']}, modes {s['modes']}, transitions {s['transitions']}; time: "
      + ", ".join(f"{k} {v:.2f} s" for k, v in t.items()) + "\n")


class SetupProgress:
    """Setup's phases on stderr while a first run compiles (a long silence otherwise): a live
    line on a terminal, else a plain line per phase and at most one every 5 s within one. Silent
    until the compile starts, so a run from the artifact cache prints nothing more."""

    def __init__(self, stream, tty: bool):
        self.stream, self.tty, self.active = stream, tty, False
        self.phase, self.last, self.t0 = None, 0.0, time.perf_counter()

    def start(self, artifact) -> None:
        """``on_compile``: the compile begins (the artifact cache has no entry)."""
        self.stream.write("compiling the problem into the artifact cache (its first run; later "
                          f"runs of the same files start from {artifact.name})...\n")
        self.active, self.t0 = True, time.perf_counter()

    def __call__(self, phase: str, done: int = 0, total: int = 0, detail: str = "") -> None:
        if not self.active:
            return
        now = time.perf_counter()
        if phase == self.phase and now - self.last < (0.1 if self.tty else 5.0):
            return
        self.phase, self.last = phase, now
        text = (f"  {now - self.t0:5.1f} s  {phase}" + (f" {done}/{total}" if total else "")
                + (f" ({detail})" if detail else "") + "...")
        self.stream.write(f"\r{text}\033[K" if self.tty else text + "\n")
        self.stream.flush()

    def done(self) -> None:
        """Setup is over: the live line goes (the planner's own line takes its place)."""
        if self.active and self.tty:
            self.stream.write("\r\033[K")
            self.stream.flush()
        self.active = False


class _Progress:
    """One status line on stderr, refreshed at most twice a second."""

    def __init__(self, limit: float):
        self.limit, self.t0, self.last = limit, time.perf_counter(), 0.0

    def __call__(self, planner) -> None:
        now = time.perf_counter()
        if now - self.last < 0.5:
            return
        self.last = now
        sys.stderr.write(f"\r  {now - self.t0:6.1f}/{self.limit:.0f} s  nodes "
                         f"{len(planner.node_mode):6d}  modes {len(planner.modes):4d}  "
                         f"transitions {planner.counts['transitions']:4d}\033[K")
        sys.stderr.flush()

    def done(self) -> None:
        sys.stderr.write("\r\033[K")
