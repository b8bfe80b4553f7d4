"""What repair edits in a domain: the action's geometric precondition read as a :class:`Formula`
over templates, the instances a formula may use, truths given as DSL, and the write-back.

The action's precondition is a conjunction of discrete literals and exactly one geometric atom
whose predicate's ``:semantics`` is an and/or of template calls (``stdlib/templates.tmpc``) with
number parameters. Continuous instances are every template over an ordered pair (object,
manipulator) of that atom's parameters whose manipulator is a robot frame; discrete instances
are the domain's non-geometric predicates over the action's parameters. Repair writes the
continuous part back into the predicate's ``:semantics`` and the discrete literals into the
precondition, then formats the file with ``tmpc fmt``'s formatter and re-checks it.
"""

from __future__ import annotations

import difflib
import itertools
from dataclasses import dataclass

from tmpc.lang import ast as A
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.formatter import format_doc
from tmpc.lang.reader import parse_source
from tmpc.lang.reader_formulas import parse_expr
from tmpc.lang.scope import type_keys
from tmpc.lang.source import SourceFile
from tmpc.runtime.repair.model import TEMPLATES, Formula, Instance, Literal


@dataclass
class Target:
    """The ground action under repair and everything formulas over it may mention."""

    action: A.Action
    #: action parameter -> ground argument
    binding: dict[str, str]
    #: the geometric atom of the precondition and its predicate; action param -> predicate param
    atom: A.Atom
    predicate: A.PredicateDecl
    rename: dict[str, str]
    instances: list[Instance]
    start: Formula
    #: the domain's name (a store records it)
    domain_name: str

    @property
    def ground(self) -> str:
        return "(" + " ".join([self.action.name.text, *self.binding.values()]) + ")"

    def ground_atom(self, inst: Instance) -> str:
        return "(" + " ".join([inst.name, *(self.binding[a] for a in inst.args)]) + ")"


def _fail(code: str, msg: str, span=None, hint: str | None = None) -> InputError:
    return InputError(error(code, msg, span, hint))


def target(program, action: str, is_frame) -> Target:
    """The repair target for ``action`` (``NAME`` or ``NAME ARG...``); ``is_frame(name)`` says
    whether a ground argument is a robot frame."""
    scope = program.scope
    words = action.split()
    act = scope.actions.get(words[0].lower()) if words else None
    if act is None:
        known = ", ".join(sorted(a.name.text for a in scope.actions.values()))
        raise _fail("E844", f"unknown action `{action}`", None, f"the domain's actions: {known}")
    params = [p.name.text for p in act.params]
    if len(words) > 1:
        if len(words) - 1 != len(params):
            raise _fail("E844", f"`{act.name.text}` takes {len(params)} arguments, "
                        f"{len(words) - 1} given", act.span)
        binding = dict(zip(params, words[1:]))
    else:
        binding = _only_grounding(scope, act)
    for p, obj in binding.items():
        if obj.lower() not in scope.objects:
            raise _fail("E844", f"`{obj}` is not an object of the problem", act.span)
    pre = act.precondition
    parts = pre.parts if isinstance(pre, A.And) else (pre,) if pre is not None else ()
    geo, discrete = [], []
    for part in parts:
        neg = isinstance(part, A.Not)
        atom = part.part if neg else part
        if not isinstance(atom, A.Atom):
            raise _fail("E844", "repair reads a precondition that is a conjunction of atoms "
                        "and negated atoms", part.span)
        decl = scope.predicates.get(atom.pred.key)
        if decl is not None and decl.semantics is not None and not neg:
            geo.append((atom, decl))
        else:
            discrete.append(Literal(Instance(atom.pred.key, _arg_names(atom, params), True),
                                    None, not neg))
    if len(geo) != 1:
        raise _fail("E844", f"`{act.name.text}` needs exactly one geometric atom in its "
                    f"precondition to repair, found {len(geo)}", act.span,
                    "declare one predicate with `:semantics` over templates, e.g. "
                    "`(graspable ?c ?g :semantics (dist ?c ?g 0.5))`")
    atom, decl = geo[0]
    args = _arg_names(atom, params)
    rename = dict(zip(args, (p.name.text for p in decl.params)))
    back = {v: k for k, v in rename.items()}
    start_geo = formula_of(decl.semantics, scope, back)
    start = Formula(tuple(discrete), start_geo.clauses)
    instances = _instances(scope, act, binding, args, is_frame)
    _fits(start, instances, act, decl.span)
    return Target(act, binding, atom, decl, rename, instances, start, program.domain.name.text)


def _fits(f: Formula, instances, act: A.Action, span) -> None:
    missing = f.instances() - set(instances)
    if missing:
        inst = sorted(missing)[0]
        raise _fail("E845", f"`{inst.text()}` does not fit `{act.name.text}`: a continuous "
                    "template relates an object to a robot frame among the geometric atom's "
                    "arguments (object first), a discrete one is a domain predicate over the "
                    "action's parameters", span)


def _arg_names(atom: A.Atom, params: list[str]) -> tuple[str, ...]:
    out = []
    for t in atom.args:
        if not isinstance(t, A.Var) or t.name.text not in params:
            raise _fail("E844", "repair needs the precondition's atoms over the action's "
                        "parameters", atom.span)
        out.append(t.name.text)
    return tuple(out)


def _only_grounding(scope, act: A.Action) -> dict[str, str]:
    choices = []
    for p in act.params:
        want = type_keys(p.type)
        choices.append([o.name.text for o in scope.objects.values()
                        if scope.compatible(o.types, want)])
    combos = [c for c in itertools.product(*choices) if len(set(c)) == len(c)]
    if len(combos) != 1:
        raise _fail("E844", f"`{act.name.text}` has {len(combos)} groundings in this problem",
                    act.span, f'name the arguments: --action "{act.name.text} '
                    + " ".join(p.name.text for p in act.params) + '"')
    return dict(zip((p.name.text for p in act.params), combos[0]))


def _instances(scope, act, binding, geo_args, is_frame) -> list[Instance]:
    out = []
    for o, m in itertools.permutations(geo_args, 2):
        if is_frame(binding[m]) and not is_frame(binding[o]):
            out += [Instance(name, (o, m)) for name in TEMPLATES]
    types = {p.name.text: type_keys(p.type) for p in act.params}
    for decl in scope.predicates.values():
        if decl.semantics is not None or decl.external or decl.span is None:
            continue
        slots = [type_keys(p.type) for p in decl.params]
        for args in itertools.permutations(types, len(slots)):
            if all(scope.compatible(types[a], s) for a, s in zip(args, slots)):
                out.append(Instance(decl.name.key, args, True))
    return out


# ---------------------------------------------------------------------------------------------
# formulas from DSL


def formula_of(expr: A.Expr, scope, rename: dict[str, str], discrete_ok: bool = False) -> Formula:
    """``expr`` (an and/or of template calls, and with ``discrete_ok`` of discrete atoms) as a
    formula over action parameters (``rename``: the expression's variables -> parameters)."""
    discrete: list[Literal] = []

    def lit(e, positive=True):
        if not isinstance(e, A.Call):
            raise _bad(e)
        op = e.op.key
        if op == "not" and discrete_ok:
            return lit(e.args[0], not positive)
        args = []
        for a in e.args:
            if isinstance(a, A.ExprVar):
                args.append(rename.get(a.name.text, a.name.text))
        if op in TEMPLATES and positive:
            if len(e.args) != 3 or not isinstance(e.args[2], A.Num) or len(args) != 2:
                raise _fail("E845", f"`({e.op.text} ...)` takes an object, a manipulator and "
                            "a number", e.span)
            return Literal(Instance(op, tuple(args)), float(e.args[2].value))
        decl = scope.predicates.get(op)
        if discrete_ok and decl is not None and decl.semantics is None and \
                len(args) == len(e.args):
            discrete.append(Literal(Instance(op, tuple(args), True), None, positive))
            return None
        raise _bad(e)

    def conj(e) -> tuple[Literal, ...]:
        if isinstance(e, A.Call) and e.op.key == "and":
            return tuple(x for a in e.args for x in conj(a))
        got = lit(e)
        return () if got is None else (got,)

    def flat(e):
        if isinstance(e, A.Call) and e.op.key == "and":
            return [x for a in e.args for x in flat(a)]
        return [e]

    top = flat(expr)
    ors = [e for e in top if isinstance(e, A.Call) and e.op.key == "or"]
    if len(ors) > 1:
        raise _bad(ors[1])
    common = tuple(x for e in top if e not in ors for x in conj(e))
    clauses = tuple(common + conj(a) for a in ors[0].args) if ors else (common,)
    return Formula(tuple(discrete), clauses)


def _bad(e) -> InputError:
    names = ", ".join(TEMPLATES)
    return _fail("E845", "repair edits formulas of templates: an and/or of "
                 f"({names} ?object ?manipulator NUMBER) and, in a truth, discrete atoms",
                 getattr(e, "span", None), 'include "tmpc/templates" and write e.g. '
                 "`(and (dist ?c ?g 0.1) (roll-aligned ?c ?g 0.1))`")


def parse_truth(text: str, t: Target, scope) -> Formula:
    """A controller's hidden truth, DSL over the action's parameters."""
    expr, _src = parse_expr(text)
    f = formula_of(expr, scope, {p: p for p in t.binding}, discrete_ok=True)
    _fits(f, t.instances, t.action, None)
    return f


# ---------------------------------------------------------------------------------------------
# write-back


def rewrite(src: SourceFile, t: Target, f: Formula) -> str:
    """The domain text with ``f`` in place of the repaired predicate's semantics and the
    action's precondition, formatted as ``tmpc fmt`` would."""
    sem = t.predicate.semantics
    geo = f.geometric_text(t.rename)
    pre = t.action.precondition
    atom_text = src.text[t.atom.span.start:t.atom.span.end]
    parts = [lit.text() for lit in f.discrete] + [atom_text]
    new_pre = parts[0] if len(parts) == 1 else "(and " + " ".join(parts) + ")"
    edits = sorted([(sem.span.start, sem.span.end, geo),
                    (pre.span.start, pre.span.end, new_pre)], reverse=True)
    text = src.text
    for a, b, new in edits:
        text = text[:a] + new + text[b:]
    parsed = parse_source(SourceFile(src.path, text))
    if any(d.is_error for d in parsed.diagnostics):
        raise _fail("E848", f"{src.path}: the repaired domain does not parse", None)
    return format_doc(parsed.sexpr)


def diff(path: str, old: str, new: str) -> str:
    return "".join(difflib.unified_diff(old.splitlines(True), new.splitlines(True),
                                        f"a/{path}", f"b/{path}"))
