"""`tmpc plan DOMAIN PROBLEM [-o PLAN] [--min-steps N] [--max-steps N] [--time-limit S] [-v]`.

Task planning alone, on any classical PDDL (geometric literals count as satisfied): a
length-optimal sequential plan from the incremental SAT planner (:mod:`.taskplan`), written in
the IPC plan format (one ``(action arg ...)`` per line, then ``; cost = N (unit cost)`` and
``; length N``). The plan is replayed on the ground problem before it is written. Exit 0 with a
plan; 3 with no plan within the limits (E611-E613 say why: the goal is unreachable even ignoring
deletes, every length up to ``--max-steps`` is impossible, or the time ran out and which lengths
were ruled out); 1 for bad input; 2 for bad limits. ``-v`` prints statistics per horizon on
stderr.
"""

from __future__ import annotations

import sys
import time

from tmpc.compiler.ground import ground
from tmpc.compiler.smt import unreachable_goal_names
from tmpc.lang.diagnostics import CheckError, InputError, TmpcError, error
from tmpc.lang.fileio import atomic_write_text
from tmpc.lang.program import check_paths
from tmpc.runtime.cli.output import print_diagnostics
from tmpc.runtime.planners import SOLVED, TIMEOUT, UNREACHABLE, TaskPlanner, simulate


class NoPlanError(TmpcError):
    """No plan within the limits (exit 3)."""

    exit_code = 3


class LimitError(TmpcError):
    """Bad step or time limits (a usage error, exit 2)."""

    exit_code = 2


def run_plan(args) -> int:
    t0 = time.perf_counter()
    _check_limits(args)
    prog, files = _load(args.domain, args.problem, args.verbose)
    try:
        gp = ground(prog)
    except TmpcError as exc:
        exc.files.update(files)
        raise
    t_ground = time.perf_counter() - t0
    if args.verbose:
        sys.stderr.write(f"ground: {len(gp.atoms)} atoms, {len(gp.actions)} actions, "
                         f"{len(gp.axioms)} axioms in {t_ground:.2f} s\n")
    if not gp.goal_relaxed_reachable:
        raise NoPlanError(_unreachable(gp, prog), files)
    left = args.time_limit - (time.perf_counter() - t0)
    planner = TaskPlanner(gp, analysis_budget=min(1.0, max(left, 0.0) / 10))
    if args.verbose:
        _describe(planner)
    left = args.time_limit - (time.perf_counter() - t0)
    result = planner.plan(args.max_steps, max(left, 0.001), args.min_steps)
    if args.verbose:
        _print_stats(result)
    if result.status == UNREACHABLE:
        raise NoPlanError(_unreachable(gp, prog), files)
    if result.status != SOLVED:
        raise NoPlanError(_no_plan(result, args, result.status == TIMEOUT), files)
    ok, why = simulate(gp, result.actions)
    if not ok:
        raise RuntimeError(f"the plan found does not replay ({why})")
    shortest = result.impossible_below >= result.horizon
    text = plan_text(result.actions, gp.uses_costs, shortest)
    if args.output:
        write_atomically(args.output, text)
    else:
        sys.stdout.write(text)
    what = "shortest possible" if shortest else f"shortest with at least {args.min_steps} steps"
    sys.stderr.write(f"plan of length {len(result.actions)} ({what}) in "
                     f"{time.perf_counter() - t0:.2f} s"
                     + (f", written to {args.output}" if args.output else "") + "\n")
    return 0


def _check_limits(args) -> None:
    problems = []
    if args.min_steps < 0:
        problems.append("--min-steps must be >= 0")
    if args.max_steps < 0:
        problems.append("--max-steps must be >= 0")
    if args.min_steps > args.max_steps:
        problems.append(f"--min-steps {args.min_steps} is larger than --max-steps "
                        f"{args.max_steps}")
    if not args.time_limit > 0:
        problems.append("--time-limit must be positive")
    if problems:
        raise LimitError(error("E610", "; ".join(problems), None))


def _load(domain: str, problem: str, verbose: bool):
    """The checked program of the two files, and the source files for diagnostics."""
    report = check_paths([domain, problem])
    files = report.workspace.files
    errors = [d for d in report.diagnostics if d.is_error]
    if errors:
        raise CheckError(errors, files)
    progs = [p for p in report.programs if p.problem is not None]
    if len(progs) != 1:
        raise InputError(error("E615", f"{domain} and {problem} do not make one domain and one "
                               f"problem for it", None,
                               "pass the domain file, then the problem file"), files)
    if verbose:
        print_diagnostics([d for d in report.diagnostics if not d.is_error], files, "text")
    return progs[0], files


def _unreachable(gp, prog):
    atoms = unreachable_goal_names(prog, gp)
    span = prog.problem.goal.span if prog.problem.goal is not None else None
    if atoms:
        names = ", ".join(atoms[:5]) + (" ..." if len(atoms) > 5 else "")
        what = f"no sequence of actions can make {names} true"
    else:
        what = "the goal cannot be reached even when delete effects are ignored"
    return error("E611", f"no plan: {what}", span,
                 "check the goal against the actions' effects and the initial state")


def _no_plan(result, args, timeout: bool):
    lo = result.impossible_below
    if timeout:
        ruled = f"no plan of length < {lo} exists" if lo > 0 else "no length was ruled out"
        return error("E613", f"time limit of {args.time_limit:g} s reached at horizon "
                     f"{result.horizon}: {ruled}", None, "raise --time-limit")
    if lo > args.max_steps:
        msg = f"no plan of length <= {args.max_steps}"
    else:
        msg = (f"no plan of length {max(args.min_steps, lo)} to {args.max_steps}"
               + (f" (lengths below {lo} are impossible)" if lo else ""))
    return error("E612", msg, None, "raise --max-steps to search longer plans")


def plan_text(actions, uses_costs: bool, shortest: bool = True) -> str:
    """The IPC plan format: one ``(action arg ...)`` per line, lowercase, then the cost."""
    lines = [a.name.lower() for a in actions]
    n = len(actions)
    if uses_costs:
        cost = sum(a.cost for a in actions)
        lines.append(f"; cost = {cost:g} (general cost)")
        lines.append(f"; length {n} ({'shortest possible; ' if shortest else ''}action costs "
                     "are not minimized)")
    else:
        lines.append(f"; cost = {n} (unit cost)")
        lines.append(f"; length {n}")
    return "\n".join(lines) + "\n"


def write_atomically(path: str, text: str) -> None:
    """lang.fileio's atomic write (temporary file and rename, usual permissions); an unwritable
    place is E614."""
    try:
        atomic_write_text(path, text)
    except OSError as exc:
        raise InputError(error("E614", f"cannot write {path}: {exc.strerror or exc}",
                               None)) from None


def _describe(planner) -> None:
    lm = planner.landmarks
    bound = planner.lower_bound
    mutexes = planner.mutexes
    sys.stderr.write(
        f"lower bound: {bound if bound is not None else 'unreachable'} "
        f"({lm.bound if lm else 0} disjoint landmarks, {planner.bound_seconds:.3f} s); "
        f"{'no' if mutexes is None else len(mutexes)} mutex pairs; "
        f"templates {planner.template_seconds:.3f} s "
        f"(per step: {planner.encoding.sizes['step'][0]} + {planner.encoding.sizes['layer'][0]} "
        f"assertions)\n")


def _print_stats(result) -> None:
    w = sys.stderr.write
    w(f"{'horizon':>7} {'clauses':>9} {'vars':>8} {'encode s':>9} {'solve s':>9}  result\n")
    for s in result.stats:
        w(f"{s.horizon:>7} {s.clauses:>9} {s.variables:>8} {s.encode_s:>9.3f} "
          f"{s.solve_s:>9.3f}  {s.result}\n")
    w(f"{result.status} after {result.seconds:.2f} s\n")
