"""`tmpc plan DOMAIN PROBLEM [-o PLAN] [--engine sat|astar|auto] [--min-steps N] [--max-steps N]
[--time-limit S] [-v]`.

Task planning alone, on any classical PDDL (geometric literals count as satisfied), by one of the
engines of :data:`~tmpc.runtime.planners.engines.ENGINES`: the incremental SAT planner
(length-optimal), A* with LM-cut (cost-optimal) or both in parallel (``auto``). The plan is written
in the IPC plan format (one ``(action arg ...)`` per line, then ``; cost = N (unit cost)`` and
``; length N``) after it is replayed on the ground problem. Exit 0 with a plan; 3 with no plan
within the limits (E611-E613, E616 say why: the goal is unreachable even ignoring deletes, every
length up to ``--max-steps`` is impossible, the time ran out and what was ruled out, or A*
explored every reachable state); 1 for bad input; 2 for bad limits. ``-v`` prints the engine that
answered and its statistics (per horizon for SAT; expansions/s and heuristic time for A*) on
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
from tmpc.runtime.planners import (ENGINES, EXHAUSTED, SOLVED, TIMEOUT, UNREACHABLE, Limits,
                                   simulate)


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
    limits = Limits(max(left, 0.001), args.min_steps, args.max_steps)
    result = ENGINES[args.engine].run(gp, limits)
    if args.verbose:
        _print_engines(args.engine, result)
    if result.status == UNREACHABLE:
        raise NoPlanError(_unreachable(gp, prog), files)
    if result.status != SOLVED:
        raise NoPlanError(_no_plan(result, args), files)
    actions = [gp.actions[i] for i in result.actions]
    ok, why = simulate(gp, actions)
    if not ok:
        raise RuntimeError(f"the plan found does not replay ({why})")
    text = plan_text(actions, gp.uses_costs, result.optimal)
    if args.output:
        write_atomically(args.output, text)
    else:
        sys.stdout.write(text)
    what = {"length": "shortest possible", "cost": "cheapest possible"}.get(
        result.optimal, f"shortest with at least {args.min_steps} steps")
    cost = f" and cost {sum(a.cost for a in actions):g}" if gp.uses_costs else ""
    sys.stderr.write(f"plan of length {len(actions)}{cost} ({what}) from the {result.engine} "
                     f"engine in {time.perf_counter() - t0:.2f} s"
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
    if args.engine == "astar" and args.min_steps > 0:
        problems.append("--min-steps is a horizon of the SAT engine; A* finds the cheapest plan "
                        "of any length")
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


def _no_plan(result, args):
    """E612, E613 or E616 for an engine's result without a plan (``auto``: the others' too)."""
    results = [result, *result.others]
    exhausted = next((r for r in results if r.engine == "astar" and r.status == EXHAUSTED),
                     None)
    if exhausted is not None:
        return error("E616", f"no plan: A* explored all {exhausted.detail.evaluated:,} "
                     "reachable states", None, "check the goal against the actions' effects "
                     "and the initial state")
    if all(r.status == TIMEOUT for r in results):
        ruled = "; ".join(_ruled_out(r) for r in sorted(results, key=lambda r: r.engine))
        return error("E613", f"time limit of {args.time_limit:g} s reached: {ruled}", None,
                     "raise --time-limit" + ("" if args.engine == "auto" else
                                             ", or try --engine auto"))
    r = next(r for r in results if r.engine == "sat" and r.status == EXHAUSTED)
    lo = r.detail.impossible_below
    if lo > args.max_steps:
        msg = f"no plan of length <= {args.max_steps}"
    else:
        msg = (f"no plan of length {max(args.min_steps, lo)} to {args.max_steps}"
               + (f" (lengths below {lo} are impossible)" if lo else ""))
    return error("E612", msg, None, "raise --max-steps to search longer plans")


def _ruled_out(r) -> str:
    if r.detail is None:
        return "no engine answered within the time limit"
    if r.engine == "astar":
        s = r.detail
        return (f"A* expanded {s.expanded:,} states, no plan costs less than {s.f_bound:g}"
                if s.expanded else "A* did not finish its first state")
    lo = r.detail.impossible_below
    return (f"SAT at horizon {r.detail.horizon}, "
            + (f"no plan of length < {lo} exists" if lo > 0 else "no length was ruled out"))


def plan_text(actions, uses_costs: bool, optimal: str = "length") -> str:
    """The IPC plan format: one ``(action arg ...)`` per line, lowercase, then the cost.
    ``optimal``: ``length`` (shortest), ``cost`` (cheapest) or ``""`` (neither proven)."""
    lines = [a.name.lower() for a in actions]
    n = len(actions)
    if uses_costs:
        cost = sum(a.cost for a in actions)
        lines.append(f"; cost = {cost:g} (general cost)")
        if optimal == "cost":
            lines.append(f"; length {n} (cheapest possible)")
        else:
            lines.append(f"; length {n} ({'shortest possible; ' if optimal else ''}action "
                         "costs are not minimized)")
    else:
        lines.append(f"; cost = {n} (unit cost)")
        lines.append(f"; length {n}")
    return "\n".join(lines) + "\n"


def write_atomically(path: str, text: str) -> None:
    """lang.fileio's atomic write (temporary file and rename, usual permissions); an unwritable
    place is E828, as for every plan file."""
    try:
        atomic_write_text(path, text)
    except OSError as exc:
        raise InputError(error("E828", f"cannot write {path}: {exc.strerror or exc}", None,
                               "check that the folder exists and is writable")) from None


def _print_engines(engine: str, result) -> None:
    """``-v``: the engine that answered, its figures, and the other engines of ``auto``."""
    w = sys.stderr.write
    if engine == "auto":
        others = ", ".join(f"{r.engine} {r.status} after {r.seconds:.2f} s"
                           for r in result.others) or "the other engine stopped"
        w(f"engine auto: {result.engine} answered first ({result.status} after "
          f"{result.seconds:.2f} s; {others})\n")
    for r in [result, *result.others]:
        _print_sat(r) if r.engine == "sat" else _print_astar(r)


def _print_astar(r) -> None:
    s = r.detail
    share = s.h_seconds / s.seconds if s.seconds else 0.0
    sys.stderr.write(
        f"astar: {r.status} after {s.seconds:.2f} s; h(init) = {s.h_init:g}, f bound "
        f"{s.f_bound:g}; {s.expanded:,} expanded ({s.expansions_per_s:,.0f}/s), "
        f"{s.reopened:,} reopened, {s.generated:,} generated, {s.evaluated:,} evaluated, "
        f"{s.dead_ends:,} dead ends; LM-cut {s.h_seconds:.2f} s ({share:.0%}, "
        f"{s.h_seconds / max(s.evaluated, 1) * 1e6:.0f} us per state)\n")


def _print_sat(r) -> None:
    w = sys.stderr.write
    su = r.setup
    bound = su["lower_bound"]
    mutexes = su["mutexes"]
    w(f"sat: lower bound: {bound if bound is not None else 'unreachable'} "
      f"({su['landmarks']} disjoint landmarks, {su['bound_s']:.3f} s); "
      f"{'no' if mutexes is None else mutexes} mutex pairs; "
      f"templates {su['template_s']:.3f} s "
      f"(per step: {su['per_step'][0]} + {su['per_step'][1]} assertions)\n")
    w(f"{'horizon':>7} {'clauses':>9} {'vars':>8} {'encode s':>9} {'solve s':>9}  result\n")
    for s in r.detail.stats:
        w(f"{s.horizon:>7} {s.clauses:>9} {s.variables:>8} {s.encode_s:>9.3f} "
          f"{s.solve_s:>9.3f}  {s.result}\n")
    w(f"sat: {r.status} after {r.detail.seconds:.2f} s\n")
