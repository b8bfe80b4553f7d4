"""Static checks for `tmpc check`: actions that can never be applied, goals that can never hold.

:func:`static_checks` returns warnings (docs/diagnostics.md, W610-W613):

* **W610** an action whose precondition is contradictory as a formula: every distinct atom (same
  predicate, same argument terms) and every numeric comparison is a free Boolean and Z3 finds no
  assignment. This ignores what grounding could add (two variables bound to one object make more
  atoms equal, which only constrains more), so a contradiction found is real. Quantifiers whose
  type may be empty (``forall``, a negated ``exists``) are free Booleans; the others are opened
  with fresh variables. Needs no problem.
* **W611** (with a problem) an action none of whose ground instances is reachable: the grounder
  keeps only bindings whose precondition is not statically false and that the delete relaxation
  reaches, so none left means the action can never be applied. The message names the reason when
  it is simple: a parameter type without objects, a static predicate without facts, a predicate
  no reachable atom has.
* **W612** (with a problem) a goal unreachable in the delete relaxation, naming the goal atoms
  that no action sequence can make true.
* **W613** (a note) checks skipped: the time budget ran out, or the problem is too large to
  ground for a quick check.

Z3 is imported only when the checks run, so `tmpc check` stays light without them.
"""

from __future__ import annotations

import itertools
import time

from tmpc.compiler.ground import GroundingError, GroundProblem, bits, ground
from tmpc.compiler.smt.encode import relaxed_fixpoint
from tmpc.lang import ast as A
from tmpc.lang.checker import CheckedProgram
from tmpc.lang.diagnostics import Diagnostic, Severity, warning

#: grounding cap for the quick checks (bindings per schema); larger problems get a W613 note
CHECK_MAX_BINDINGS = 200_000


def static_checks(program: CheckedProgram, budget_s: float = 2.0) -> list[Diagnostic]:
    """W610-W613 warnings for ``program`` (see the module docstring) within ``budget_s``."""
    t0 = time.perf_counter()
    out: list[Diagnostic] = []
    contradictory = set()
    ctx = None
    for act in program.domain.actions:
        if time.perf_counter() - t0 > budget_s:
            out.append(not_checked_note("the contradiction check of action preconditions",
                                        act.name.span))
            return out
        if act.precondition is None:
            continue
        if ctx is None:
            import z3
            ctx = z3.Context()
        if _contradictory(ctx, act.precondition, budget_s):
            contradictory.add(act.name.key)
            out.append(warning("W610", f"action `{act.name.text}` can never be applied: its "
                               "precondition is contradictory", act.name.span,
                               "some literal is required both true and false"))
    if program.problem is None:
        return out
    try:
        gp = ground(program, max_bindings=CHECK_MAX_BINDINGS)
    except GroundingError:
        out.append(not_checked_note(
            "grounding-based checks (the problem is too large to ground quickly)",
            program.problem.name.span))
        return out
    if time.perf_counter() - t0 > budget_s:
        out.append(not_checked_note("grounding-based checks", program.problem.name.span))
        return out
    out += _never_applicable(program, gp, contradictory)
    if not gp.goal_relaxed_reachable:
        out.append(_goal_warning(program, gp))
    return out


def not_checked_note(what: str, span) -> Diagnostic:
    """The W613 note: a check (``what``) did not run within its time budget."""
    return Diagnostic("W613", Severity.NOTE, f"unknown: {what} did not run within the time "
                      "budget", span)


def unreachable_goal_atoms(gp: GroundProblem) -> list[int]:
    """Positive goal atoms that the delete relaxation never reaches."""
    _, _, reached = relaxed_fixpoint(gp)
    return sorted(i for i in gp.goal.pos if not (reached >> i) & 1)


def unreachable_goal_names(program: CheckedProgram, gp: GroundProblem) -> list[str]:
    """The goal's top-level atoms that can never be true, as the user wrote them: state atoms the
    delete relaxation never reaches, and atoms of predicates no action changes that are not in
    ``:init`` (grounding folds those to false)."""
    out = [gp.atom_name(i) for i in unreachable_goal_atoms(gp)]
    goal = program.problem.goal if program.problem is not None else None
    sc = program.scope
    for atom in _top_positive_atoms(goal):
        decl = sc.predicates.get(atom.pred.key)
        if decl is None or decl.kind is A.Kind.GEOMETRIC or \
                not all(isinstance(t, A.Const) for t in atom.args):
            continue
        args = tuple(t.name.key for t in atom.args)
        if gp.atom_id(atom.pred.key, *args) is None and \
                (atom.pred.key, args) not in gp.static_facts:
            out.append("(" + " ".join([atom.pred.text] + [t.name.text for t in atom.args]) + ")")
    return out


def _goal_warning(program: CheckedProgram, gp: GroundProblem) -> Diagnostic:
    atoms = unreachable_goal_names(program, gp)
    goal = program.problem.goal
    span = goal.span if goal is not None else program.problem.name.span
    if atoms:
        names = ", ".join(atoms[:5]) + (" ..." if len(atoms) > 5 else "")
        msg = f"the goal can never be reached: no sequence of actions makes {names} true"
    else:
        msg = "the goal can never be reached, even ignoring delete effects"
    return warning("W612", msg, span, "`tmpc plan` would stop at once with no plan")


# ---------------------------------------------------------------------------------------------
# Actions no grounding keeps


def _never_applicable(program: CheckedProgram, gp: GroundProblem,
                      skip: set[str]) -> list[Diagnostic]:
    kept = {a.schema.lower() for a in gp.actions}
    _, _, reached = relaxed_fixpoint(gp)
    live_preds = {gp.atoms[i].predicate.lower() for i in bits(reached)}
    static_preds = {p for p, _ in gp.static_facts}
    out = []
    for act in program.domain.actions:
        key = act.name.key
        if key in kept or key in skip:
            continue
        why = _reason(program, act, gp, live_preds, static_preds)
        out.append(warning("W611", f"action `{act.name.text}` can never be applied in problem "
                           f"`{program.problem.name.text}`: {why}", act.name.span))
    return out


def _reason(program, act, gp, live_preds, static_preds) -> str:
    sc = program.scope
    for p in act.params:
        types = tuple(n.key for n in p.type.names) if p.type is not None else ("object",)
        if not any(o.types & set(types) for o in gp.objects):
            return f"there is no object of type `{' '.join(types)}` for `{p.name.text}`"
    for lit in _top_positive_atoms(act.precondition):
        key = lit.pred.key
        decl = sc.predicates.get(key)
        if decl is None or decl.kind is A.Kind.GEOMETRIC:
            continue
        atom_kind = key in sc.derived or any(a.predicate.lower() == key for a in gp.atoms)
        if atom_kind and key not in live_preds:
            return f"no `({lit.pred.text} ...)` atom can ever become true"
        if not atom_kind and key not in static_preds and key not in live_preds:
            return (f"`{lit.pred.text}` never changes and has no fact in `:init`, so "
                    f"`({lit.pred.text} ...)` is always false")
    return "no binding of its parameters has a precondition reachable from the initial state"


def _top_positive_atoms(f):
    if isinstance(f, A.Atom):
        yield f
    elif isinstance(f, A.And):
        for p in f.parts:
            yield from _top_positive_atoms(p)


# ---------------------------------------------------------------------------------------------
# Contradictory preconditions


def _contradictory(ctx, f: A.Formula, budget_s: float) -> bool:
    import z3
    counter = itertools.count()
    expr = _to_z3(z3, ctx, f, {}, True, counter)
    s = z3.Solver(ctx=ctx)
    s.set("timeout", max(1, int(budget_s * 1000)))
    s.add(expr)
    return s.check() == z3.unsat


def _term(t, env: dict[str, str]) -> str:
    if isinstance(t, A.Var):
        return env.get(t.name.key, t.name.key)
    return "'" + t.name.key


def _to_z3(z3, ctx, f, env: dict[str, str], positive: bool, counter):
    """``f`` with atoms as Booleans. ``positive``: the polarity ``f`` appears with (a quantifier
    that may range over an empty type is a free Boolean)."""
    fresh = lambda: z3.Bool(f"_q{next(counter)}", ctx)      # noqa: E731
    if isinstance(f, A.Atom):
        return z3.Bool("(" + " ".join([f.pred.key] + [_term(t, env) for t in f.args]) + ")", ctx)
    if isinstance(f, A.Equals):
        left, right = sorted((_term(f.left, env), _term(f.right, env)))
        if left == right:
            return z3.BoolVal(True, ctx)
        if left.startswith("'") and right.startswith("'"):
            return z3.BoolVal(False, ctx)
        return z3.Bool(f"(= {left} {right})", ctx)
    if isinstance(f, A.And):
        return z3.And([_to_z3(z3, ctx, p, env, positive, counter) for p in f.parts] or
                      [z3.BoolVal(True, ctx)])
    if isinstance(f, A.Or):
        return z3.Or([_to_z3(z3, ctx, p, env, positive, counter) for p in f.parts] or
                     [z3.BoolVal(False, ctx)])
    if isinstance(f, A.Not):
        return z3.Not(_to_z3(z3, ctx, f.part, env, not positive, counter))
    if isinstance(f, A.Imply):
        return z3.Or(z3.Not(_to_z3(z3, ctx, f.left, env, not positive, counter)),
                     _to_z3(z3, ctx, f.right, env, positive, counter))
    if isinstance(f, A.Quantified):
        opens = (f.kind == "exists") == positive      # a witness is needed: safe to open
        if not opens:
            return fresh()
        inner = dict(env)
        for p in f.params:
            inner[p.name.key] = f"{p.name.key}#{next(counter)}"
        return _to_z3(z3, ctx, f.body, inner, positive, counter)
    return fresh()                                      # numeric comparisons and the rest


__all__ = ["static_checks", "unreachable_goal_atoms", "unreachable_goal_names",
           "CHECK_MAX_BINDINGS", "not_checked_note"]
