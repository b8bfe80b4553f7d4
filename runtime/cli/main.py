"""The `tmpc` command line: the composition root.

Each command is a small function registered in :data:`COMMANDS`; argparse's choices come from
that registry. Commands import what they need lazily so `tmpc check` never loads JAX, Z3, OMPL or
lupa. Exit codes (docs/design.md §8): 0 success, 1 user error with diagnostics, 2 usage error, 3 no
plan/sample within limits, 70 internal error (a bug: rerun with --debug and report it).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings
from typing import Callable

from tmpc.runtime.cli.exits import EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE
from tmpc.runtime.cli.output import print_diagnostics
from tmpc.runtime.interrupts import install as install_interrupts
from tmpc.runtime.planners import ENGINES, PLANNERS
from tmpc.runtime.planners import DEFAULT_MOTION_PLANNER, MOTION_PLANNERS, SIMPLIFIERS

# ---------------------------------------------------------------------------------------------
# commands


def cmd_check(args) -> int:
    from tmpc.runtime.cli.check import run_check
    return run_check(args)


def cmd_compile(args) -> int:
    from tmpc.runtime.cli.compile import run_compile
    return run_compile(args)


def cmd_cache(args) -> int:
    from tmpc.runtime.cli.cache import run_cache
    return run_cache(args)


def cmd_fmt(args) -> int:
    from tmpc.runtime.cli.fmt import run_fmt
    return run_fmt(args.files, check=args.check, fmt=args.format, print_diags=print_diagnostics)


def cmd_eval(args) -> int:
    from tmpc.runtime.cli.eval import run_eval
    if args.expr is None and not args.predicate and not args.collisions:
        sys.stderr.write("tmpc eval: give --expr EXPR, --predicate NAME ARG..., or --collisions\n")
        return EXIT_USAGE
    return run_eval(args, print_diagnostics)


def cmd_sample(args) -> int:
    from tmpc.runtime.cli.sample import run_sample
    return run_sample(args)


def cmd_plan(args) -> int:
    from tmpc.runtime.cli.plan import run_plan
    return run_plan(args)


def cmd_run(args) -> int:
    t = time.perf_counter()
    from tmpc.runtime.cli.run import run_run  # numpy, JAX, fcl, trimesh: timed for `-v`
    return run_run(args, imports=time.perf_counter() - t)


def cmd_validate(args) -> int:
    from tmpc.runtime.cli.validate import run_validate
    return run_validate(args)


def cmd_time(args) -> int:
    from tmpc.runtime.cli.timing import run_time
    return run_time(args)


def cmd_export(args) -> int:
    from tmpc.runtime.cli.export import run_export
    return run_export(args)


def cmd_simulate(args) -> int:
    from tmpc.runtime.cli.simulate import run_simulate
    return run_simulate(args)


def cmd_view(args) -> int:
    from tmpc.runtime.cli.view import run_view
    return run_view(args)


def cmd_repair(args) -> int:
    from tmpc.runtime.cli.repair import run_repair
    return run_repair(args)


def cmd_motion(args) -> int:
    from tmpc.runtime.cli.motion import run_motion
    return run_motion(args)


def cmd_lsp(args) -> int:
    from tmpc.runtime.cli.lsp import run_lsp
    return run_lsp(args)


def cmd_bench(args) -> int:
    from tmpc.runtime.cli.bench import run_bench
    return run_bench(args)


COMMANDS: dict[str, tuple[Callable, str]] = {
    "check": (cmd_check, "check PDDL domains, problems and modules; scenes, configs, URDF, Lua"),
    "fmt": (cmd_fmt, "format files in place (canonical layout, comments kept)"),
    "compile": (cmd_compile, "compile a problem into a self-contained artifact (.tmpa)"),
    "eval": (cmd_eval, "evaluate an expression or predicate, and collisions, at a state"),
    "sample": (cmd_sample, "states where a predicate or an action's precondition holds"),
    "plan": (cmd_plan, "task planning only (classical PDDL): a length-optimal sequential plan"),
    "run": (cmd_run, "task and motion planning: a collision-free, action-annotated trajectory"),
    "validate": (cmd_validate, "check a plan independently: collisions, preconditions, goal"),
    "view": (cmd_view, "render a plan: an animated HTML page and/or a PNG snapshot"),
    "time": (cmd_time, "time a plan: time-optimal motions under the robot's joint limits"),
    "export": (cmd_export, "write a timed plan for a robot: ROS JointTrajectory-shaped JSON/YAML"),
    "simulate": (cmd_simulate, "replay a timed plan in MuJoCo: drift, contacts, the goal after "
                 "settling"),
    "repair": (cmd_repair, "repair an action's geometric precondition from observed executions"),
    "bench": (cmd_bench, "benchmark planners over problems, seeds and parameters (a local "
              "pool or Ray; JSON, table, OMPL log, plots)"),
    "lsp": (cmd_lsp, "language server for editors (stdio; --tcp PORT)"),
    "motion": (cmd_motion, "one collision-free motion in one mode, by an OMPL planner or "
               "tmpc's own"),
    "cache": (cmd_cache, "show or empty the cache (compiled runs, kernels, XLA's cache)"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tmpc", description="tmpc: task and motion planning compiler and interpreter")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    parser.add_argument("--version", action="version", version=f"tmpc {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, (_, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        _configure(name, p)
    return parser


#: the commands that load legacy Lua predicates (and take the sandbox's limits)
LUA_COMMANDS = {"check", "compile", "eval", "sample", "run", "validate"}
LUA_COMMANDS |= {"motion"}


def _configure(name: str, p: argparse.ArgumentParser) -> None:
    if name != "export":       # export's --format is the document's (a contract)
        p.add_argument("--format", choices=("text", "json"), default="text",
                       help="diagnostics as text (default) or JSON on stdout")
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="show tracebacks of internal errors")
    if name in LUA_COMMANDS:
        g = p.add_argument_group("legacy Lua predicates (these win over a run manifest's "
                                 "[planner] lua_* values)")
        g.add_argument("--lua-instructions", type=POSITIVE_INT, metavar="N",
                       help="instructions one Lua call may run (default 10,000,000)")
        g.add_argument("--lua-seconds", type=SECONDS, metavar="S",
                       help="CPU seconds one Lua call may take (default 10)")
        g.add_argument("--lua-memory", type=POSITIVE_INT, metavar="BYTES",
                       help="memory a Lua file may use (default 67,108,864)")
    if name == "check":
        p.add_argument("files", nargs="+", metavar="FILE", help="domain/problem/module files")
        p.add_argument("--static", action="store_true",
                       help="also run the SAT and relaxation checks: actions that can never "
                       "apply, goals that can never hold (W610-W613; grounds the problem)")
        p.add_argument("--budget", type=SECONDS, default=2.0, metavar="S",
                       help="time budget of --static per program (default 2 s)")
        p.add_argument("--geometry-budget", type=SECONDS, default=60.0, metavar="S",
                       help="time budget of --static's geometric checks per run configuration, "
                       "kernel compilation included (default 60 s)")
    elif name == "eval":
        p.add_argument("input", metavar="INPUT",
                       help="a scene (JSON/XML) or run configuration (TOML, tmit-star spec JSON)")
        p.add_argument("--state", metavar="S.json", help="state JSON (- for stdin); default: "
                       "the initial state")
        p.add_argument("--expr", metavar="EXPR", help="e.g. '(position l_gripper_tool_frame)'")
        p.add_argument("--predicate", nargs="+", metavar=("NAME", "ARG"),
                       help="a geometric predicate and its arguments: truth, distance, gradient")
        p.add_argument("--collisions", action="store_true",
                       help="report validity and every colliding pair")
        p.add_argument("--tolerance", type=LENGTH, default=0.0,
                       help="penetration depth (m) below which contacts are ignored")
        p.add_argument("--json", action="store_true", help="print JSON")
    elif name == "compile":
        p.add_argument("input", metavar="INPUT", nargs="?",
                       help="a run configuration (manifest TOML, planet TOML, tmit-star spec JSON)")
        p.add_argument("-o", "--output", required=True, metavar="ART.tmpa")
        p.add_argument("--domain")
        p.add_argument("--problem")
        p.add_argument("--scene")
        p.add_argument("--semantics", help="legacy Lua predicate file")
    elif name == "sample":
        p.add_argument("input", metavar="INPUT", help="a run configuration (manifest TOML, planet "
                       "TOML, tmit-star spec JSON)")
        g = p.add_mutually_exclusive_group(required=True)
        g.add_argument("--predicate", nargs="+", metavar=("NAME", "ARG"))
        g.add_argument("--action", nargs="+", metavar=("NAME", "ARG"))
        p.add_argument("-n", type=POSITIVE_INT, default=1, help="how many states (default 1)")
        p.add_argument("--seed", type=COUNT, default=0, help="random seed (default 0)")
        p.add_argument("--state", metavar="S.json", help="objects and mode to sample in (state "
                       "JSON); default: the initial state")
        p.add_argument("--iterations", type=POSITIVE_INT, default=30, help="projection iterations")
        p.add_argument("--max-starts", type=POSITIVE_INT, default=20000,
                       help="give up after this many start configurations")
        p.add_argument("--allow-collisions", action="store_true",
                       help="accept states in collision")
    elif name == "plan":
        p.add_argument("domain", metavar="DOMAIN")
        p.add_argument("problem", metavar="PROBLEM")
        p.add_argument("-o", "--output", metavar="PLAN", help="write the plan here (default: "
                       "stdout)")
        p.add_argument("--engine", default="sat", choices=sorted(ENGINES),
                       help="default: sat. " + "; ".join(
                           f"{k}: {v.summary}" for k, v in sorted(ENGINES.items())))
        p.add_argument("--min-steps", type=int, default=0, help="first horizon to try (SAT)")
        p.add_argument("--max-steps", type=int, default=200, help="last horizon to try (SAT)")
        p.add_argument("--time-limit", type=float, default=300.0, metavar="S",
                       help="give up after S seconds (exit 3)")
        p.add_argument("-v", "--verbose", action="store_true",
                       help="the engine that answered and its statistics: per horizon for SAT "
                       "(clauses, encoding and solve time), expansions/s and heuristic time for A*")
    elif name == "run":
        p.add_argument("input", metavar="INPUT", help="a run configuration (manifest TOML, planet "
                       "TOML, tmit-star spec JSON) or a compiled artifact (.tmpa)")
        p.add_argument("--planner", default=None, choices=sorted(PLANNERS),
                       help="planner (default: optimal, stopping at its first solution; "
                       "`--planner optimal` improves its plan until the time limit): " + "; ".join(
                           f"{k}: {v.summary}" for k, v in sorted(PLANNERS.items())))
        p.add_argument("--seed", type=COUNT, default=0, help="random seed (default 0)")
        p.add_argument("--time-limit", type=SECONDS, default=None, metavar="S",
                       help="stop after S seconds and report the best progress (exit 3); "
                       "default: the configuration's, else 120")
        p.add_argument("-o", "--output", metavar="PLAN.json", help="write the plan JSON here "
                       "(default: the configuration's output, if any)")
        p.add_argument("--html", metavar="PLAN.html", help="write the animated viewer here")
        p.add_argument("--png", metavar="PLAN.png", help="write a snapshot here")
        p.add_argument("--explain", metavar="FILE.json", help="write why no plan was found "
                       "(the culprits, in order of blame; docs/planning.md) as JSON here")
        p.add_argument("--legacy-output", choices=("planet", "tmit-star"),
                       help="write the bare state array of that planner instead of tmpc-plan/1")
        p.add_argument("--heuristic-bias", type=PROBABILITY, default=None,
                       help="unified: probability of a heuristic sample (planet coin_bias)")
        p.add_argument("--batch-size", type=POSITIVE_INT, default=None,
                       help="optimal: samples per mode per batch (default: the "
                       "configuration's batch_size, else 50)")
        p.add_argument("--rewire-factor", type=SECONDS, default=None, metavar="F",
                       help="optimal: scales the k-nearest neighbours and the transition "
                       "radius (default 1)")
        p.add_argument("--first-solution", action="store_true",
                       help="optimal: stop at the first solution (as tmit-star without -o; what "
                       "the default planner does)")
        p.add_argument("--until-converged", action="store_true",
                       help="optimal: stop once the best cost of the last 10 searches "
                       "varies by at most 10%%")
        p.add_argument("--timed", action="store_true", help="give the plan a time-optimal "
                       "timing (toppra, the URDF's limits; docs/robot-export.md)")
        _timing_options(p)
        _ompl_options(p)
        p.add_argument("-q", "--quiet", action="store_true", help="no progress display")
        p.add_argument("-v", "--verbose", action="store_true", help="where setup time went: "
                       "imports, load, compile, deserialize, first-call compile, planning, output")
    elif name == "validate":
        p.add_argument("input", metavar="INPUT", help="the run configuration or artifact the "
                       "plan was made for")
        p.add_argument("plan", metavar="PLAN.json", help="a tmpc-plan/1 file or a bare planet/"
                       "tmit-star state array")
        p.add_argument("--resolution", type=float, default=0.05,
                       help="longest joint-space step between motion checks (default 0.05)")
        p.add_argument("--tolerance", type=float, default=None,
                       help="penetration depth (m) to ignore (default: the configuration's)")
        p.add_argument("--convention", default="auto",
                       choices=("auto", "tmpc", "tmit-star", "planet"),
                       help="how the plan was written (default auto: tmpc for tmpc-plan/1, "
                       "else the planner a bare array's action spelling names; docs/validate.md)")
        p.add_argument("--strict", action="store_true",
                       help="warnings are violations: a released object that does not rest on a "
                       "support (W830) makes the plan invalid")
        p.add_argument("--json", action="store_true", help="print the report as JSON")
        p.add_argument("--from-plan-start", action="store_true",
                       help="the plan's first state is its start (a plan made by replanning from "
                       "an observed state), not the scene's start")
        p.add_argument("--physics", action="store_true", help="then replay the plan in MuJoCo "
                       "(`tmpc simulate --strict`; an untimed plan is timed first)")
    elif name == "time":
        p.add_argument("input", metavar="INPUT", help="the run configuration or artifact the "
                       "plan was made for")
        p.add_argument("plan", metavar="PLAN.json")
        p.add_argument("-o", "--output", metavar="OUT.json", help="write the timed plan here "
                       "(default: stdout)")
        _timing_options(p)
    elif name == "export":
        p.add_argument("plan", metavar="PLAN.json", help="a timed plan (`tmpc time`, `tmpc run "
                       "--timed`)")
        p.add_argument("--format", dest="export_format", required=True,
                       choices=("ros-joint-trajectory",), help="ros-joint-trajectory: one "
                       "trajectory_msgs/JointTrajectory per motion, grasp/release events between")
        p.add_argument("-o", "--output", metavar="FILE", help="FILE.json, or FILE.yaml/.yml "
                       "for YAML (default: JSON on stdout)")
    elif name == "simulate":
        p.add_argument("input", metavar="INPUT", help="the run configuration or artifact the "
                       "plan was made for")
        p.add_argument("plan", metavar="PLAN.json", help="a plan (an untimed one is timed "
                       "first)")
        p.add_argument("--strict", action="store_true", help="exit 1 when a released object "
                       "drifts more than 1 cm while settling, tips (> 5 degrees) or the goal "
                       "no longer holds")
        p.add_argument("--json", action="store_true", help="print the report as JSON")
        p.add_argument("--html", metavar="OUT.html", help="write the simulated motion as a "
                       "viewer page")
        p.add_argument("--settle", type=SECONDS, default=1.0, metavar="S",
                       help="seconds the world is left to settle after the plan (default 1)")
        _timing_options(p)
    elif name == "view":
        p.add_argument("input", metavar="INPUT", help="the run configuration or artifact")
        p.add_argument("plan", metavar="PLAN.json")
        p.add_argument("--html", metavar="OUT.html", help="animated, self-contained page")
        p.add_argument("--png", metavar="OUT.png", help="snapshot")
        p.add_argument("--state", type=COUNT, default=None, metavar="I",
                       help="which state the PNG shows (default: the last)")
    elif name == "cache":
        p.add_argument("action", choices=("info", "clear"))
        p.add_argument("parts", nargs="*", metavar="PART",
                       help="runs, artifacts, exports, collision, robots, jax (default: all)")
    elif name == "lsp":
        p.add_argument("--stdio", action="store_true", help="speak LSP on stdin/stdout "
                       "(the default)")
        p.add_argument("--tcp", type=int, metavar="PORT", help="listen on 127.0.0.1:PORT instead")
        p.add_argument("--no-worker", action="store_true", help="no worker process: witnesses, "
                       "code lenses and static checks are off")
    elif name == "repair":
        p.add_argument("input", metavar="INPUT", nargs="?", help="a run configuration or "
                       "artifact (with --experiment: default examples/repair/expN.toml)")
        p.add_argument("--action", metavar="NAME", help='the action to repair: "NAME" or '
                       '"NAME ARG..."')
        p.add_argument("--controller", metavar="KIND:SPEC", help="sim:TRUTH (a hidden DSL "
                       "formula, or sim:@FILE) or py:MODULE:FUNCTION")
        p.add_argument("--observations", metavar="FILE.jsonl", help="recorded executions")
        p.add_argument("--db", metavar="STORE", help="the SQLite store of observations and "
                       "repairs")
        p.add_argument("--resume", action="store_true", help="continue from the store")
        p.add_argument("--write", action="store_true", help="write the repaired precondition "
                       "back into the domain")
        p.add_argument("--report", metavar="DIR", help="report.json, table.md and plots")
        p.add_argument("--experiment", type=POSITIVE_INT, metavar="N",
                       help="run the thesis's experiment N (1, 2, 3)")
        p.add_argument("--trials", type=POSITIVE_INT, help="trials of --experiment (default: "
                       "the thesis's)")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--time-limit", type=SECONDS, default=None, metavar="S",
                       help="per loop (trial)")
        p.add_argument("--sampling", choices=("naive", "active"), default=None,
                       help="how states are drawn (default active; experiments: the thesis's)")
        p.add_argument("--search-seconds", type=SECONDS, default=10.0, metavar="S",
                       help="time of one repair's edit search (default 10)")
        p.add_argument("--max-edits", type=POSITIVE_INT, default=3,
                       help="edits per repair (default 3)")
        p.add_argument("--stop-unexpected", type=POSITIVE_INT, default=None, metavar="N",
                       help="stop after N unexpected observations")
        p.add_argument("--stop-expected", type=POSITIVE_INT, default=1000, metavar="N",
                       help="stop after N expected observations in a row (default 1000)")
        p.add_argument("--max-observations", type=POSITIVE_INT, default=5000, metavar="N")
        p.add_argument("--no-refit", dest="refit", action="store_false",
                       help="move parameters only in repairs, as the thesis does (default: "
                       "also keep them at the maximum-margin fit of every observation)")
    elif name == "bench":
        p.add_argument("inputs", nargs="+", metavar="INPUT", help="run configurations or "
                       "artifacts (one problem each)")
        p.add_argument("--planners", default="unified", help="comma-separated planner names ("
                       + ", ".join(sorted(PLANNERS)) + ")")
        p.add_argument("--seeds", type=POSITIVE_INT, default=10, help="seeds 0..N-1 per problem "
                       "(default 10)")
        p.add_argument("--time-limit", type=SECONDS, default=120.0, metavar="S",
                       help="per run (default 120)")
        p.add_argument("-o", "--output", metavar="RESULTS.json", help="results as JSON "
                       "(tmpc-bench/1), or R.jsonl: a line per run as runs finish (--resume); "
                       "`bench report`: the report's folder")
        p.add_argument("--ompl-log", metavar="RESULTS.log", help="results in OMPL's benchmark "
                       "log format (ompl_benchmark_statistics.py / Planner Arena read it)")
        p.add_argument("--validate", action="store_true", help="check every plan with the "
                       "independent validator")
        p.add_argument("--simulate", action="store_true", help="time every solved plan and "
                       "replay it in MuJoCo: a physics column (settled, drift; docs/physics.md)")
        g = p.add_argument_group("distributed sweeps (docs/bench.md); any of these, or -o "
                                 "R.jsonl, runs each run as a task; `tmpc bench report "
                                 "R.jsonl [report.json] -o DIR` draws plots and tables of "
                                 "results files and repair reports")
        g.add_argument("--backend", choices=("local", "ray"), help="local: a process pool on "
                       "this machine (the default); ray: Ray tasks (pip install "
                       "'tmpc[cluster]')")
        g.add_argument("--address", metavar="auto|HOST:PORT", help="the Ray cluster to join "
                       "(default: start one on this machine)")
        g.add_argument("--workers", type=POSITIVE_INT, metavar="N", help="runs in flight "
                       "(default: this machine's cores; with Ray, the cluster's CPUs)")
        g.add_argument("--task-memory", type=POSITIVE_INT, default=2048, metavar="MIB",
                       help="memory a Ray task reserves (default 2048)")
        g.add_argument("--param", action="append", metavar="NAME=V1,V2,...", help="sweep a "
                       "planner parameter (repeat: the cross product)")
        g.add_argument("--resume", action="store_true", help="skip the runs the results file "
                       "(-o R.jsonl) already has")
        p.add_argument("--docs", metavar="DIR", help="`bench report --docs DIR -o FILE.md`: "
                       "render the performance document from the results files in DIR "
                       "(docs/bench.md)")
    elif name == "motion":
        p.add_argument("input", metavar="INPUT", help="a run configuration or artifact")
        p.add_argument("--from", dest="start", required=True, metavar="S1",
                       help="a state file, `start` (the scene's) or `random` (collision-free, "
                       "from --seed)")
        p.add_argument("--to", dest="goal", required=True, metavar="S2", help="as --from")
        p.add_argument("--planner", default=DEFAULT_MOTION_PLANNER, metavar="NAME",
                       help=f"ompl:NAME or tmpc (default {DEFAULT_MOTION_PLANNER}): "
                       + ", ".join(MOTION_PLANNERS))
        p.add_argument("--mode", default=None, metavar="M", help="`start` or a state file: "
                       "where the objects are and what the robot holds (default: the --from "
                       "state file's, else the scene's start)")
        p.add_argument("--seed", type=COUNT, default=0, help="random seed (default 0)")
        p.add_argument("--time-limit", type=SECONDS, default=10.0, metavar="S",
                       help="give up after S seconds (exit 3; default 10)")
        p.add_argument("--json", action="store_true", help="print the path, its length and "
                       "the time as JSON")
    elif name == "fmt":
        p.add_argument("files", nargs="+", metavar="FILE", help="files to format; - for stdin")
        p.add_argument("--check", action="store_true",
                       help="change nothing; exit 1 if a file would be reformatted")


def _ompl_options(p: argparse.ArgumentParser) -> None:
    """`tmpc run`'s options of the decoupled planner and the simplifier (issue Q, docs/ompl.md)."""
    p.add_argument("--motion-planner", default=None, metavar="NAME",
                   help=f"decoupled: each motion's planner (default {DEFAULT_MOTION_PLANNER}): "
                   + ", ".join(MOTION_PLANNERS))
    p.add_argument("--motion-checks", type=POSITIVE_INT, default=None, metavar="N",
                   help="decoupled: tmpc's checks an OMPL planner gets per motion before the "
                   "next transition sample (default 4000; a count, so runs do not depend on "
                   "the machine's speed)")
    p.add_argument("--motion-budget", type=SECONDS, default=None, metavar="S",
                   help="decoupled: seconds per motion (tmpc's lazy PRM: default 2; OMPL's "
                   "planners: a wall-clock ceiling besides --motion-checks, none by default)")
    p.add_argument("--simplify", choices=SIMPLIFIERS, default=None,
                   help="what shortens the final plan's motions: tmpc (default: the planner's "
                   "own shortcuts and refinement) or ompl (then OMPL's PathSimplifier, each "
                   "result checked by tmpc's motion checker)")


def _timing_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--max-accel", type=SECONDS, default=None, metavar="A",
                   help="joint acceleration limit (rad/s², m/s²) where the URDF gives none "
                   "(default 2)")
    p.add_argument("--dt", type=SECONDS, default=None, metavar="S",
                   help="seconds between a timed motion's samples (default 0.05)")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("tmpc")
    except PackageNotFoundError:
        return "unknown"


class _PipeGuard:
    """A standard stream that outlives its reader: once a write finds the pipe closed (``tmpc
    check ... | head``), later output goes to /dev/null and the command runs on to its own exit
    status (1 when there were errors), instead of ending early with 0 or a traceback."""

    def __init__(self, stream):
        self._stream = stream
        self.broken = False

    def write(self, text):
        if not self.broken:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._gone()
        return len(text)

    def flush(self):
        if not self.broken:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._gone()

    def _gone(self) -> None:
        self.broken = True
        try:        # the interpreter's own flush at exit must not find the closed pipe either
            os.dup2(os.open(os.devnull, os.O_WRONLY), self._stream.fileno())
        except (OSError, ValueError, AttributeError):
            pass

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _number(kind, low: float, low_ok: bool, high: float | None = None):
    """An argparse type: a finite ``kind`` above ``low`` (or at it, with ``low_ok``) and at
    most ``high``; anything else is a usage error (exit 2) saying what is wanted. (Options a
    command checks itself with a code of its own, `plan`'s limits (E610) and `validate`'s
    resolution and tolerance (E813), keep their plain types.)"""
    want = (f"{'>=' if low_ok else '>'} {low:g}" + (f" and <= {high:g}" if high is not None
                                                     else ""))
    name = "an integer" if kind is int else "a number"

    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {name}") from None
        if not math.isfinite(v) or v < low or (v == low and not low_ok) or \
                (high is not None and v > high):
            raise argparse.ArgumentTypeError(f"{text} must be {name} {want}")
        return v
    parse.__name__ = kind.__name__
    return parse


POSITIVE_INT, COUNT = _number(int, 0, False), _number(int, 0, True)
SECONDS, LENGTH = _number(float, 0, False), _number(float, 0, True)
PROBABILITY = _number(float, 0, True, 1)


def run_and_exit(argv: list[str] | None = None):
    """The console entry (``tmpc``, ``python -m tmpc.runtime.cli``): :func:`main`, then exit.
    After a command that imported JAX, the interpreter's teardown (XLA's clients, executables
    and thread pools) costs noticeable time in a process that is done, so the process ends at once,
    its output flushed (every file tmpc writes is complete before then: atomic writes). Under
    a tracer or profiler (coverage, cProfile) the usual exit runs."""
    install_interrupts()
    code = main(argv)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    if "jax" in sys.modules and sys.gettrace() is None and sys.getprofile() is None:
        os._exit(code)
    sys.exit(code)


def main(argv: list[str] | None = None) -> int:
    streams, show = (sys.stdout, sys.stderr), warnings.showwarning
    sys.stdout, sys.stderr = (s if isinstance(s, _PipeGuard) else _PipeGuard(s) for s in streams)
    warnings.showwarning = _show_warning
    try:
        return _main(argv)
    finally:
        sys.stdout, sys.stderr = streams
        warnings.showwarning = show


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """tmpc's own warnings as ``warning: MESSAGE`` lines (the line of tmpc's source that
    raised one tells a user nothing); other libraries' the usual way."""
    import tmpc.compiler
    import tmpc.lang
    import tmpc.runtime
    roots = [os.path.dirname(m.__file__) + os.sep for m in (tmpc.lang, tmpc.compiler,
                                                               tmpc.runtime)]
    if issubclass(category, UserWarning) and \
            any(os.path.abspath(filename).startswith(r) for r in roots):
        (file or sys.stderr).write(f"warning: {message}\n")
    else:
        (file or sys.stderr).write(warnings.formatwarning(message, category, filename, lineno,
                                                          line))


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from tmpc.lang.diagnostics import TmpcError
    if args.command in LUA_COMMANDS:
        from tmpc.lang.lua import override_lua_limits
        override_lua_limits(args.lua_instructions, args.lua_seconds, args.lua_memory)
    try:
        return COMMANDS[args.command][0](args)
    except TmpcError as exc:
        print_diagnostics(exc.diagnostics, exc.files, getattr(args, "format", "text"))
        return exc.exit_code
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return EXIT_OK
    except Exception:
        if args.debug:
            raise
        import traceback
        last = traceback.extract_tb(sys.exc_info()[2])[-1]
        sys.stderr.write(f"internal error: {sys.exc_info()[1]!r} at {last.filename}:{last.lineno}\n"
                         "this is a bug in tmpc; rerun with --debug for the traceback and report "
                         "it\n")
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
