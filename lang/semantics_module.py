"""A semantics module applied to a classical domain and problem: the planning program they mean.

A semantics module (``(define (semantics NAME) (:domain D) ...)``, docs/language.md "Semantics
modules") gives an unchanged classical PDDL domain a geometric meaning, beside it, in the tmpc
language. :func:`apply_semantics` rewrites the domain and problem trees so the rest of tmpc sees an
ordinary tmpc program; every node it adds keeps the span of what it came from, so diagnostics
point at the semantics module or at the PDDL file. The rules:

- a predicate declared in the module with ``:kinematic (link ?hand ?x)`` becomes kinematic; a
  ``?hand`` parent that is not a parameter is the module's ``(:hand FRAME ...)``: the predicate
  gains a first parameter of type ``tmpc-hand`` and every atom of it gains ``FRAME`` as first
  argument (with several hands: the action's new parameter ``?hand``, so a plan says which hand);
- a predicate given ``:semantics`` that some effect of the domain changes stays a symbol for the
  task planner (the file tracks it) and its meaning becomes a hidden geometric predicate
  ``P~means`` added to the precondition of every action that adds ``P``: the place where it
  becomes true must make it true. One no effect changes becomes geometric (its `:init` atoms are
  then dropped with W021: the scene decides them);
- ``(:action A :precondition F)`` adds ``F`` to ``A``'s precondition (``?hand`` is the frame);
- ``(:action A :carries ?x ...)``: ``A`` moves ``?x`` in one step without a holding predicate (a
  Hanoi ``move``); it is split into ``A~grasp`` (``A``'s precondition and ``F``; the hand takes
  ``?x``) and ``A`` (the release, where ``A``'s effects and their meanings hold);
- the module's own types, constants, helpers and includes join the program as a module.
"""

from __future__ import annotations

from dataclasses import fields, is_dataclass, replace
from typing import Callable

from tmpc.lang import ast as A
from tmpc.lang.diagnostics import Diagnostic, Related, error, warning
from tmpc.lang.reader_common import suggest

#: the type of the module's hand frame, and the variable that names it
HAND_TYPE = "tmpc-hand"
HAND_VAR = "?hand"
#: hidden predicates of carried actions
CARRYING = "tmpc-carrying"
HAND_FREE = "tmpc-hand-free"
MEANS_SUFFIX = "~means"
GRASP_SUFFIX = "~grasp"
PENDING_SUFFIX = "~pending"


def _name(text: str, like: A.Name | None) -> A.Name:
    return A.Name(text, span=like.span if like is not None else None)


def _typed(var: str, type_: str, like: A.Name | None) -> A.Typed:
    return A.Typed(_name(var, like), A.TypeRef((_name(type_, like),), span=like and like.span),
                   span=like and like.span)


def map_tree(node, fn: Callable):
    """``node`` with ``fn`` applied bottom-up to every AST dataclass inside it (tuples too)."""
    if isinstance(node, tuple):
        return tuple(map_tree(x, fn) for x in node)
    if not is_dataclass(node) or isinstance(node, (A.Name, A.Typed, A.TypeRef)):
        return node
    changes = {}
    for f in fields(node):
        if f.name == "span":
            continue
        old = getattr(node, f.name)
        new = map_tree(old, fn)
        if new is not old:
            changes[f.name] = new
    return fn(replace(node, **changes) if changes else node)


def _atoms(effect) -> list[tuple[bool, A.Atom]]:
    """(added?, atom) of an effect's literals, top level and under `and`."""
    if effect is None:
        return []
    if isinstance(effect, A.AndEffect):
        return [x for p in effect.parts for x in _atoms(p)]
    if isinstance(effect, A.AddEffect):
        return [(True, effect.atom)]
    if isinstance(effect, A.DelEffect):
        return [(False, effect.atom)]
    return []


def _flat(kind, *parts):
    """``kind`` (:class:`~tmpc.lang.ast.And` or :class:`~tmpc.lang.ast.AndEffect`) of
    ``parts`` without the Nones, nested ones of that kind spliced in; one part stays itself."""
    flat: list = []
    for p in parts:
        if p is not None:
            flat.extend(p.parts if isinstance(p, kind) else (p,))
    if not flat:
        return None
    return flat[0] if len(flat) == 1 and kind is A.And else kind(tuple(flat), span=flat[0].span)


def _conj(*parts) -> A.Formula | None:
    return _flat(A.And, *parts)


def _effects(*parts) -> A.Effect | None:
    return _flat(A.AndEffect, *parts)


class _Overlay:
    def __init__(self, domain: A.Domain, problem: A.Problem | None, sem: A.Domain):
        self.domain, self.problem, self.sem = domain, problem, sem
        self.diags: list[Diagnostic] = []
        self.hands = sem.hands
        self.hand = sem.hands[0] if sem.hands else None
        #: several hands: ``?hand`` is a parameter of the actions that use it
        self.multi = len(sem.hands) > 1
        #: predicates every atom of which gains the hand as its first argument
        self.with_hand: set[str] = set()
        #: predicate key -> its hidden meaning predicate (``P~means``)
        self.meanings: dict[str, A.PredicateDecl] = {}
        self.decls = {p.name.key: p for p in domain.predicates}
        #: predicates some effect of the domain changes
        self.changed = {at.pred.key for a in domain.actions for _, at in _atoms(a.effect)}

    # ---- predicates ------------------------------------------------------------------------
    def predicates(self) -> list[A.PredicateDecl]:
        out = {p.name.key: p for p in self.domain.predicates}
        for p in self.sem.predicates:
            old = self.decls.get(p.name.key)
            if old is not None and not self._same_signature(old, p):
                continue
            if p.kind is A.Kind.KINEMATIC and p.kinematic is not None:
                out[p.name.key] = self._kinematic(p)
            elif p.kind is A.Kind.GEOMETRIC and old is not None and p.name.key in self.changed:
                means = A.PredicateDecl(_name(p.name.text + MEANS_SUFFIX, p.name), p.params,
                                        A.Kind.GEOMETRIC, p.semantics, None, p.external,
                                        span=p.span)
                self.meanings[p.name.key] = means
                out[means.name.key] = means
            elif p.kind is A.Kind.DISCRETE and old is not None:
                continue            # the file's declaration stands
            else:
                out[p.name.key] = p
        return list(out.values())

    def _same_signature(self, old: A.PredicateDecl, new: A.PredicateDecl) -> bool:
        if len(old.params) == len(new.params):
            return True
        self.diags.append(error(
            "E126", f"`{new.name.text}` takes {len(new.params)} argument(s) here but "
            f"{len(old.params)} in the domain", new.span, "give the meaning the domain's "
            "parameters, in its order", related=[Related(old.span, "declared in the domain here")]))
        return False

    def _kinematic(self, p: A.PredicateDecl) -> A.PredicateDecl:
        spec = p.kinematic
        assert spec is not None
        params = {q.name.key for q in p.params}
        if spec.parent.key in params:
            return p
        if spec.parent.key != HAND_VAR or self.hand is None:
            hint = "declare the robot frame that holds with `(:hand FRAME)` and write " \
                   f"`(link {HAND_VAR} ?x)`" if self.hand is None else \
                f"the parent is a parameter of `{p.name.text}` or `{HAND_VAR}`"
            self.diags.append(error("E125", f"`{spec.parent.text}` in the kinematic annotation "
                                    f"of `{p.name.text}` is not one of its parameters",
                                    spec.parent.span, hint))
            return p
        self.with_hand.add(p.name.key)
        return replace(p, params=(_typed(HAND_VAR, HAND_TYPE, spec.parent),) + p.params)

    # ---- atoms -----------------------------------------------------------------------------
    def _hand_term(self, like: A.Name) -> A.Const:
        assert self.hand is not None
        return A.Const(_name(self.hand.text, like), span=like.span)

    def rewrite(self, node, in_action: bool = True):
        """Every atom of a with-hand predicate gains the hand; ``?hand`` becomes the frame (with
        several hands, inside an action it stays the action's ``?hand`` parameter; in the
        problem it is the first hand)."""
        keep_var = self.multi and in_action

        def hand(like: A.Name):
            return A.Var(_name(HAND_VAR, like), span=like.span) if keep_var \
                else self._hand_term(like)

        def fn(n):
            if isinstance(n, A.Atom) and n.pred.key in self.with_hand:
                return replace(n, args=(hand(n.pred),) + n.args)
            if isinstance(n, A.Var) and n.name.key == HAND_VAR and self.hand is not None \
                    and not keep_var:
                return self._hand_term(n.name)
            return n
        return map_tree(node, fn)

    def with_hand_param(self, act: A.Action) -> A.Action:
        """With several hands, an action whose atoms name ``?hand`` takes it as a parameter."""
        if not self.multi or any(p.name.key == HAND_VAR for p in act.params):
            return act
        found: list[A.Var] = []

        def fn(n):
            if isinstance(n, A.Var) and n.name.key == HAND_VAR:
                found.append(n)
            return n
        map_tree((act.precondition, act.effect), fn)
        if not found:
            return act
        return replace(act, params=act.params + (_typed(HAND_VAR, HAND_TYPE, found[0].name),))

    def _means(self, action: A.Action) -> A.Formula | None:
        """The meanings of the atoms ``action`` adds, as precondition atoms."""
        out = []
        for added, at in _atoms(action.effect):
            m = self.meanings.get(at.pred.key)
            if added and m is not None:
                out.append(A.Atom(m.name, at.args, span=at.span))
        return _conj(*out)

    # ---- actions ---------------------------------------------------------------------------
    def actions(self) -> tuple[list[A.Action], list[A.PredicateDecl], list[A.InitItem]]:
        extra = {a.name.key: a for a in self.sem.actions}
        by_key = {a.name.key: a for a in self.domain.actions}
        for key, a in extra.items():
            if key not in by_key:
                self.diags.append(error("E127", f"no action `{a.name.text}` in the domain "
                                        f"`{self.domain.name.text}`", a.name.span,
                                        suggest(key, by_key)))
            if a.params:
                self.diags.append(warning("W020", f"`{a.name.text}`'s parameters are the "
                                          "domain's; the ones given here are ignored",
                                          a.params[0].span))
        out: list[A.Action] = []
        preds: list[A.PredicateDecl] = []
        init: list[A.InitItem] = []
        carried = False
        for act in self.domain.actions:
            ext = extra.get(act.name.key)
            pre_extra = ext.precondition if ext is not None else None
            if ext is not None and ext.carries is not None:
                split = self._carry(act, ext.carries, pre_extra)
                if split is not None:
                    out.extend(split[0])
                    preds.append(split[1])
                    carried = True
                    continue
            out.append(replace(act, precondition=_conj(act.precondition, pre_extra,
                                                       self._means(act))))
        if carried:
            like = self.hand or self.sem.name
            preds.insert(0, A.PredicateDecl(
                _name(CARRYING, like), (_typed(HAND_VAR, HAND_TYPE, like), _typed("?x", "object",
                                                                                 like)),
                A.Kind.KINEMATIC, None, A.KinematicSpec(_name(HAND_VAR, like), _name("?x", like),
                                                        span=like.span), span=like.span))
            preds.insert(1, A.PredicateDecl(_name(HAND_FREE, like), (), A.Kind.DISCRETE,
                                            span=like.span))
            init.append(A.Atom(_name(HAND_FREE, like), (), span=like.span))
        return out, preds, init

    def _carry(self, act: A.Action, var: A.Var, pre_extra):
        if var.name.key not in {p.name.key for p in act.params}:
            self.diags.append(error("E128", f"`{var.name.text}` is not a parameter of "
                                    f"`{act.name.text}`", var.span,
                                    "`:carries` names the parameter the action moves"))
            return None
        if self.hand is None:
            self.diags.append(error("E125", f"`{act.name.text}` carries `{var.name.text}` but "
                                    "the module names no hand", var.span,
                                    "add `(:hand FRAME)`: the robot frame that holds"))
            return None
        nm = act.name
        args = tuple(A.Var(p.name, span=p.span) for p in act.params)
        pending = A.PredicateDecl(_name(nm.text + PENDING_SUFFIX, nm), act.params,
                                  A.Kind.DISCRETE, span=act.span)
        pend_atom = A.Atom(pending.name, args, span=act.span)
        hand = A.Var(_name(HAND_VAR, nm), span=nm.span) if self.multi else self._hand_term(nm)
        carry_atom = A.Atom(_name(CARRYING, nm), (hand, var), span=var.span)
        free_atom = A.Atom(_name(HAND_FREE, nm), (), span=act.span)
        grasp = A.Action(_name(nm.text + GRASP_SUFFIX, nm), act.params,
                         _conj(act.precondition, pre_extra, free_atom),
                         _effects(A.AddEffect(carry_atom, span=var.span),
                                  A.DelEffect(free_atom, span=act.span),
                                  A.AddEffect(pend_atom, span=act.span)), span=act.span)
        release = A.Action(nm, act.params, _conj(pend_atom, self._means(act)),
                           _effects(act.effect, A.DelEffect(carry_atom, span=var.span),
                                    A.AddEffect(free_atom, span=act.span),
                                    A.DelEffect(pend_atom, span=act.span)), span=act.span)
        return [grasp, release], pending

    # ---- the whole -------------------------------------------------------------------------
    def run(self) -> tuple[A.Domain, A.Problem | None, A.Domain]:
        sem, dom = self.sem, self.domain
        if sem.target is not None and sem.target.key != dom.name.key:
            self.diags.append(warning("W019", f"this module gives meaning to domain "
                                      f"`{sem.target.text}`, used here with `{dom.name.text}`",
                                      sem.target.span))
        preds = self.predicates()
        actions, hidden, init_extra = self.actions()
        geometric_now = {p.name.key for p in preds if p.kind is A.Kind.GEOMETRIC}
        constants = dom.constants
        for h in self.hands:
            constants += (A.Typed(h, A.TypeRef((_name(HAND_TYPE, h),), span=h.span),
                                  span=h.span),)
        new_dom = replace(dom, predicates=tuple(preds) + tuple(hidden), actions=tuple(actions),
                          constants=constants, includes=dom.includes, defines=dom.defines)
        new_dom = replace(new_dom, actions=tuple(self.with_hand_param(a) for a in
                                                 self.rewrite(new_dom.actions)))
        problem = self.problem
        if problem is not None:
            kept = []
            for item in problem.init:
                if isinstance(item, A.Atom) and item.pred.key in geometric_now:
                    self.diags.append(warning("W021", f"`{item.pred.text}` has a geometric "
                                              "meaning here: the scene decides its initial "
                                              "value; this atom is ignored", item.span))
                    continue
                kept.append(item)
            problem = replace(problem, init=self.rewrite(tuple(kept), False) + tuple(init_extra),
                              goal=self.rewrite(problem.goal, False))
        types = sem.types + (A.TypeDecl(_name(HAND_TYPE, sem.name), None, span=sem.name.span),)
        module = replace(sem, form="module", predicates=(), actions=(), types=types)
        return new_dom, problem, module


def apply_semantics(domain: A.Domain, problem: A.Problem | None, sem: A.Domain
                    ) -> tuple[A.Domain, A.Problem | None, A.Domain, list[Diagnostic]]:
    """(domain, problem, the module's remainder as a module, diagnostics): see the module doc."""
    ov = _Overlay(domain, problem, sem)
    new_dom, new_pb, module = ov.run()
    return new_dom, new_pb, module, ov.diags


__all__ = ["apply_semantics", "HAND_TYPE", "HAND_VAR", "CARRYING", "HAND_FREE", "MEANS_SUFFIX",
           "map_tree"]
