"""A naive reference for grounding tests: PDDL semantics evaluated directly on the AST.

No pruning, no normalization: every type-correct binding of every action is an action, a state is
a set of ``(predicate key, object keys)`` facts (static ones included), formulas and effects are
interpreted recursively, derived predicates are recomputed by a naive stratified fixpoint.
Geometric literals count as satisfied (either polarity), as in the grounder's discrete view.
It is slow and obviously correct; tests compare :mod:`tmpc.compiler.ground.problem` against it.
"""

from __future__ import annotations

import itertools
from collections import deque

from tmpc.lang import ast as A
from tmpc.lang.scope import type_keys

Fact = tuple[str, tuple[str, ...]]


class Reference:
    def __init__(self, prog):
        self.prog, self.sc = prog, prog.scope
        th = self.sc.types
        self.types = {k: set().union(*(th.ancestors(t) for t in o.types))
                      for k, o in self.sc.objects.items()}
        self.geo = {k for k, d in self.sc.predicates.items() if d.kind is A.Kind.GEOMETRIC}
        self.numeric = {(i.target.name.key, tuple(t.name.key for t in i.target.args)):
                        i.value.value for i in prog.problem.init if isinstance(i, A.NumericInit)}
        self.levels = self._levels()

    # ---- objects and bindings ------------------------------------------------------------------
    def objects_of(self, typed: A.Typed) -> list[str]:
        want = set(type_keys(typed.type))
        return [k for k, ts in self.types.items() if ts & want]

    def envs(self, params, env=None):
        env = env or {}
        for combo in itertools.product(*(self.objects_of(p) for p in params)):
            inner = dict(env)
            inner.update({p.name.key: o for p, o in zip(params, combo)})
            yield inner

    def actions(self):
        """Every type-correct ground action: (action decl, env, name tuple)."""
        for act in self.prog.domain.actions:
            for env in self.envs(act.params):
                yield act, env, (act.name.key, tuple(env[p.name.key] for p in act.params))

    # ---- formulas ------------------------------------------------------------------------------
    def term(self, t, env) -> str:
        return env[t.name.key] if isinstance(t, A.Var) else t.name.key

    def num(self, e, env):
        if isinstance(e, A.Num):
            return e.value
        if isinstance(e, A.FuncTerm):
            return self.numeric.get((e.name.key, tuple(self.term(t, env) for t in e.args)))
        vals = [self.num(a, env) for a in e.args]
        if len(vals) == 1 and e.op == "-":
            return -vals[0]
        out = vals[0]
        for v in vals[1:]:
            out = {"+": out + v, "-": out - v, "*": out * v, "/": out / v if v else None}[e.op]
        return out

    def holds(self, f, env, state, pos: bool = True) -> bool:
        """Truth of ``f`` (``pos``) or of its negation (not ``pos``)."""
        if f is None:
            return pos
        if isinstance(f, A.Atom):
            if f.pred.key in self.geo:
                return True
            return ((f.pred.key, tuple(self.term(t, env) for t in f.args)) in state) == pos
        if isinstance(f, A.Equals):
            return (self.term(f.left, env) == self.term(f.right, env)) == pos
        if isinstance(f, A.Compare):
            a, b = self.num(f.left, env), self.num(f.right, env)
            if a is None or b is None:
                return False        # an undefined fluent: false either way (as the grounder)
            ok = {
                "<": a < b, "<=": a <= b, "=": a == b, ">=": a >= b, ">": a > b}[f.op]
            return ok == pos
        if isinstance(f, A.Not):
            return self.holds(f.part, env, state, not pos)
        if isinstance(f, (A.And, A.Or)):
            vals = (self.holds(p, env, state, pos) for p in f.parts)
            return all(vals) if isinstance(f, A.And) == pos else any(vals)
        if isinstance(f, A.Imply):
            if pos:
                return self.holds(f.left, env, state, False) or self.holds(f.right, env, state)
            return self.holds(f.left, env, state) and self.holds(f.right, env, state, False)
        if isinstance(f, A.Quantified):
            vals = (self.holds(f.body, e, state, pos) for e in self.envs(f.params, env))
            return all(vals) if (f.kind == "forall") == pos else any(vals)
        raise TypeError(f)

    # ---- effects and states --------------------------------------------------------------------
    def effects(self, e, env, state, adds, dels) -> None:
        if e is None:
            return
        if isinstance(e, A.AndEffect):
            for p in e.parts:
                self.effects(p, env, state, adds, dels)
        elif isinstance(e, (A.AddEffect, A.DelEffect)):
            if e.atom.pred.key not in self.geo:
                fact = (e.atom.pred.key, tuple(self.term(t, env) for t in e.atom.args))
                (adds if isinstance(e, A.AddEffect) else dels).add(fact)
        elif isinstance(e, A.ForallEffect):
            for inner in self.envs(e.params, env):
                self.effects(e.body, inner, state, adds, dels)
        elif isinstance(e, A.WhenEffect):
            if self.holds(e.condition, env, state):
                self.effects(e.body, env, state, adds, dels)

    def apply(self, act, env, state: frozenset) -> frozenset:
        adds, dels = set(), set()
        self.effects(act.effect, env, state, adds, dels)
        return self.derive((state - dels) | adds)

    def initial(self) -> frozenset:
        facts = set()
        for i in self.prog.problem.init:
            if isinstance(i, A.Atom):
                args = tuple(t.name.key for t in i.args)
                if all(a in self.sc.objects for a in args) and i.pred.key not in self.sc.derived:
                    facts.add((i.pred.key, args))
        return self.derive(frozenset(facts))

    def _levels(self) -> list[list[str]]:
        level = {p: 0 for p in self.sc.derived}
        for _ in range(len(level) + 1):
            for p, rules in self.sc.derived.items():
                for r in rules:
                    for q, neg in _preds(r.body, False):
                        if q in level:
                            level[p] = max(level[p], level[q] + (1 if neg else 0))
        return [[p for p in level if level[p] == k] for k in sorted(set(level.values()))]

    def derive(self, state: frozenset) -> frozenset:
        facts = {f for f in state if f[0] not in self.sc.derived}
        for preds in self.levels:
            changed = True
            while changed:
                changed = False
                for p in preds:
                    for r in self.sc.derived[p]:
                        for env in self.envs(r.params):
                            head = (p, tuple(env[x.name.key] for x in r.params))
                            if head not in facts and self.holds(r.body, env, facts):
                                facts.add(head)
                                changed = True
        return frozenset(facts)

    def goal(self, state) -> bool:
        return self.holds(self.prog.problem.goal, {}, state)

    def replay(self, plan: list[tuple[str, tuple[str, ...]]]) -> bool:
        """Does the plan (action key, object keys) apply step by step and reach the goal?"""
        acts = {a.name.key: a for a in self.prog.domain.actions}
        state = self.initial()
        for name, args in plan:
            act = acts[name]
            env = dict(zip((p.name.key for p in act.params), args))
            if not self.holds(act.precondition, env, state):
                return False
            state = self.apply(act, env, state)
        return self.goal(state)

    def bfs(self, max_states: int = 5000):
        """Breadth-first search over all type-correct actions, on past the goal until the state
        space (or ``max_states``) is exhausted. Returns (a shortest plan or None, every ground
        action applicable in some explored state, explored states)."""
        ground = list(self.actions())
        start = self.initial()
        parent = {start: None}
        used: set = set()
        queue = deque([start])
        plan = None
        while queue and len(parent) <= max_states:
            s = queue.popleft()
            if plan is None and self.goal(s):
                plan = _path(parent, s)
            for act, env, name in ground:
                if self.holds(act.precondition, env, s):
                    used.add(name)
                    t = self.apply(act, env, s)
                    if t not in parent:
                        parent[t] = (s, name)
                        queue.append(t)
        return plan, used, parent


def _preds(f, neg):
    if isinstance(f, A.Atom):
        yield f.pred.key, neg
    elif isinstance(f, A.Not):
        yield from _preds(f.part, not neg)
    elif isinstance(f, (A.And, A.Or)):
        for p in f.parts:
            yield from _preds(p, neg)
    elif isinstance(f, A.Imply):
        yield from _preds(f.left, not neg)
        yield from _preds(f.right, neg)
    elif isinstance(f, A.Quantified):
        yield from _preds(f.body, neg)


def _path(parent, s):
    out = []
    while parent[s] is not None:
        s, name = parent[s]
        out.append(name)
    return out[::-1]
