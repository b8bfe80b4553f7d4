"""The grounding engine behind :func:`tmpc.compiler.ground.ground`.

Four passes:

1. **Lift** every action, derived rule and the goal to normal form
   (:mod:`tmpc.compiler.ground.lift`) and classify predicates: *geometric* (decided by geometry),
   *derived*, *fluent* (in some effect) and *static* (the rest: evaluated here from ``:init``).
2. **Count** each schema's bindings (:mod:`tmpc.compiler.ground.bind`; E600 past the limit).
3. **Explore** (rounds until no new atom is reached): enumerate each schema's bindings whose
   top-level positive literals hold in the static facts plus the atoms reached so far (a join,
   :class:`tmpc.compiler.ground.bind.Join`), instantiate the new ones — static atoms, ``=`` and
   numeric comparisons become constants as the formula is built; fluent atoms get provisional ids —
   and feed them to the delete-relaxed exploration (:mod:`tmpc.compiler.ground.reach`) as units: the
   action, each conditional effect (with the action's precondition), each axiom.
4. **Finalize**: keep reached atoms plus goal atoms, renumber them (predicate order, then object
   order), simplify every formula with "never reached = false", and build the result.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from tmpc.compiler.ground.bind import FactIndex, Join, anchors, checks, count, count_joined, narrow
from tmpc.compiler.ground.derived import Axiom, DerivedEvaluator, stratify
from tmpc.compiler.ground.formula import (
    FALSE,
    TRUE,
    Condition,
    GAtom,
    GFormula,
    GGeo,
    GNot,
    atom_ids,
    conj,
    disj,
    geo_atoms,
    relaxed_holds,
    remap,
)
from tmpc.compiler.ground.lift import (
    ExpansionTooLarge,
    LAnd,
    LCmp,
    LConst,
    LEq,
    LFormula,
    Lifter,
    LLit,
    LNumEffect,
    LOr,
    literals,
    type_keys,
)
from tmpc.compiler.ground.problem import (
    ConditionalEffect,
    GroundAction,
    GroundAtom,
    GroundObject,
    GroundProblem,
    GroundStats,
    KinematicEffect,
    grounding_error,
)
from tmpc.compiler.ground.reach import Relaxed
from tmpc.compiler.ground.symbols import shown_as
from tmpc.lang import ast as A
from tmpc.lang.checker import CheckedProgram

COST = "total-cost"
_CMP = {"<": float.__lt__, "<=": float.__le__, "=": float.__eq__, ">=": float.__ge__,
        ">": float.__gt__}


@dataclass
class _Schema:
    """An action or derived rule, lifted: precondition (rule body), flattened effects, cost
    effects; ``head`` is the derived predicate of a rule (None for actions). ``order`` ranks it;
    the binding domains, tests and join anchors are filled in before exploring, the
    :class:`~tmpc.compiler.ground.bind.Join` at its first round."""

    decl: A.Action | A.Derived
    pre: LFormula
    effects: list = field(default_factory=list)
    costs: list[LNumEffect] = field(default_factory=list)
    head: str | None = None
    order: int = 0
    doms: list = field(default_factory=list)
    tests: list = field(default_factory=list)
    joins: list = field(default_factory=list)
    seen: set = field(default_factory=set)
    join: object = None


@dataclass
class _Candidate:
    schema: _Schema
    binding: tuple[str, ...]
    pre: GFormula
    adds: list[int]
    dels: list[int]
    cond: list[tuple[GFormula, list[int], list[int]]]
    unit: int = -1


class _Builder:
    def __init__(self, prog: CheckedProgram, limit: int):
        if prog.problem is None:
            raise grounding_error("E605", f"domain `{prog.domain.name.text}` has no problem to "
                                  "ground", prog.domain.name.span,
                                  "pass a problem file with the domain")
        self.prog, self.sc, self.limit = prog, prog.scope, limit
        self.objects = self._objects()
        self.otext = {o.key: o.name for o in self.objects}
        self.obj_pos = {o.key: i for i, o in enumerate(self.objects)}
        self._by_type: dict[tuple[str, ...], list[str]] = {}
        self.lifter = Lifter(self.objects_of, limit)
        self.ptext = {k: d.name.text for k, d in self.sc.predicates.items()}
        self.ids: dict[tuple[str, tuple[str, ...]], int] = {}
        self.keys: list[tuple[str, tuple[str, ...]]] = []
        self.considered = 0

    # ---- objects and predicates -------------------------------------------------------------
    def _objects(self) -> list[GroundObject]:
        th = self.sc.types
        out = []
        for info in self.sc.objects.values():
            types = set()
            for t in info.types:
                types |= th.ancestors(t)
            out.append(GroundObject(info.name.text, frozenset(types), info.constant))
        return out

    def objects_of(self, types: tuple[str, ...]) -> list[str]:
        if types not in self._by_type:
            want = set(types)
            self._by_type[types] = [o.key for o in self.objects if o.types & want]
        return self._by_type[types]

    def classify(self, schemas: list[_Schema]) -> None:
        changed = {e.pred for s in schemas for e in s.effects}
        self.kinds: dict[str, str] = {}
        for key, decl in self.sc.predicates.items():
            if decl.kind is A.Kind.GEOMETRIC:
                self.kinds[key] = "geo"
            elif key in self.sc.derived:
                self.kinds[key] = "derived"
            else:
                self.kinds[key] = "fluent" if key in changed else "static"

    def intern(self, key: tuple[str, tuple[str, ...]]) -> int:
        i = self.ids.get(key)
        if i is None:
            i = self.ids[key] = len(self.keys)
            self.keys.append(key)
        return i

    # ---- lifting ----------------------------------------------------------------------------
    def lift(self, f, env, what: str, span) -> LFormula:
        try:
            return self.lifter.formula(f, env)
        except ExpansionTooLarge as exc:
            raise grounding_error("E601", f"expanding the quantifiers of {what} gives a formula "
                                  f"of more than {self.limit:,} nodes", exc.where,
                                  "quantify over narrower types") from None

    def lift_schema(self, act: A.Action) -> _Schema:
        env = {p.name.key: i for i, p in enumerate(act.params)}
        what = f"action `{act.name.text}`"
        pre = self.lift(act.precondition, env, what, act.span)
        try:
            effects, nums = self.lifter.effect(act.effect, env)
        except ExpansionTooLarge as exc:
            raise grounding_error("E601", f"expanding the `forall` effects of {what} gives more "
                                  f"than {self.limit:,} effects", exc.where) from None
        for n in nums:
            if n.target != ("f", COST, ()) or n.op != "increase":
                raise grounding_error("E602", f"numeric effect `{n.op}` on `{n.target[1]}` in "
                                      f"{what}: only `(increase (total-cost) ...)` is supported",
                                      n.span, "tmpc plans with action costs, not numeric state")
            if n.condition != LConst(True):
                raise grounding_error("E602", f"a conditional action cost in {what} is not "
                                      "supported", n.span, "give the action one fixed cost")
        return _Schema(act, pre, effects, nums)

    def check_comparisons(self, f: LFormula, what: str, span) -> None:
        for lit in literals(f):
            if isinstance(lit, LCmp) and _mentions(lit, COST):
                raise grounding_error("E602", f"{what} compares `total-cost`: conditions on "
                                      "numeric state are not supported", span)

    # ---- instantiation ----------------------------------------------------------------------
    def inst(self, f: LFormula, b) -> GFormula:
        t = type(f)
        if t is LLit:
            return self.literal(f, b)
        if t is LAnd:
            return conj(self.inst(p, b) for p in f.parts)
        if t is LOr:
            return disj(self.inst(p, b) for p in f.parts)
        if t is LEq:
            left = b[f.left] if type(f.left) is int else f.left
            right = b[f.right] if type(f.right) is int else f.right
            return TRUE if (left == right) == f.positive else FALSE
        if t is LCmp:
            return self.compare(f, b)
        return TRUE if f.value else FALSE

    def literal(self, f: LLit, b) -> GFormula:
        args = tuple(b[a] if type(a) is int else a for a in f.args)
        kind = self.kinds.get(f.pred, "static")
        if kind == "static":
            return TRUE if ((f.pred, args) in self.static_facts) == f.positive else FALSE
        if kind == "geo":
            leaf = GGeo(self.ptext[f.pred], tuple(self.otext[a] for a in args))
        else:
            leaf = GAtom(self.intern((f.pred, args)))
        return leaf if f.positive else GNot(leaf)

    def number(self, e: tuple, b) -> float | None:
        if e[0] == "n":
            return float(e[1])
        if e[0] == "f":
            return self.numeric.get((e[1], tuple(b[a] if type(a) is int else a for a in e[2])))
        vals = [self.number(p, b) for p in e[2]]
        if any(v is None for v in vals):
            return None
        return _arith(e[1], vals)

    def compare(self, f: LCmp, b) -> GFormula:
        left, right = self.number(f.left, b), self.number(f.right, b)
        if left is None or right is None:
            return FALSE        # an undefined fluent makes the comparison false (PDDL 2.1)
        return TRUE if _CMP[f.op](left, right) == f.positive else FALSE

    def prepare(self, s: _Schema) -> None:
        """Binding domains (counted: E600), tests and join anchors of ``s``."""
        params = s.decl.params
        what = (f"derived predicate `{s.decl.name.text}`" if s.head else
                f"action `{s.decl.name.text}`")
        doms = narrow([self.objects_of(type_keys(p)) for p in params], s.pre, self.index,
                      self.statics)
        product = count(doms)
        total, exact = (product, True) if product <= self.limit else \
            count_joined(doms, s.pre, self.index, self.statics, self.limit)
        if total > self.limit:
            sizes = ", ".join(f"{p.name.text}: {len(d)} ({_type_text(p)})"
                              for p, d in zip(params, doms))
            many = f"{total:,}" if exact else f"more than {self.limit:,}"
            joined = "" if total == product else \
                f" after joining its static preconditions ({product:,} before)"
            raise grounding_error(
                "E600", f"{what} has {many} parameter bindings{joined}, over the grounding limit "
                f"of {self.limit:,} (objects per parameter: {sizes})", s.decl.span,
                "narrow the parameter types, add static preconditions (facts no action changes) "
                "on the parameters, or raise the limit (max_bindings)")
        indexed = {k for k, v in self.kinds.items() if v != "geo"}
        s.doms = doms
        s.tests = checks(s.pre, self.index, self.statics, indexed)
        s.joins = anchors(s.pre, indexed)

    def explore(self, schemas: list[_Schema], init: list[int]):
        """Rounds of join-enumeration and relaxed exploration until no new atom is reached.
        Returns (action candidates, ground rules (predicate, head, body))."""
        self.relax = Relaxed(self.keys, lambda i: self.index.add(self.keys[i]))
        for i in init:
            self.relax.reach(i)
        self.relax.propagate()
        cands: list[_Candidate] = []
        rules: list[tuple[str, int, GFormula]] = []
        while True:
            before = self.relax.count
            for s in schemas:
                self.ground_new(s, cands, rules)
                self.relax.propagate()
            if self.relax.count == before:
                return cands, rules

    def ground_new(self, s: _Schema, cands: list, rules: list) -> None:
        # the join yields in its own order; new bindings are handled in parameter-by-parameter
        # object order (every domain lists objects in declaration order)
        if s.join is None:      # made once the initial state is in the index
            s.join = Join(s.doms, s.tests, s.joins, self.index)
        new = [b for b in s.join.run() if b not in s.seen]
        pos = self.obj_pos
        new.sort(key=lambda b: tuple(pos[o] for o in b))
        for b in new:
            s.seen.add(b)
            self.considered += 1
            pre = self.inst(s.pre, b)
            if pre is FALSE:
                continue
            if s.head is not None:
                head = self.intern((s.head, b))
                rules.append((s.head, head, pre))
                self.relax.add(pre, [head])
                continue
            c = self.effects(s, b, pre)
            c.unit = self.relax.add(pre, c.adds)
            for cond, adds, _ in c.cond:
                if adds:
                    self.relax.add(conj([pre, cond]), adds)
            cands.append(c)

    def effects(self, s: _Schema, b, pre: GFormula) -> _Candidate:
        groups: dict[GFormula, tuple[list[int], list[int]]] = {}
        conds: dict[int, GFormula] = {}
        for e in s.effects:
            if self.kinds.get(e.pred) == "geo":
                continue        # legacy: geometric atoms in effects are ignored (W004)
            key = id(e.condition)
            if key not in conds:
                conds[key] = self.inst(e.condition, b)
            cond = conds[key]
            if cond is FALSE:
                continue
            atom = self.intern((e.pred, tuple(b[a] if type(a) is int else a for a in e.args)))
            adds, dels = groups.setdefault(cond, ([], []))
            (adds if e.positive else dels).append(atom)
        adds, dels = groups.pop(TRUE, ([], []))
        return _Candidate(s, b, pre, adds, dels, [(c, a, d) for c, (a, d) in groups.items()])

    def rule_schemas(self) -> list[_Schema]:
        out = []
        for key, rules in self.sc.derived.items():
            for rule in rules:
                env = {p.name.key: i for i, p in enumerate(rule.params)}
                what = f"derived predicate `{rule.name.text}`"
                body = self.lift(rule.body, env, what, rule.span)
                self.check_comparisons(body, what, rule.span)
                out.append(_Schema(rule, body, head=key))
        return out

    # ---- problem ----------------------------------------------------------------------------
    def read_init(self) -> list[int]:
        facts, fluent = set(), []
        self.numeric: dict[tuple[str, tuple[str, ...]], float] = {}
        for item in self.prog.problem.init:
            if isinstance(item, A.NumericInit):
                key = (item.target.name.key, tuple(t.name.key for t in item.target.args))
                self.numeric[key] = float(item.value.value)
            elif isinstance(item, A.Atom):
                args = tuple(t.name.key for t in item.args)
                if any(a not in self.sc.objects for a in args):
                    continue    # legacy fact naming an undeclared object (W015): dropped
                kind = self.kinds.get(item.pred.key)
                if kind == "static":
                    facts.add((item.pred.key, args))
                elif kind == "fluent":
                    fluent.append(self.intern((item.pred.key, args)))
        self.statics = {k for k, v in self.kinds.items() if v == "static"}
        self.static_facts = frozenset(facts)
        self.index = FactIndex(facts)
        return fluent

    def run(self) -> GroundProblem:
        t0 = time.perf_counter()
        schemas = [self.lift_schema(a) for a in self.prog.domain.actions]
        self.classify(schemas)
        self.uses_costs = any(s.costs for s in schemas)
        init = self.read_init()
        for s in schemas:
            what = f"the precondition of `{s.decl.name.text}`"
            self.check_comparisons(s.pre, what, s.decl.span)
            for e in s.effects:
                self.check_comparisons(e.condition, f"an effect of `{s.decl.name.text}`",
                                       s.decl.span)
        goal_l = self.lift(self.prog.problem.goal, {}, "the goal", self.prog.problem.span)
        self.check_comparisons(goal_l, "the goal", self.prog.problem.span)
        rule_schemas = self.rule_schemas()
        bodies: dict[str, list[LFormula]] = {}
        for r in rule_schemas:
            bodies.setdefault(r.head, []).append(r.pre)
        strata, bad = stratify(bodies)
        if bad is not None:
            span = self.sc.derived[bad][0].span
            raise grounding_error("E604", f"derived predicate `{self.ptext[bad]}` depends on "
                                  "its own negation (the rules cannot be stratified)", span,
                                  "a derived predicate may use another one negatively only if "
                                  "that one does not depend on it")
        for i, s in enumerate(schemas + rule_schemas):
            s.order = i
            self.prepare(s)
        goal = self.inst(goal_l, ())
        cands, rules = self.explore(schemas + rule_schemas, init)
        return self.finish(cands, rules, strata, init, goal, t0)

    # ---- finalize ---------------------------------------------------------------------------
    def finish(self, cands, rules, strata, init, goal, t0) -> GroundProblem:
        self.relax.grow()
        reached, fired = self.relax.reached, self.relax.fired
        keep = {i for i in range(len(self.keys)) if reached[i]} | set(atom_ids(goal))
        pred_order = {k: i for i, k in enumerate(self.sc.predicates)}
        obj_order = {o.key: i for i, o in enumerate(self.objects)}
        order = sorted(keep, key=lambda i: (pred_order[self.keys[i][0]],
                                            tuple(obj_order[a] for a in self.keys[i][1])))
        ids = {old: new for new, old in enumerate(order)}
        atoms = tuple(self.atom(self.keys[i]) for i in order)
        kin = {i: self.kinematic(a, i) for i, a in enumerate(atoms) if a.kind == "kinematic"}
        actions = []
        cands = sorted((c for c in cands if fired[c.unit]),
                       key=lambda c: (c.schema.order, tuple(obj_order[o] for o in c.binding)))
        for c in cands:
            a = self.action(c, ids, reached, kin, len(actions))
            if a is not None:
                actions.append(a)
        axioms = []
        for key, head, body in rules:
            body = remap(body, ids, reached) if reached[head] else FALSE
            if body is not FALSE:
                axioms.append(Axiom(ids[head], body, strata[key]))
        derived = frozenset(i for i, a in enumerate(atoms) if a.kind == "derived")
        evaluator = DerivedEvaluator(tuple(axioms), derived)
        goal_f = remap(goal, ids)
        geometric = _geometric([a.pre.formula for a in actions] +
                               [ce.condition for a in actions for ce in a.conditional] +
                               [ax.body for ax in axioms] + [goal_f])
        index = {(k[0], k[1]): ids[i] for i, k in enumerate(self.keys) if i in ids}
        stats = GroundStats(self.considered, len(self.keys), time.perf_counter() - t0)
        return GroundProblem(
            self.prog.domain.name.text, self.prog.problem.name.text, tuple(self.objects), atoms,
            tuple(actions), tuple(axioms), evaluator(sum(1 << ids[i] for i in set(init))),
            Condition.of(goal_f), self.static_facts, dict(self.numeric), self.uses_costs,
            relaxed_holds(goal, reached), geometric, stats, index, evaluator)

    def atom(self, key: tuple[str, tuple[str, ...]]) -> GroundAtom:
        decl = self.sc.predicates[key[0]]
        kind = "derived" if self.kinds[key[0]] == "derived" else \
            "kinematic" if decl.kinematic is not None else "discrete"
        return GroundAtom(decl.name.text, tuple(self.otext[a] for a in key[1]), kind)

    def kinematic(self, atom: GroundAtom, i: int) -> tuple[str, str]:
        decl = self.sc.predicates[atom.predicate.lower()]
        names = [p.name.key for p in decl.params]
        spec = decl.kinematic
        return (atom.args[names.index(spec.parent.key)], atom.args[names.index(spec.child.key)])

    def action(self, c: _Candidate, ids, reached, kin, index: int) -> GroundAction | None:
        pre = remap(c.pre, ids, reached)
        if pre is FALSE:
            return None
        adds = {ids[p] for p in c.adds}
        dels = {ids[p] for p in c.dels if reached[p]}
        conditional = []
        for cond, ca, cd in c.cond:
            cond = remap(cond, ids, reached)
            ca = {ids[p] for p in ca if reached[p]}
            cd = {ids[p] for p in cd if reached[p]}
            if cond is TRUE:
                adds |= ca
                dels |= cd
            elif cond is not FALSE and (ca or cd):
                conditional.append(_conditional(cond, ca, cd, kin))
        dels -= adds
        cost = sum(self.cost(n, c) for n in c.schema.costs) if self.uses_costs else 1.0
        decl = c.schema.decl
        args = tuple(self.otext[o] for o in c.binding)
        shown = shown_as(decl.name.text, args, self.prog)
        return GroundAction(index, decl.name.text, args,
                            Condition.of(pre), frozenset(adds), frozenset(dels),
                            tuple(conditional), _kinematic(adds, dels, kin), cost,
                            _mask(adds), _mask(dels), decl.span,
                            None if shown == (decl.name.text, args) else shown)

    def cost(self, n: LNumEffect, c: _Candidate) -> float:
        v = self.number(n.value, c.binding)
        if v is None:
            args = " ".join(self.otext[o] for o in c.binding)
            raise grounding_error("E603", f"the cost of `({c.schema.decl.name.text} {args})` "
                                  "uses a numeric fluent with no value in `:init`", n.span,
                                  "give every function the action cost reads a value in `:init`")
        return v


def _conditional(cond, adds, dels, kin) -> ConditionalEffect:
    return ConditionalEffect(cond, frozenset(adds), frozenset(dels), _kinematic(adds, dels, kin),
                             _mask(adds), _mask(dels), Condition.of(cond))


def _kinematic(adds, dels, kin) -> tuple[KinematicEffect, ...]:
    out = [KinematicEffect("unlink", *kin[i], i) for i in sorted(dels) if i in kin]
    out += [KinematicEffect("link", *kin[i], i) for i in sorted(adds) if i in kin]
    return tuple(out)


def _mask(ids) -> int:
    return sum(1 << i for i in ids)


def _geometric(formulas) -> tuple[GGeo, ...]:
    seen: dict[GGeo, None] = {}
    for f in formulas:
        for g in geo_atoms(f):
            seen[g] = None
    return tuple(seen)


def _mentions(lit: LCmp, fkey: str) -> bool:
    def walk(e):
        if e[0] == "f":
            return e[1] == fkey
        return e[0] == "op" and any(walk(p) for p in e[2])
    return walk(lit.left) or walk(lit.right)


def _arith(op: str, vals: list[float]) -> float | None:
    if op == "-" and len(vals) == 1:
        return -vals[0]
    out = vals[0]
    for v in vals[1:]:
        if op == "+":
            out += v
        elif op == "-":
            out -= v
        elif op == "*":
            out *= v
        elif op == "/":
            if v == 0:
                return None
            out /= v
    return out


def _type_text(p: A.Typed) -> str:
    keys = type_keys(p)
    return keys[0] if len(keys) == 1 else "either " + " ".join(keys)


def build(prog: CheckedProgram, limit: int) -> GroundProblem:
    return _Builder(prog, limit).run()
