"""The `tmpc` command line: the composition root.

Each command is a small function registered in :data:`COMMANDS`; argparse's choices come from
that registry. Commands import what they need lazily so `tmpc check` never loads JAX, Z3, OMPL or
lupa. Exit codes (DESIGN §8): 0 success, 1 user error with diagnostics, 2 usage error, 3 no
plan/sample within limits, 70 internal error (a bug: rerun with --debug and report it).
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable

EXIT_OK, EXIT_ERROR, EXIT_USAGE, EXIT_NOT_FOUND, EXIT_INTERNAL = 0, 1, 2, 3, 70


def _print_diagnostics(diags, files, fmt: str, stream=None) -> None:
    from tmpc.lang.diagnostics import render, render_json, sort_key, use_color
    stream = stream or sys.stderr
    if fmt == "json":
        sys.stdout.write(render_json(diags, files) + "\n")
        return
    color = use_color(stream)
    for d in sorted(diags, key=sort_key):
        stream.write(render(d, files, color) + "\n\n")


def _summary(diags) -> str:
    errors = sum(1 for d in diags if d.is_error)
    warnings = len(diags) - errors
    parts = []
    if errors:
        parts.append(f"{errors} error{'s' if errors != 1 else ''}")
    if warnings:
        parts.append(f"{warnings} warning{'s' if warnings != 1 else ''}")
    return ", ".join(parts)


# ---------------------------------------------------------------------------------------------
# commands


def cmd_check(args) -> int:
    from tmpc.lang.program import check_paths
    report = check_paths(args.files)
    if args.static and report.ok:
        # SAT/relaxation checks (W610-W613): opt-in, because they ground the problem and load
        # Z3, and plain `tmpc check` stays light enough for an editor on every keystroke
        from tmpc.compiler.smt_checks import static_checks
        for prog in report.programs:
            report.diagnostics.extend(static_checks(prog, args.budget))
        if report.workspace.configs:
            # geometric conditions no configuration satisfies (W614), by projection
            from tmpc.runtime.geo_checks import geometric_checks
            from tmpc.runtime.world import load_world
            for config in report.workspace.configs:
                report.diagnostics.extend(geometric_checks(load_world(config.path),
                                                           args.geometry_budget))
    _print_diagnostics(report.diagnostics, report.workspace.files, args.format)
    if args.format != "json":
        summary = _summary(report.diagnostics)
        names = ", ".join(_program_name(p) for p in report.programs)
        if report.ok:
            sys.stderr.write(f"ok: {names or 'no programs'}" + (f" ({summary})" if summary else "")
                             + "\n")
        else:
            sys.stderr.write(f"check failed: {summary}\n")
    return EXIT_OK if report.ok else EXIT_ERROR


def _program_name(p) -> str:
    name = f"domain {p.domain.name.text}" if p.domain.form == "domain" else \
        f"module {p.domain.name.text}"
    return name + (f" + problem {p.problem.name.text}" if p.problem else "")


def cmd_fmt(args) -> int:
    from tmpc.runtime.fmt_command import run_fmt
    return run_fmt(args.files, check=args.check, fmt=args.format, print_diags=_print_diagnostics)


def cmd_eval(args) -> int:
    from tmpc.runtime.eval_command import run_eval
    if args.expr is None and not args.predicate and not args.collisions:
        sys.stderr.write("tmpc eval: give --expr EXPR, --predicate NAME ARG..., or --collisions\n")
        return EXIT_USAGE
    return run_eval(args, _print_diagnostics)


def cmd_sample(args) -> int:
    from tmpc.runtime.sample_command import run_sample
    return run_sample(args)


def cmd_compile(args) -> int:
    from tmpc.compiler.artifact import build_artifact
    from tmpc.runtime.world import load_world
    from tmpc.lang.diagnostics import InputError, error
    if args.input is None:
        if not (args.domain and args.problem and args.scene):
            raise InputError(error("E585", "give a run configuration, or --domain, --problem "
                                   "and --scene", None))
        world = _world_from_parts(args)
    else:
        world = load_world(args.input)
    if world.program is None:
        raise InputError(error("E585", f"{args.input}: a scene alone cannot be compiled; give a "
                               "run configuration that names the domain and problem", None))
    manifest = build_artifact(world, args.output)
    skipped = [k["name"] for k in manifest["kernels"] if k.get("member") is None]
    sys.stderr.write(f"wrote {args.output}: {len(manifest['kernels'])} kernels"
                     + (f" ({len(skipped)} rebuilt from the sources on load: "
                        f"{', '.join(skipped)} call untraceable Lua)" if skipped else "")
                     + f", {len(manifest['members'])} members\n")
    return EXIT_OK


def _world_from_parts(args):
    """A run manifest beside the output, pointing at the given files (absolute paths)."""
    import tempfile
    from pathlib import Path
    from tmpc.runtime.world import load_world
    lines = ["[problem]"] + [f'{k} = "{Path(v).resolve()}"' for k, v in
                             (("domain", args.domain), ("problem", args.problem),
                              ("scene", args.scene), ("semantics", args.semantics)) if v]
    with tempfile.TemporaryDirectory() as d:
        manifest = Path(d) / "run.toml"
        manifest.write_text("\n".join(lines) + "\n")
        return load_world(manifest)


def cmd_plan(args) -> int:
    from tmpc.runtime.plan_command import run_plan
    return run_plan(args)


def cmd_run(args) -> int:
    from tmpc.runtime.run_command import run_run
    return run_run(args)


def cmd_validate(args) -> int:
    from tmpc.runtime.validate import run_validate
    return run_validate(args)


def cmd_view(args) -> int:
    from tmpc.runtime.viewer import run_view
    return run_view(args)


def cmd_bench(args) -> int:
    from tmpc.runtime.bench_command import run_bench
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
    "bench": (cmd_bench, "benchmark planners over problems and seeds (JSON, table, OMPL log)"),
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


def _configure(name: str, p: argparse.ArgumentParser) -> None:
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="diagnostics as text (default) or JSON on stdout")
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="show tracebacks of internal errors")
    if name == "check":
        p.add_argument("files", nargs="+", metavar="FILE", help="domain/problem/module files")
        p.add_argument("--static", action="store_true",
                       help="also run the SAT and relaxation checks: actions that can never "
                       "apply, goals that can never hold (W610-W613; grounds the problem)")
        p.add_argument("--budget", type=float, default=2.0, metavar="S",
                       help="time budget of --static per program (default 2 s)")
        p.add_argument("--geometry-budget", type=float, default=60.0, metavar="S",
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
        p.add_argument("--tolerance", type=float, default=0.0,
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
        p.add_argument("-n", type=int, default=1, help="how many states (default 1)")
        p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
        p.add_argument("--state", metavar="S.json", help="objects and mode to sample in (state "
                       "JSON); default: the initial state")
        p.add_argument("--iterations", type=int, default=30, help="projection iterations")
        p.add_argument("--max-starts", type=int, default=20000, help="give up after this many "
                       "start configurations")
        p.add_argument("--allow-collisions", action="store_true",
                       help="accept states in collision")
    elif name == "plan":
        p.add_argument("domain", metavar="DOMAIN")
        p.add_argument("problem", metavar="PROBLEM")
        p.add_argument("-o", "--output", metavar="PLAN", help="write the plan here (default: "
                       "stdout)")
        p.add_argument("--min-steps", type=int, default=0, help="first horizon to try")
        p.add_argument("--max-steps", type=int, default=200, help="last horizon to try")
        p.add_argument("--time-limit", type=float, default=300.0, metavar="S",
                       help="give up after S seconds (exit 3)")
        p.add_argument("-v", "--verbose", action="store_true",
                       help="statistics per horizon: clauses, encoding and solve time")
    elif name == "run":
        p.add_argument("input", metavar="INPUT", help="a run configuration (manifest TOML, planet "
                       "TOML, tmit-star spec JSON) or a compiled artifact (.tmpa)")
        p.add_argument("--planner", default="unified", help="planner (default: unified)")
        p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
        p.add_argument("--time-limit", type=float, default=None, metavar="S",
                       help="stop after S seconds and report the best progress (exit 3); "
                       "default: the configuration's, else 120")
        p.add_argument("-o", "--output", metavar="PLAN.json", help="write the plan JSON here "
                       "(default: the configuration's output, if any)")
        p.add_argument("--html", metavar="PLAN.html", help="write the animated viewer here")
        p.add_argument("--png", metavar="PLAN.png", help="write a snapshot here")
        p.add_argument("--legacy-output", choices=("planet", "tmit-star"),
                       help="write the bare state array of that planner instead of tmpc-plan/1")
        p.add_argument("--heuristic-bias", type=float, default=None,
                       help="probability of a heuristic sample (planet coin_bias)")
        p.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    elif name == "validate":
        p.add_argument("input", metavar="INPUT", help="the run configuration or artifact the "
                       "plan was made for")
        p.add_argument("plan", metavar="PLAN.json", help="a tmpc-plan/1 file or a bare planet/"
                       "tmit-star state array")
        p.add_argument("--resolution", type=float, default=0.05,
                       help="longest joint-space step between motion checks (default 0.05)")
        p.add_argument("--tolerance", type=float, default=None,
                       help="penetration depth (m) to ignore (default: the configuration's)")
        p.add_argument("--json", action="store_true", help="print the report as JSON")
    elif name == "view":
        p.add_argument("input", metavar="INPUT", help="the run configuration or artifact")
        p.add_argument("plan", metavar="PLAN.json")
        p.add_argument("--html", metavar="OUT.html", help="animated, self-contained page")
        p.add_argument("--png", metavar="OUT.png", help="snapshot")
        p.add_argument("--state", type=int, default=None, metavar="I",
                       help="which state the PNG shows (default: the last)")
    elif name == "bench":
        p.add_argument("inputs", nargs="+", metavar="INPUT", help="run configurations or "
                       "artifacts (one problem each)")
        p.add_argument("--planners", default="unified", help="comma-separated planner names")
        p.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 per problem "
                       "(default 10)")
        p.add_argument("--time-limit", type=float, default=120.0, metavar="S",
                       help="per run (default 120)")
        p.add_argument("-o", "--output", metavar="RESULTS.json", help="results as JSON")
        p.add_argument("--ompl-log", metavar="RESULTS.log", help="results in OMPL's benchmark "
                       "log format (ompl_benchmark_statistics.py / Planner Arena read it)")
        p.add_argument("--validate", action="store_true", help="check every plan with the "
                       "independent validator")
    elif name == "fmt":
        p.add_argument("files", nargs="+", metavar="FILE", help="files to format; - for stdin")
        p.add_argument("--check", action="store_true",
                       help="change nothing; exit 1 if a file would be reformatted")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("tmpc")
    except PackageNotFoundError:
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from tmpc.lang.diagnostics import TmpcError
    try:
        return COMMANDS[args.command][0](args)
    except TmpcError as exc:
        _print_diagnostics(exc.diagnostics, exc.files, getattr(args, "format", "text"))
        return exc.exit_code
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return 130
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
