"""Level 2: the AST read from domains, problems, modules and the legacy dialects."""

from __future__ import annotations

from tmpc.lang import ast as A
from tmpc.lang.reader import parse_text

NATIVE = """
(define (domain d)
  (:requirements :strips :typing :tmpc)
  (:types stick manipulator surface - object)
  (:constants base_link - object)
  (:predicates
    (on ?x - stick ?s - surface)
    (holding ?m - manipulator ?x - stick :kinematic (link ?m ?x))
    (near ?m - manipulator ?x - stick
      :semantics (let ((?d (distance (position ?m) (position ?x)))) (<= ?d 0.1)))
    (ext ?m - manipulator :geometric))
  (:define (twice ?v - scalar) (* 2 ?v))
  (:action pick
    :parameters (?m - manipulator ?x - stick ?s - surface)
    :precondition (and (on ?x ?s) (near ?m ?x) (not (holding ?m ?x)))
    :effect (and (holding ?m ?x) (not (on ?x ?s)))))
"""


def only(text):
    parsed = parse_text(text)
    assert not [d for d in parsed.diagnostics if d.is_error], parsed.diagnostics
    return parsed.definitions


def test_native_domain_kinds_and_semantics():
    (dom,) = only(NATIVE)
    assert dom.dialect is A.Dialect.TMPC
    kinds = {p.name.text: p.kind for p in dom.predicates}
    assert kinds == {"on": A.Kind.DISCRETE, "holding": A.Kind.KINEMATIC,
                     "near": A.Kind.GEOMETRIC, "ext": A.Kind.GEOMETRIC}
    holding = dom.predicates[1]
    assert (holding.kinematic.parent.text, holding.kinematic.child.text) == ("?m", "?x")
    near = dom.predicates[2]
    assert isinstance(near.semantics, A.Let) and not near.external
    assert dom.predicates[3].external
    assert dom.defines[0].name.text == "twice"
    act = dom.actions[0]
    assert [p.name.text for p in act.params] == ["?m", "?x", "?s"]
    assert isinstance(act.precondition, A.And) and isinstance(act.precondition.parts[2], A.Not)
    assert isinstance(act.effect.parts[1], A.DelEffect)


def test_planet_dialect():
    (dom,) = only("""
(define (domain clutter)
 (:requirements :strips :equality)
 (:predicates (on-surface ?x -objs ?s -surface :discrete)
  (holding ?m -manipulator ?x -objs :kinematic ((link ?m ?x) (unlink ?m ?x)))
  (at ?m -manipulator ?x -objs))
 (:action pickup
  :parameters (?x -objs ?s -surface ?m -manipulator)
  :precondition (and (on-surface ?x ?s) (at ?m ?x))
  :effect (and (holding ?m ?x) (not (on-surface ?x ?s)))))""")
    assert dom.dialect is A.Dialect.PLANET
    at = dom.predicates[2]
    assert at.kind is A.Kind.GEOMETRIC and at.external
    assert dom.predicates[1].kinematic.style == "planet"
    assert [p.type.names[0].text for p in dom.predicates[0].params] == ["objs", "surface"]


def test_tmit_star_dialect():
    (dom,) = only("""
(define (domain shelves)
 (:predicates (arm-empty ?m -manipulator :discrete)
  (holding ?m -manipulator ?x -objs (kinematic (link ?m ?x) (unlink ?m ?x)))
  (in-region ?m -manipulator))
 (:action pick :parameters (?x -objs ?m -manipulator)
  :precondition (and (arm-empty ?m) (in-region ?m))
  :effect (and (holding ?m ?x) (not (arm-empty ?m)))))""")
    assert dom.dialect is A.Dialect.TMIT_STAR
    assert dom.predicates[1].kind is A.Kind.KINEMATIC
    assert dom.predicates[2].kind is A.Kind.GEOMETRIC


def test_classical_domain_stays_discrete():
    (dom,) = only("(define (domain b) (:predicates (p ?x) (q)) (:action a :effect (q)))")
    assert dom.dialect is A.Dialect.PDDL
    assert {p.kind for p in dom.predicates} == {A.Kind.DISCRETE}


def test_problem_sections():
    (prob,) = only("""
(define (problem p1) (:domain d)
  (:objects a b - loc c)
  (:init (at a) (= (dist a b) 3) (= (total-cost) 0))
  (:goal (forall (?x - loc) (visited ?x)))
  (:metric minimize (total-cost)))""")
    assert prob.domain_name.text == "d"
    assert [(o.name.text, o.type.names[0].text if o.type else None) for o in prob.objects] == \
        [("a", "loc"), ("b", "loc"), ("c", None)]
    assert isinstance(prob.init[1], A.NumericInit) and prob.init[1].value.value == 3
    assert isinstance(prob.goal, A.Quantified) and prob.metric.direction == "minimize"


def test_effects_numeric_conditional_and_derived():
    (dom,) = only("""
(define (domain d) (:requirements :adl :derived-predicates :action-costs)
  (:predicates (p ?x) (q ?x) (r))
  (:functions (total-cost) - number (w ?x) - number)
  (:derived (r) (exists (?x) (p ?x)))
  (:action a :parameters (?x)
    :precondition (or (p ?x) (imply (q ?x) (= ?x ?x)))
    :effect (and (forall (?y) (when (p ?y) (not (p ?y)))) (increase (total-cost) (w ?x)))))""")
    assert [f.type.text for f in dom.functions] == ["number", "number"]
    eff = dom.actions[0].effect
    assert isinstance(eff.parts[0], A.ForallEffect) and isinstance(eff.parts[0].body, A.WhenEffect)
    assert isinstance(eff.parts[1], A.NumericEffect) and eff.parts[1].op == "increase"
    assert isinstance(dom.derived[0].body, A.Quantified)


def test_keywords_are_case_insensitive_and_names_keep_spelling():
    (dom,) = only("(DEFINE (DOMAIN Blocks) (:REQUIREMENTS :STRIPS) (:PREDICATES (On ?X ?Y)) "
                  "(:ACTION Stack :PARAMETERS (?X ?Y) :PRECONDITION (AND (On ?X ?Y)) "
                  ":EFFECT (NOT (On ?X ?Y))))")
    assert dom.name.text == "Blocks" and dom.name.key == "blocks"
    assert dom.requirements[0].name.text == ":strips"
    assert dom.actions[0].precondition.parts[0].pred.text == "On"


def test_spans_point_into_the_text():
    text = NATIVE
    (dom,) = only(text)
    act = dom.actions[0]
    assert text[act.name.span.start:act.name.span.end] == "pick"
    eff = act.effect.parts[0]
    assert text[eff.span.start:eff.span.end] == "(holding ?m ?x)"


def test_recovery_returns_partial_tree_and_all_errors():
    parsed = parse_text("""
(define (domain d)
  (:predicates (p ?x))
  (:action a :parameters (?x) :precondtion (p ?x) :effect (p ?x))
  (:bogus 1)
  (:action b :parameters (?x) :effect (not (p ?x) (p ?x))))""")
    codes = [d.code for d in parsed.diagnostics]
    assert codes == ["E106", "E102", "E112"]
    (dom,) = parsed.definitions
    assert [a.name.text for a in dom.actions] == ["a", "b"]
