"""The checker: a parsed domain (+ problem, + included modules) -> :class:`CheckedProgram`.

It resolves every name, checks PDDL typing and arity, the kind rules of the tmpc extension
(geometric atoms never in effects, discrete atoms never in `:semantics` bodies), expression types
(via :mod:`tmpc.lang.checker_expr`), and warns where a requirement flag is missing for a
feature used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from tmpc.lang import ast as A
from tmpc.lang import symbols as K
from tmpc.lang.checker_expr import ExprChecker
from tmpc.lang.columns import InitFacts, TypedNames
from tmpc.lang.diagnostics import Diagnostic, DiagnosticSink, Related, error, warning
from tmpc.lang.reader_common import suggest
from tmpc.lang.scope import OBJECT, ObjectInfo, Scope, type_keys
from tmpc.lang.source import Span

LEGACY = (A.Dialect.PLANET, A.Dialect.TMIT_STAR)


@dataclass(frozen=True)
class CheckedProgram:
    """A domain and optional problem that passed the checker (no errors; warnings allowed)."""

    domain: A.Domain
    problem: A.Problem | None
    scope: Scope
    modules: tuple[A.Domain, ...] = ()
    diagnostics: tuple[Diagnostic, ...] = ()


@dataclass
class _Uses:
    """Features seen, for requirement warnings: feature -> first span."""

    seen: dict[str, Span] = field(default_factory=dict)

    def mark(self, feature: str, span: Span) -> None:
        self.seen.setdefault(feature, span)


FEATURE_REQS = {
    "typing": (":typing", "types"),
    "negation": (":negative-preconditions", "a negative precondition"),
    "disjunction": (":disjunctive-preconditions", "`or`/`imply` in a precondition"),
    "equality": (":equality", "`=`"),
    "exists": (":existential-preconditions", "`exists`"),
    "forall": (":universal-preconditions", "`forall` in a precondition"),
    "conditional": (":conditional-effects", "`when` or `forall` in an effect"),
    "derived": (":derived-predicates", "`:derived`"),
    "costs": (":action-costs", "action costs"),
    "numeric": (":numeric-fluents", "numeric fluents"),
}


class Checker:
    def __init__(self, domain: A.Domain, problem: A.Problem | None = None,
                 modules: tuple[A.Domain, ...] = ()):
        self.domain, self.problem, self.modules = domain, problem, modules
        self.sink = DiagnosticSink()
        self.scope = Scope()
        self.uses = _Uses()
        self.legacy = domain.dialect in LEGACY
        self.exprs = ExprChecker(self.scope, self.sink)
        self._type_sets: dict[tuple[str, ...], tuple[str, ...]] = {}
        #: undeclared constants read as robot frames (W018), by key
        self._frames: set[str] = set()

    # ---- driver --------------------------------------------------------------------------
    def run(self) -> list[Diagnostic]:
        d = self.domain
        self.check_requirements(d.requirements)
        for m in self.modules:
            self.declare_module(m)
        self.declare_types(d)
        self.declare_objects(d.constants, constant=True)
        self.declare_predicates(d)
        self.declare_functions(d)
        for h in d.defines:
            self._declare_unique(self.scope.helpers, h.name, h, "helper")
        self.warn_shadowing(d)
        for der in d.derived:
            self.check_derived(der)
        for h in d.defines:
            self.exprs.check_helper_definition(h)
        for p in d.predicates:
            if p.semantics is not None:
                self.exprs.check_semantics(p)
        if self.problem is not None:
            # Old IPC domains (tyreworld) name problem objects in actions; see term_types.
            self.declare_objects(self.problem.objects, constant=False)
        for act in d.actions:
            self._declare_unique(self.scope.actions, act.name, act, "action")
            self.check_action(act)
        if d.form == "module" and d.actions:
            self.sink.add(error("E122", "a module cannot define actions", d.actions[0].span))
        if self.problem is not None:
            self.check_problem(self.problem)
        self.requirement_warnings()
        return self.sink.items

    def declare_module(self, m: A.Domain) -> None:
        for h in m.defines:
            self.scope.module_helpers.setdefault(h.name.key, h)

    def warn_shadowing(self, d: A.Domain) -> None:
        for item in (*d.defines, *d.predicates):
            inc = self.scope.module_helpers.get(item.name.key)
            if inc is not None:
                self.sink.add(warning("W016", f"`{item.name.text}` shadows the helper of the same "
                                      f"name from an included module", item.name.span,
                                      "rename it to use the included helper",
                                      related=[Related(inc.name.span, "the included helper")]))

    def _declare_unique(self, table: dict, name: A.Name, value, what: str) -> bool:
        prev = table.get(name.key)
        if prev is not None and getattr(prev, "span", None) is not None:
            self.sink.add(error("E201", f"{what} `{name.text}` is defined twice", name.span,
                                related=[Related(prev.name.span, "first defined here")]))
            return False
        table[name.key] = value
        return True

    # ---- requirements --------------------------------------------------------------------
    def check_requirements(self, reqs: tuple[A.Requirement, ...]) -> None:
        for r in reqs:
            if r.name.key in K.UNSUPPORTED_REQUIREMENTS:
                self.sink.add(warning("W003", f"requirement `{r.name.text}` is accepted but tmpc "
                                      "does not plan with it", r.span))

    def requirement_warnings(self) -> None:
        declared = K.closure({r.name.key for r in self.domain.requirements})
        if self.problem is not None:
            declared |= K.closure({r.name.key for r in self.problem.requirements})
        if self.legacy:
            return   # planet/tmit-star ignored requirements; nagging legacy files helps nobody
        for feature, span in self.uses.seen.items():
            req, what = FEATURE_REQS[feature]
            if req not in declared and not (feature == "numeric" and ":fluents" in declared):
                self.sink.add(warning("W001", f"{what} used without `{req}` in `:requirements`",
                                      span, f"add `{req}` to the domain's `:requirements`"))

    # ---- types and objects ---------------------------------------------------------------
    def declare_types(self, d: A.Domain) -> None:
        th = self.scope.types
        for m in self.modules:
            for t in m.types:
                th.declare(t.name, t.parent.names if t.parent else ())
        for t in d.types:
            th.declare(t.name, t.parent.names if t.parent else ())
            if t.parent is not None:
                self.uses.mark("typing", t.span)
        for t in d.types:
            for p in (t.parent.names if t.parent else ()):
                if p.key not in th:
                    th.declare(p, ())   # a type named only as a parent is declared by that use
        cyc = th.cycle()
        if cyc:
            where = th.decl.get(cyc[0])
            self.sink.add(error("E207", "cyclic type hierarchy: " + " -> ".join(cyc),
                                where.span if where else d.span))
            for t in cyc:
                th.parents[t] = {OBJECT} if t != OBJECT else set()

    def require_type(self, name: A.Name) -> None:
        th = self.scope.types
        if name.key in th:
            return
        if self.legacy or not self.domain.types:
            # Legacy files and untyped-`:types` domains use types without declaring them.
            th.declare(name, ())
            return
        # Real IPC files (tetris) use undeclared types: accept them as subtypes of `object`.
        self.sink.add(warning("W012", f"type `{name.text}` is not declared; it is taken as a "
                              "subtype of `object`", name.span,
                              _did_you_mean(name.key, th.parents) or
                              "declare it in `(:types ...)`"))
        th.declare(name, ())

    def check_typed(self, params: tuple[A.Typed, ...], what: str,
                    decl: bool = False) -> dict[str, tuple[str, ...]]:
        """Check a typed variable list; return var key -> type keys.

        ``decl``: a predicate/function declaration, where a repeated name is only a warning
        (IPC's logistics00 declares `(in ?obj ?obj)`).
        """
        out: dict[str, tuple[str, ...]] = {}
        first: dict[str, A.Name] = {}
        for p in params:
            if p.type is not None:
                self.uses.mark("typing", p.span)
                for n in p.type.names:
                    self.require_type(n)
            if p.name.key in first:
                make = warning if decl else error
                self.sink.add(make("W014" if decl else "E201",
                                   f"`{p.name.text}` appears twice in {what}", p.name.span,
                                   related=[Related(first[p.name.key].span, "first here")]))
            first.setdefault(p.name.key, p.name)
            out[p.name.key] = type_keys(p.type)
        return out

    def declare_objects(self, items: tuple[A.Typed, ...], constant: bool) -> None:
        if isinstance(items, TypedNames):
            self._declare_packed_objects(items, constant)
            return
        for o in items:
            self._declare_object(o, constant)

    def _declare_object(self, o: A.Typed, constant: bool) -> None:
        if o.type is not None:
            for n in o.type.names:
                self.require_type(n)
        prev = self.scope.objects.get(o.name.key)
        if prev is not None:
            if prev.constant and not constant:
                self.sink.add(warning("W010", f"object `{o.name.text}` repeats a domain "
                                      "constant", o.name.span,
                                      related=[Related(prev.name.span, "the constant")]))
                return
            self.sink.add(error("E201", f"object `{o.name.text}` is declared twice",
                                o.name.span, related=[Related(prev.name.span, "first here")]))
            return
        self.scope.objects[_key(o.name.text)] = ObjectInfo(o.name, self._shared(type_keys(o.type)),
                                                           constant)

    def _shared(self, types: tuple[str, ...]) -> tuple[str, ...]:
        """One tuple per distinct type set (a large problem's objects share a few)."""
        return self._type_sets.setdefault(types, types)

    def _declare_packed_objects(self, items: TypedNames, constant: bool) -> None:
        """:meth:`declare_objects` of names kept as columns: each name's info refers to its
        entry (the Name is built only for a diagnostic or a language-server request)."""
        objects = self.scope.objects
        group_types: dict[int, tuple[str, ...]] = {}
        ref, grp = items.ref, items.grp
        for j in range(len(ref)):
            if ref[j] < 0:
                self._declare_object(items.others[j], constant)
                continue
            g = grp[j]
            types = group_types.get(g)
            if types is None:
                tref = items.groups[g][0]
                for n in (tref.names if tref is not None else ()):
                    self.require_type(n)
                types = group_types[g] = self._shared(type_keys(tref))
            key = _key(items.name_text(j))
            if key in objects:
                self._declare_object(items[j], constant)
                continue
            objects[key] = ObjectInfo(items, types, constant, j)

    # ---- predicates and functions --------------------------------------------------------
    def declare_predicates(self, d: A.Domain) -> None:
        for p in d.predicates:
            if not self._declare_unique(self.scope.predicates, p.name, p, "predicate"):
                continue
            params = self.check_typed(p.params, f"`{p.name.text}`'s parameters", decl=True)
            if p.kinematic is not None:
                for v in (p.kinematic.parent, p.kinematic.child):
                    if v.key not in params:
                        self.sink.add(error("E402", f"`{v.text}` in the kinematic annotation is "
                                            f"not a parameter of `{p.name.text}`", v.span))
                if p.kinematic.parent.key == p.kinematic.child.key:
                    self.sink.add(error("E402", "an object cannot be linked to itself",
                                        p.kinematic.span))

    def declare_functions(self, d: A.Domain) -> None:
        for f in d.functions:
            self._declare_unique(self.scope.functions, f.name, f, "function")
            self.check_typed(f.params, f"`{f.name.text}`'s parameters", decl=True)

    # ---- actions and formulas ------------------------------------------------------------
    def check_action(self, act: A.Action) -> None:
        env = self.check_typed(act.params, f"the parameters of `{act.name.text}`")
        used: set[str] = set()
        if act.precondition is not None:
            self.check_formula(act.precondition, env, used, "precondition")
        if act.effect is not None:
            self.check_effect(act.effect, env, used)
        for p in act.params:
            if p.name.key not in used:
                self.sink.add(warning("W002", f"parameter `{p.name.text}` of `{act.name.text}` "
                                      "is never used", p.name.span))

    def check_derived(self, der: A.Derived) -> None:
        self.uses.mark("derived", der.span)
        decl = self.scope.predicates.get(der.name.key)
        env = self.check_typed(der.params, f"the parameters of derived `{der.name.text}`")
        if decl is None:
            self.sink.add(error("E200", f"derived predicate `{der.name.text}` is not declared in "
                                "`:predicates`", der.name.span, "declare it with its parameters"))
        elif len(decl.params) != len(der.params):
            self.sink.add(error("E202", f"derived `{der.name.text}` has {len(der.params)} "
                                f"parameters; its declaration has {len(decl.params)}",
                                der.name.span, related=[Related(decl.span, "declared here")]))
        self.scope.derived.setdefault(der.name.key, []).append(der)
        self.check_formula(der.body, env, set(), "derived")

    def check_formula(self, f: A.Formula, env: dict, used: set, where: str,
                      negated: bool = False) -> None:
        if isinstance(f, A.Atom):
            self.check_atom(f, env, used, where)
            if negated:
                self.uses.mark("negation", f.span)
        elif isinstance(f, A.Equals):
            self.uses.mark("equality", f.span)
            for t in (f.left, f.right):
                self.term_types(t, env, used)
        elif isinstance(f, A.Compare):
            self.uses.mark("numeric", f.span)
            self.check_num(f.left, env, used)
            self.check_num(f.right, env, used)
        elif isinstance(f, A.And):
            for p in f.parts:
                self.check_formula(p, env, used, where, negated)
        elif isinstance(f, A.Or):
            self.uses.mark("disjunction", f.span)
            for p in f.parts:
                self.check_formula(p, env, used, where, negated)
        elif isinstance(f, A.Not):
            self.check_formula(f.part, env, used, where, not negated)
        elif isinstance(f, A.Imply):
            self.uses.mark("disjunction", f.span)
            self.check_formula(f.left, env, used, where, not negated)
            self.check_formula(f.right, env, used, where, negated)
        elif isinstance(f, A.Quantified):
            self.uses.mark("exists" if (f.kind == "exists") != negated else "forall", f.span)
            inner = dict(env)
            inner.update(self.check_typed(f.params, f"the `{f.kind}` variables"))
            self.check_formula(f.body, inner, used, where, negated)

    def check_atom(self, at: A.Atom, env: dict, used: set, where: str) -> A.PredicateDecl | None:
        decl = self.scope.predicates.get(at.pred.key)
        if decl is None:
            hint = _did_you_mean(at.pred.key, self.scope.predicates)
            if at.pred.key in self.scope.functions:
                hint = f"`{at.pred.text}` is a function; compare it, e.g. `(> ({at.pred.text} ...) 0)`"
            self.sink.add(error("E200", f"unknown predicate `{at.pred.text}`", at.pred.span,
                                hint or "declare it in `(:predicates ...)`"))
            for t in at.args:
                self.term_types(t, env, used)
            return None
        self.check_args(at.args, decl.params, at, env, used, f"`{decl.name.text}`", decl.span)
        return decl

    def check_args(self, args, params, node, env, used, what: str, decl_span: Span) -> None:
        if len(args) != len(params):
            self.sink.add(error("E202", f"{what} takes {len(params)} argument"
                                f"{'s' if len(params) != 1 else ''}, given {len(args)}",
                                node.span, related=[Related(decl_span, "declared here")]))
        for t, p in zip(args, params):
            actual = self.term_types(t, env, used)
            expected = type_keys(p.type)
            if actual is not None and not self.scope.compatible(actual, expected):
                self.sink.add(error("E204", f"`{t.name.text}` has type {_types(actual)}, but "
                                    f"{what} expects {_types(expected)} for `{p.name.text}`",
                                    t.span, related=[Related(p.span, "parameter declared here")]))

    def term_types(self, t: A.Term, env: dict, used: set) -> tuple[str, ...] | None:
        if isinstance(t, A.Var):
            if t.name.key not in env:
                self.sink.add(error("E205", f"unknown variable `{t.name.text}`", t.span,
                                    _did_you_mean(t.name.key, env) or
                                    "declare it in `:parameters` or a quantifier"))
                return None
            used.add(t.name.key)
            return env[t.name.key]
        info = self.scope.objects.get(t.name.key)
        if info is not None and t.name.key in self._frames:
            return None          # a W018 robot frame: it takes the type each use wants
        in_domain = self.problem is None or not self._in_problem(t.span)
        if info is not None and in_domain and not info.constant:
            self.sink.add(warning("W013", f"the domain uses `{t.name.text}`, an object of the "
                                  "problem", t.span, "declare it in the domain's `(:constants ...)`",
                                  related=[Related(info.name.span, "declared here")]))
        if info is None and in_domain and self.domain.dialect is A.Dialect.PLANET:
            return self._planet_frame(t)
        if info is None and self.problem is None and self.domain.form == "domain":
            self.sink.add(warning("W013", f"`{t.name.text}` is not a constant of the domain; it "
                                  "must be an object of every problem", t.span,
                                  _did_you_mean(t.name.key, self.scope.objects) or
                                  "declare it in `(:constants ...)`, or did you mean a ?variable?"))
            return None
        if info is None:
            what = "constant" if in_domain else "object"
            self.sink.add(error("E206", f"unknown {what} `{t.name.text}`", t.span,
                                _did_you_mean(t.name.key, self.scope.objects) or
                                ("declare it in `(:constants ...)`, or did you mean a ?variable?"
                                 if in_domain else "declare it in `(:objects ...)`")))
            return None
        return info.types

    def _planet_frame(self, t: A.Const) -> None:
        """planet's domains name robot links as constants they never declare (its
        clutter_nohit.pddl: ``l_upper_arm_link``). The name becomes an untyped constant: W018
        once, no type check at any use (it takes the type the parameter wants: planet's
        ``donthits ?l - link``), never an action's argument; the scene resolves it (a robot
        frame or an object, else E822 at run time)."""
        self.sink.add(warning("W018", f"`{t.name.text}` is not declared; as in planet, it is read "
                              "as a robot frame or scene object", t.span,
                              "declare it in `(:constants ...)` to give it a type"))
        self.scope.objects[t.name.key] = ObjectInfo(t.name, (), constant=True)
        self._frames.add(t.name.key)
        return None

    def _lenient_init(self) -> bool:
        """Are init facts naming undeclared objects W015 (ignored) rather than E206? In legacy
        files, and in classical ones that use types without declaring `:typing` (written for
        planners that checked nothing: the Lagriffoul suite's blocksworld_pb_C.pddl has
        `(clear d)`)."""
        return self.legacy or (
            self.domain.dialect is A.Dialect.PDDL and "typing" in self.uses.seen and
            ":typing" not in {r.name.key for r in self.domain.requirements})

    def _unknown_objects(self, item: A.Atom) -> bool:
        """Legacy init facts naming undeclared objects (tmit-star's clutter pb_11 has them) are
        ignored with a warning, as the original planners did; the grounder drops them too
        (:meth:`_lenient_init` says which files)."""
        bad = [t for t in item.args if isinstance(t, A.Const) and
               t.name.key not in self.scope.objects]
        for t in bad:
            self.sink.add(warning("W015", f"`{t.name.text}` is not an object of the problem; this "
                                  "fact is ignored", item.span,
                                  "declare the object in `(:objects ...)` or remove the fact"))
        return bool(bad)

    def _in_problem(self, span: Span) -> bool:
        p = self.problem
        return p is not None and span.path == p.span.path and \
            p.span.start <= span.start < p.span.end

    def check_num(self, e: A.NumExpr, env: dict, used: set) -> None:
        if isinstance(e, A.FuncTerm):
            decl = self.scope.functions.get(e.name.key)
            if decl is None:
                self.sink.add(error("E208", f"unknown function `{e.name.text}`", e.name.span,
                                    _did_you_mean(e.name.key, self.scope.functions) or
                                    "declare it in `(:functions ...)`"))
                return
            self.check_args(e.args, decl.params, e, env, used, f"`{decl.name.text}`", decl.span)
        elif isinstance(e, A.NumOp):
            for a in e.args:
                self.check_num(a, env, used)

    def check_effect(self, e: A.Effect, env: dict, used: set) -> None:
        if isinstance(e, A.AndEffect):
            for p in e.parts:
                self.check_effect(p, env, used)
        elif isinstance(e, (A.AddEffect, A.DelEffect)):
            decl = self.check_atom(e.atom, env, used, "effect")
            if decl is not None:
                self.check_effect_kind(decl, e)
        elif isinstance(e, A.ForallEffect):
            self.uses.mark("conditional", e.span)
            inner = dict(env)
            inner.update(self.check_typed(e.params, "the `forall` variables"))
            self.check_effect(e.body, inner, used)
        elif isinstance(e, A.WhenEffect):
            self.uses.mark("conditional", e.span)
            self.check_formula(e.condition, env, used, "condition")
            self.check_effect(e.body, env, used)
        elif isinstance(e, A.NumericEffect):
            is_cost = e.target.name.key == "total-cost"
            self.uses.mark("costs" if is_cost else "numeric", e.span)
            self.check_num(e.target, env, used)
            self.check_num(e.value, env, used)
            if is_cost and isinstance(e.value, A.Num) and not (
                    math.isfinite(e.value.value) and (e.value.value >= 0 or e.op != "increase")):
                self.sink.add(error("E406", f"action cost `{e.value.text}`: costs are finite and "
                                    "not negative", e.value.span,
                                    "an optimal planner's bound needs costs >= 0; use 0 for free "
                                    "actions"))

    def check_effect_kind(self, decl: A.PredicateDecl, e) -> None:
        if decl.name.key in self.scope.derived:
            self.sink.add(error("E405", f"derived predicate `{decl.name.text}` cannot be changed "
                                "by an effect", e.span))
        if decl.kind is not A.Kind.GEOMETRIC:
            return
        msg = f"geometric predicate `{decl.name.text}` in an effect"
        if self.legacy:
            self.sink.add(warning("W004", msg + "; it is ignored, as planet did", e.span,
                                  "its value follows from the geometry; remove it"))
        else:
            self.sink.add(error("E400", msg + ": its value follows from the geometry", e.span,
                                "effects may change only discrete and kinematic predicates",
                                related=[Related(decl.span, "declared geometric here")]))

    # ---- problem ---------------------------------------------------------------------------
    def _check_init_item(self, item: A.InitItem, env: dict) -> None:
        if isinstance(item, A.Atom) and self._lenient_init() and self._unknown_objects(item):
            return
        if isinstance(item, A.Atom):
            decl = self.check_atom(item, env, set(), "init")
            if decl is not None and decl.kind is A.Kind.GEOMETRIC:
                self.sink.add(error("E404", f"geometric predicate `{decl.name.text}` in "
                                    "`:init`: its value follows from the scene", item.span,
                                    "remove it; tmpc evaluates it on the initial state"))
        elif isinstance(item, A.NumericInit):
            self.check_num(item.target, env, set())
        elif isinstance(item, A.Equals):
            self.check_formula(item, env, set(), "init")

    def _check_packed_init(self, init: InitFacts, env: dict) -> None:
        """:meth:`_check_init_item` of each fact, from the symbol ids of the columns: a fact
        whose predicate (or function) is known, of the right arity and with known objects of
        fitting types has nothing to report, and is not built; any other is built and checked
        as a node (so its diagnostics are the same)."""
        names = init.src.names
        scope = self.scope
        heads: dict[tuple[bool, int], tuple | None] = {}     # (numeric, id) -> (arity, expected)
        objects: dict[int, tuple[str, ...] | None] = {}
        fits: dict[tuple, bool] = {}
        for j, numeric, ids in init.facts():
            if numeric is None:
                self._check_init_item(init.others[j], env)
                continue
            sig = heads.get((numeric, ids[0]), False)
            if sig is False:
                table = scope.functions if numeric else scope.predicates
                decl = table.get(names[ids[0]].lower())
                sig = None if decl is None or (not numeric and decl.kind is A.Kind.GEOMETRIC) \
                    else (len(decl.params), tuple(type_keys(q.type) for q in decl.params))
                heads[(numeric, ids[0])] = sig
            ok = sig is not None and sig[0] == len(ids) - 1
            if ok:
                for a, expected in zip(ids[1:], sig[1]):
                    actual = objects.get(a, False)
                    if actual is False:
                        info = scope.objects.get(names[a].lower())
                        actual = objects[a] = info.types if info is not None else None
                    if actual is None:
                        ok = False
                        break
                    fit = fits.get((actual, expected))
                    if fit is None:
                        fit = fits[(actual, expected)] = scope.compatible(actual, expected)
                    if not fit:
                        ok = False
                        break
            if not ok:
                self._check_init_item(init[j], env)

    def check_problem(self, p: A.Problem) -> None:
        self.check_requirements(p.requirements)
        if p.domain_name is not None and p.domain_name.key != self.domain.name.key:
            self.sink.add(error("E209", f"problem `{p.name.text}` is for domain "
                                f"`{p.domain_name.text}`, but the domain is "
                                f"`{self.domain.name.text}`", p.domain_name.span,
                                related=[Related(self.domain.name.span, "the domain")]))
        env: dict = {}
        if isinstance(p.init, InitFacts):
            self._check_packed_init(p.init, env)
        else:
            for item in p.init:
                self._check_init_item(item, env)
        if p.goal is not None:
            self.check_formula(p.goal, env, set(), "goal")
        if p.metric is not None:
            self.check_num(p.metric.expr, env, set())


def _key(text: str) -> str:
    """A name's key (lower case), the name's own string when it is lower case already."""
    key = text.lower()
    return text if key == text else key


def _types(keys: tuple[str, ...]) -> str:
    return f"`{keys[0]}`" if len(keys) == 1 else "`(either " + " ".join(keys) + ")`"


def _did_you_mean(word: str, table) -> str | None:
    return suggest(word, table)
