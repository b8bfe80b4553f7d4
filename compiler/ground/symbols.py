"""Geometric symbols: goal atoms over movable objects become facts the task level can plan for.

A geometric goal atom such as ``(on c b)`` whose objects move only when held, and which names no
robot frame, cannot be made true by moving the robot at the end of a plan: it is decided where
its objects were released. Following the thesis's "conditionally included geometric symbols"
(ch. 4), :func:`with_geometric_symbols` rewrites a checked program so that the task level knows
which actions can change such an atom, and the transition sampler makes it hold where the plan
needs it:

* each such predicate ``P`` gets a discrete *symbol* predicate ``P@achieved`` (same parameters);
* every action that releases an object ``?x`` (deletes a kinematic atom whose child is ``?x``)
  and already requires ``P`` of ``?x`` (``place ?c ?s`` requiring ``(on ?c ?s)``) adds the
  symbol of that literal; one that does not gets one *variant* per parameter slot of ``P`` that
  ``?x`` can fill: the action's parameters plus fresh ones for ``P``'s other slots, its
  precondition conjoined with ``P`` (so the release is sampled where ``P`` holds) and its effect
  with the symbol;
* every action that grasps ``?x`` (adds such a kinematic atom) deletes every symbol naming ``?x``
  (the object leaves the pose that made it true);
* the goal atom ``(P o...)`` becomes ``(and (P@achieved o...) (P o...))``: the geometry is still
  checked at the end, and the symbol tells the task planner which releases must achieve it.

Whether a symbol holds in the initial state is decided from the scene by the compiler
(:meth:`tmpc.compiler.compile.CompiledProgram.ground`). A plan names a variant as the action it
was made from (:func:`shown_as`); state listings leave symbols out (:func:`is_symbol`).
See docs/language.md, "Geometric goals".
"""

from __future__ import annotations

import re

from dataclasses import dataclass, replace

from tmpc.lang import ast as A
from tmpc.lang.checker import CheckedProgram

#: suffix of a symbol predicate's name (not a PDDL name: it cannot clash with the user's)
SYMBOL = "@achieved"
#: separator of a variant action's name: ``place~on~0`` is ``place`` achieving ``on`` with the
#: released object in slot 0
VARIANT = "~"
#: a variant's name: its action's, the predicate it achieves and the slot
_VARIANT_NAME = re.compile(r"(.+)~[^~]+~(\d+)")


def is_symbol(predicate: str) -> bool:
    """Is ``predicate`` (a ground atom's predicate name) a geometric symbol?"""
    return predicate.endswith(SYMBOL)


def shown_as(schema: str, args: tuple[str, ...], program: CheckedProgram) -> tuple[str, tuple]:
    """A (possibly variant) action as plans name it: its original schema and arguments."""
    m = _VARIANT_NAME.fullmatch(schema)
    base = program.scope.actions.get(m.group(1).lower()) if m else None
    if base is None:
        return schema, args     # not a variant (a semantics module's `move~grasp` stays itself)
    return base.name.text, args[:len(base.params)]


@dataclass(frozen=True)
class SymbolAtom:
    """A geometric goal atom the task level plans for: ``predicate`` applied to ``args``."""

    predicate: str
    args: tuple[str, ...]


def symbol_atoms(program: CheckedProgram, movable: set[str], frames: set[str]) -> list[SymbolAtom]:
    """The goal's positive geometric atoms (top-level conjunction) that name at least one
    ``movable`` object and no robot frame (names lower-case)."""
    out: list[SymbolAtom] = []
    if program.problem is None or program.problem.goal is None:
        return out
    for lit in A.conjuncts(program.problem.goal):
        if not isinstance(lit, A.Atom):
            continue
        decl = program.scope.predicates.get(lit.pred.key)
        if decl is None or decl.kind is not A.Kind.GEOMETRIC:
            continue
        if any(not isinstance(t, A.Const) for t in lit.args):
            continue
        names = {t.name.key for t in lit.args}
        if names & movable and not names & frames:
            out.append(SymbolAtom(decl.name.text, tuple(t.name.text for t in lit.args)))
    return out


def with_geometric_symbols(program: CheckedProgram, movable: set[str],
                           frames: set[str]) -> CheckedProgram:
    """``program`` with symbols, variants and the goal rewritten as the module docstring says;
    ``program`` itself when its goal has no such atom. ``movable``: names (lower-case) of the
    objects that move only when held; ``frames``: names of robot frames."""
    atoms = symbol_atoms(program, movable, frames)
    if not atoms:
        return program
    scope = program.scope
    preds = {a.predicate.lower(): scope.predicates[a.predicate.lower()] for a in atoms}
    symbols = {k: A.PredicateDecl(A.Name(d.name.text + SYMBOL), d.params, A.Kind.DISCRETE)
               for k, d in preds.items()}
    kinematic = [d for d in scope.predicates.values() if d.kinematic is not None]
    actions: list[A.Action] = []
    for act in program.domain.actions:
        grasped, released = _kinematic_children(act, kinematic)
        deletes = [_forget(sym, preds[k], x, act, scope)
                   for x in grasped for k, sym in symbols.items()]
        deletes = [d for group in deletes for d in group]
        actions.append(_with_effects(act, deletes) if deletes else act)
        for x in released:
            for k, sym in symbols.items():
                own = _own_literals(actions[-1], x, preds[k])
                if own:
                    # the release already requires P of its object: it achieves it itself
                    actions[-1] = _with_effects(actions[-1], [
                        A.AddEffect(A.Atom(sym.name, lit.args)) for lit in own])
                    continue
                actions += _variants(act, x, preds[k], sym, scope)
    domain = replace(program.domain, predicates=program.domain.predicates
                     + tuple(symbols.values()), actions=tuple(actions))
    goal = _goal(program.problem.goal, {(a.predicate.lower(), tuple(x.lower() for x in a.args))
                                        for a in atoms}, symbols)
    problem = replace(program.problem, goal=goal)
    new_scope = replace(scope, predicates={**scope.predicates,
                                           **{d.name.key: d for d in symbols.values()}},
                        actions={a.name.key: a for a in actions})
    return replace(program, domain=domain, problem=problem, scope=new_scope)


# ---- pieces ---------------------------------------------------------------------------------
def _effect_literals(e):
    if isinstance(e, A.AndEffect):
        for p in e.parts:
            yield from _effect_literals(p)
    elif isinstance(e, (A.AddEffect, A.DelEffect)):
        yield e


def _kinematic_children(act: A.Action, kinematic: list[A.PredicateDecl]):
    """The parameters an action grasps (adds a kinematic atom on) and releases (deletes one)."""
    grasped: list[A.Typed] = []
    released: list[A.Typed] = []
    params = {p.name.key: p for p in act.params}
    by_key = {d.name.key: d for d in kinematic}
    for e in _effect_literals(act.effect):
        decl = by_key.get(e.atom.pred.key)
        if decl is None:
            continue
        slot = [p.name.key for p in decl.params].index(decl.kinematic.child.key)
        term = e.atom.args[slot]
        if isinstance(term, A.Var) and term.name.key in params:
            into = grasped if isinstance(e, A.AddEffect) else released
            if params[term.name.key] not in into:
                into.append(params[term.name.key])
    return grasped, released


def _type_keys(t: A.Typed) -> tuple[str, ...]:
    return tuple(n.key for n in t.type.names) if t.type else ("object",)


def _slots(x: A.Typed, pred: A.PredicateDecl, scope) -> list[int]:
    """The parameter slots of ``pred`` an object of ``x``'s type can fill."""
    return [i for i, p in enumerate(pred.params)
            if scope.compatible(_type_keys(x), _type_keys(p))
            or scope.compatible(_type_keys(p), _type_keys(x))]


def _fresh(act: A.Action, pred: A.PredicateDecl, slot: int, x: A.Typed):
    """Terms for ``pred``'s slots (``x`` in ``slot``), and the fresh parameters they need."""
    taken = {p.name.key for p in act.params}
    terms, extra = [], []
    for i, p in enumerate(pred.params):
        if i == slot:
            terms.append(A.Var(x.name))
            continue
        n = 1
        while f"?sym{n}" in taken:
            n += 1
        name = A.Name(f"?sym{n}")
        taken.add(name.key)
        extra.append(A.Typed(name, p.type))
        terms.append(A.Var(name))
    return tuple(terms), tuple(extra)


def _forget(sym: A.PredicateDecl, pred: A.PredicateDecl, x: A.Typed, act: A.Action, scope):
    """Effects deleting every symbol of ``pred`` that names the grasped ``x``."""
    out = []
    for slot in _slots(x, pred, scope):
        terms, extra = _fresh(act, pred, slot, x)
        body = A.DelEffect(A.Atom(sym.name, terms))
        out.append(A.ForallEffect(extra, body) if extra else body)
    return out


def _with_effects(act: A.Action, effects: list) -> A.Action:
    parts = (act.effect,) if act.effect is not None else ()
    return replace(act, effect=A.AndEffect(parts + tuple(effects)))


def _own_literals(act: A.Action, x: A.Typed, pred: A.PredicateDecl) -> list[A.Atom]:
    """Positive top-level literals of ``pred`` in ``act``'s precondition that name ``x``."""
    return [lit for lit in A.conjuncts(act.precondition) if isinstance(lit, A.Atom)
            and lit.pred.key == pred.name.key
            and any(isinstance(t, A.Var) and t.name.key == x.name.key for t in lit.args)]


def _variants(act: A.Action, x: A.Typed, pred: A.PredicateDecl, sym: A.PredicateDecl, scope):
    out = []
    for slot in _slots(x, pred, scope):
        terms, extra = _fresh(act, pred, slot, x)
        atom = A.Atom(pred.name, terms)
        pre = A.And((act.precondition, atom)) if act.precondition is not None \
            else atom
        name = A.Name(f"{act.name.text}{VARIANT}{pred.name.text}{VARIANT}{slot}", span=act.name.span)
        variant = replace(act, name=name, params=act.params + extra, precondition=pre)
        out.append(_with_effects(variant, [A.AddEffect(A.Atom(sym.name, terms))]))
    return out


def _goal(goal, keys: set, symbols: dict):
    if isinstance(goal, A.And):
        return replace(goal, parts=tuple(_goal(p, keys, symbols) for p in goal.parts))
    if isinstance(goal, A.Atom) and all(isinstance(t, A.Const) for t in goal.args):
        key = (goal.pred.key, tuple(t.name.key for t in goal.args))
        if key in keys:
            return A.And((A.Atom(symbols[goal.pred.key].name, goal.args, span=goal.span), goal),
                         span=goal.span)
    return goal
