"""The validator's symbolic half: a small STRIPS/ADL simulator over the *lifted* AST of the
checked program, independent of :mod:`tmpc.compiler.ground.problem` (no grounding, no bitsets, no
normalization: formulas are evaluated as written, under a substitution).

A :class:`Facts` is the set of true atoms ``(predicate key, argument keys)`` of the fluent and
static predicates plus numeric fluent values. Derived predicates are computed per state by
stratified fixpoint iteration over their rules; geometric atoms are decided by a callback
``geo(decl, args) -> (truth, distance)`` at the state's configuration.

Supported: ``and or not imply exists forall = when``, numeric comparisons over fluents,
``forall``/``when`` effects (conditions read in the state before the action; an atom both added
and deleted ends true), numeric effects (``increase``, ``decrease``, ``assign``, ``scale-up``,
``scale-down``).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from typing import Callable

from tmpc.lang import ast as A
from tmpc.lang.scope import type_keys

Atom = tuple[str, tuple[str, ...]]
GeoFn = Callable[[A.PredicateDecl, tuple[str, ...]], tuple[bool, float]]


@dataclass(frozen=True)
class Facts:
    atoms: frozenset
    numbers: tuple = ()       # sorted ((function key, args), value)

    def number(self, key) -> float | None:
        return dict(self.numbers).get(key)


class Logic:
    """The domain and problem of a checked program, for simulation."""

    def __init__(self, program, settled=()):
        """``settled``: :class:`~tmpc.runtime.start_atoms.Settled` replacements of `:init`
        atoms (the scene's placements where the file's are false in it)."""
        self.program = program
        self.settled = {s.old: s.new for s in settled}
        self.scope = sc = program.scope
        self.domain, self.problem = program.domain, program.problem
        self.objects = {k: info for k, info in sc.objects.items()}
        self.fluent = set()
        for act in sc.actions.values():
            self._effect_preds(act.effect, self.fluent)
        self.derived = {k: rules for k, rules in sc.derived.items()}
        self.geometric = {k for k, d in sc.predicates.items() if d.kind == A.Kind.GEOMETRIC}
        self._strata = self._stratify()

    # ---- names -------------------------------------------------------------------------------
    def name(self, key: str) -> str:
        info = self.objects.get(key)
        return info.name.text if info is not None else key

    def pred_name(self, key: str) -> str:
        d = self.scope.predicates.get(key)
        return d.name.text if d is not None else key

    def atom_text(self, atom: Atom) -> str:
        return "(" + " ".join([self.pred_name(atom[0])] + [self.name(a) for a in atom[1]]) + ")"

    def is_state_atom(self, key: str) -> bool:
        """Atoms a plan's mode lists: fluent discrete/kinematic predicates."""
        return key in self.fluent and key not in self.derived and key not in self.geometric

    def kinematic(self, atom: Atom) -> tuple[str, str] | None:
        """(parent, child) object keys of a kinematic atom, else None."""
        d = self.scope.predicates.get(atom[0])
        if d is None or d.kinematic is None:
            return None
        names = [p.name.key for p in d.params]
        spec = d.kinematic
        try:
            return atom[1][names.index(spec.parent.key)], atom[1][names.index(spec.child.key)]
        except (ValueError, IndexError):
            return None

    # ---- initial state and goal ----------------------------------------------------------
    def initial(self) -> Facts:
        atoms, numbers = set(), {}
        for item in self.problem.init if self.problem is not None else ():
            if isinstance(item, A.Atom):
                atom = (item.pred.key, tuple(t.name.key for t in item.args))
                atoms.add(self.settled.get(atom, atom))
            elif isinstance(item, A.NumericInit):
                key = (item.target.name.key, tuple(t.name.key for t in item.target.args))
                numbers[key] = item.value.value
        return Facts(frozenset(atoms), tuple(sorted(numbers.items())))

    def goal(self) -> A.Formula | None:
        return self.problem.goal if self.problem is not None else None

    # ---- actions -------------------------------------------------------------------------------
    def bind(self, name: str, args: tuple[str, ...]) -> tuple[A.Action, dict] | str:
        """The schema and substitution of a ground action, or why it is not one."""
        act = self.scope.actions.get(name.lower())
        if act is None:
            known = ", ".join(sorted(a.name.text for a in self.scope.actions.values()))
            return f"unknown action `{name}` (the domain has: {known})"
        if len(args) != len(act.params):
            return (f"`{act.name.text}` takes {len(act.params)} argument(s), the plan gives "
                    f"{len(args)}")
        env = {}
        for p, a in zip(act.params, args):
            info = self.objects.get(a.lower())
            if info is None:
                return f"unknown object `{a}`"
            want = type_keys(p.type)
            if not self.scope.compatible(info.types, want):
                return (f"`{a}` is {'/'.join(info.types)}, but parameter {p.name.text} of "
                        f"`{act.name.text}` is {'/'.join(want)}")
            env[p.name.key] = a.lower()
        return act, env

    def apply(self, act: A.Action, env: dict, facts: Facts, geo: GeoFn) -> Facts:
        """The successor facts: conditions of `when` read in ``facts``; deletes, then adds."""
        adds, dels, num = set(), set(), dict(facts.numbers)
        full = self.closure(facts, geo)
        self._effects(act.effect, env, full, geo, adds, dels, num, facts)
        return Facts(frozenset((facts.atoms - dels) | adds), tuple(sorted(num.items())))

    def _effects(self, e, env, full, geo, adds, dels, num, before) -> None:
        if e is None:
            return
        if isinstance(e, A.AndEffect):
            for p in e.parts:
                self._effects(p, env, full, geo, adds, dels, num, before)
        elif isinstance(e, A.AddEffect):
            adds.add(self.ground_atom(e.atom, env))
        elif isinstance(e, A.DelEffect):
            dels.add(self.ground_atom(e.atom, env))
        elif isinstance(e, A.ForallEffect):
            for b in self.bindings(e.params):
                self._effects(e.body, {**env, **b}, full, geo, adds, dels, num, before)
        elif isinstance(e, A.WhenEffect):
            if self.holds(e.condition, env, full, geo):
                self._effects(e.body, env, full, geo, adds, dels, num, before)
        elif isinstance(e, A.NumericEffect):
            key = (e.target.name.key, tuple(self.term(t, env) for t in e.target.args))
            v = self.number(e.value, env, before)
            old = num.get(key, 0.0)
            if v is not None:
                num[key] = {"increase": old + v, "decrease": old - v, "assign": v,
                            "scale-up": old * v, "scale-down": old / v if v else old}.get(e.op, v)

    # ---- formulas ---------------------------------------------------------------------------
    def term(self, t, env) -> str:
        return env[t.name.key] if isinstance(t, A.Var) else t.name.key

    def ground_atom(self, at: A.Atom, env) -> Atom:
        return at.pred.key, tuple(self.term(t, env) for t in at.args)

    def holds(self, f, env: dict, facts: Facts, geo: GeoFn) -> bool:
        """Truth of a formula; ``facts`` must include derived atoms (:meth:`closure`)."""
        if f is None:
            return True
        if isinstance(f, A.Atom):
            key, args = self.ground_atom(f, env)
            if key in self.geometric:
                return geo(self.scope.predicates[key], args)[0]
            return (key, args) in facts.atoms
        if isinstance(f, A.And):
            return all(self.holds(p, env, facts, geo) for p in f.parts)
        if isinstance(f, A.Or):
            return any(self.holds(p, env, facts, geo) for p in f.parts)
        if isinstance(f, A.Not):
            return not self.holds(f.part, env, facts, geo)
        if isinstance(f, A.Imply):
            return (not self.holds(f.left, env, facts, geo)) or self.holds(f.right, env, facts,
                                                                           geo)
        if isinstance(f, A.Equals):
            return self.term(f.left, env) == self.term(f.right, env)
        if isinstance(f, A.Quantified):
            results = (self.holds(f.body, {**env, **b}, facts, geo) for b in
                       self.bindings(f.params))
            return all(results) if f.kind == "forall" else any(results)
        if isinstance(f, A.Compare):
            a, b = self.number(f.left, env, facts), self.number(f.right, env, facts)
            if a is None or b is None:
                return False
            return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "=": a == b}[f.op]
        raise TypeError(f"unsupported formula {type(f).__name__}")

    def number(self, e, env, facts: Facts) -> float | None:
        if isinstance(e, A.Num):
            return e.value
        if isinstance(e, A.FuncTerm):
            return facts.number((e.name.key, tuple(self.term(t, env) for t in e.args)))
        vals = [self.number(a, env, facts) for a in e.args]
        if any(v is None for v in vals):
            return None
        if e.op == "-" and len(vals) == 1:
            return -vals[0]
        out = vals[0]
        for v in vals[1:]:
            if e.op == "/" and v == 0:
                return None
            out = {"+": out + v, "-": out - v, "*": out * v, "/": out / v if v else 0}[e.op]
        return out

    def failures(self, f, env: dict, facts: Facts, geo: GeoFn) -> list[str]:
        """The false parts of a formula, as text: conjunctions are split into their conjuncts;
        a false geometric atom carries its distance."""
        if f is None or self.holds(f, env, facts, geo):
            return []
        if isinstance(f, A.And):
            return [x for p in f.parts for x in self.failures(p, env, facts, geo)]
        if isinstance(f, A.Atom):
            key, args = self.ground_atom(f, env)
            text = self.atom_text((key, args))
            if key in self.geometric:
                return [f"{text} false: distance {geo(self.scope.predicates[key], args)[1]:.3g}"]
            return [f"{text} false"]
        if isinstance(f, A.Not) and isinstance(f.part, A.Atom):
            return [f"(not {self.atom_text(self.ground_atom(f.part, env))}) false"]
        return [f"{self.show(f, env)} false"]

    def show(self, f, env) -> str:
        if isinstance(f, A.Atom):
            return self.atom_text(self.ground_atom(f, env))
        if isinstance(f, (A.And, A.Or)):
            op = "and" if isinstance(f, A.And) else "or"
            return f"({op} " + " ".join(self.show(p, env) for p in f.parts) + ")"
        if isinstance(f, A.Not):
            return f"(not {self.show(f.part, env)})"
        if isinstance(f, A.Imply):
            return f"(imply {self.show(f.left, env)} {self.show(f.right, env)})"
        if isinstance(f, A.Equals):
            return f"(= {self.name(self.term(f.left, env))} {self.name(self.term(f.right, env))})"
        if isinstance(f, A.Quantified):
            params = " ".join(p.name.text for p in f.params)
            return f"({f.kind} ({params}) ...)"
        return "(...)"

    def bindings(self, params):
        domains = []
        for p in params:
            want = type_keys(p.type)
            domains.append([k for k, info in self.objects.items()
                            if self.scope.compatible(info.types, want)])
        for combo in product(*domains):
            yield {p.name.key: o for p, o in zip(params, combo)}

    # ---- derived predicates ---------------------------------------------------------------
    def closure(self, facts: Facts, geo: GeoFn) -> Facts:
        """``facts`` plus every derived atom (stratified least fixpoint)."""
        if not self.derived:
            return facts
        atoms = {a for a in facts.atoms if a[0] not in self.derived}
        for stratum in self._strata:
            while True:
                cur = Facts(frozenset(atoms), facts.numbers)
                new = set()
                for key in stratum:
                    for rule in self.derived[key]:
                        for b in self.bindings(rule.params):
                            head = (key, tuple(b[p.name.key] for p in rule.params))
                            if head not in atoms and self.holds(rule.body, b, cur, geo):
                                new.add(head)
                if not new:
                    break
                atoms |= new
        return Facts(frozenset(atoms), facts.numbers)

    def _stratify(self) -> list[list[str]]:
        deps: dict[str, list[tuple[str, bool]]] = {}
        for key, rules in self.derived.items():
            out: list[tuple[str, bool]] = []
            for r in rules:
                _preds(r.body, False, out)
            deps[key] = [(k, neg) for k, neg in out if k in self.derived]
        level = {k: 0 for k in self.derived}
        for _ in range(len(level) + 1):
            changed = False
            for k, ds in deps.items():
                for d, neg in ds:
                    want = level[d] + (1 if neg else 0)
                    if want > level[k]:
                        level[k], changed = min(want, len(level)), True
            if not changed:
                break
        strata: dict[int, list[str]] = {}
        for k, v in level.items():
            strata.setdefault(v, []).append(k)
        return [strata[v] for v in sorted(strata)]

    @staticmethod
    def _effect_preds(e, out: set) -> None:
        if e is None:
            return
        if isinstance(e, A.AndEffect):
            for p in e.parts:
                Logic._effect_preds(p, out)
        elif isinstance(e, (A.AddEffect, A.DelEffect)):
            out.add(e.atom.pred.key)
        elif isinstance(e, (A.ForallEffect, A.WhenEffect)):
            Logic._effect_preds(e.body, out)


def _preds(f, neg: bool, out: list) -> None:
    """Predicates a formula mentions, with whether under a negation."""
    if isinstance(f, A.Atom):
        out.append((f.pred.key, neg))
    elif isinstance(f, (A.And, A.Or)):
        for p in f.parts:
            _preds(p, neg, out)
    elif isinstance(f, A.Not):
        _preds(f.part, not neg, out)
    elif isinstance(f, A.Imply):
        _preds(f.left, not neg, out)
        _preds(f.right, neg, out)
    elif isinstance(f, A.Quantified):
        _preds(f.body, neg, out)
