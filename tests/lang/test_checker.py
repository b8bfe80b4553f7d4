"""The checker: names, arity, typing, kinds, expression types, requirement warnings."""

from __future__ import annotations

import pytest

from tests.support import check, codes, errors

DOMAIN = """
(define (domain d)
  (:requirements :strips :typing :negative-preconditions :tmpc)
  (:types stick surface manipulator - object thing)
  (:constants world - surface)
  (:predicates
    (on ?x - stick ?s - surface)
    (empty ?m - manipulator)
    (holding ?m - manipulator ?x - stick :kinematic (link ?m ?x))
    (near ?m - manipulator ?x - stick :semantics (<= (distance (position ?m) (position ?x)) 0.1))
    %s)
  %s
  (:action pick
    :parameters (?m - manipulator ?x - stick ?s - surface)
    :precondition (and (on ?x ?s) (empty ?m) (near ?m ?x))
    :effect (and (holding ?m ?x) (not (on ?x ?s)) (not (empty ?m))))
  %s)
"""


def dom(preds: str = "", defines: str = "", actions: str = "") -> str:
    return DOMAIN % (preds, defines, actions)


def test_clean_domain():
    rep = check(dom())
    assert rep.ok and codes(rep) == []
    (prog,) = rep.programs
    assert set(prog.scope.predicates) == {"on", "empty", "holding", "near"}


@pytest.mark.parametrize("actions, code", [
    ("(:action a :parameters (?x - stick) :effect (onn ?x ?x))", "E200"),
    ("(:action a :parameters (?x - stick) :effect (empty ?x ?x))", "E202"),
    ("(:action a :parameters (?x - stick) :effect (empty ?x))", "E204"),
    ("(:action a :parameters (?m - manipulator) :effect (empty ?n))", "E205"),
    ("(:action a :parameters (?m - manipulator) :effect (on ?m nowhere))", "E204"),
    ("(:action pick :parameters () :effect (and))", "E201"),
    ("(:action a :parameters (?m - manipulator ?x - stick) :effect (near ?m ?x))", "E400"),
    ("(:action a :parameters (?m - manipulator ?m - stick) :effect (empty ?m))", "E201"),
    ("(:action a :parameters (?x - stik) :effect (and))", None),   # W012 only
])
def test_action_errors(actions, code):
    rep = check(dom(actions=actions))
    if code is None:
        assert rep.ok and "W012" in codes(rep)
    else:
        assert code in errors(rep), rep.diagnostics


@pytest.mark.parametrize("preds, code", [
    ("(bad ?m - manipulator :semantics (distance (position ?m) (position ?m)))", "E303"),
    ("(bad ?m - manipulator :semantics (<= (distance 1 2) 0))", "E300"),
    ("(bad ?m - manipulator :semantics (and (empty ?m) (<= 1 2)))", "E401"),
    ("(bad ?m - manipulator :semantics (frob ?m))", "E301"),
    ("(bad ?m - manipulator :semantics (if (<= (z ?m) 0) (<= 1 2) (<= 2 1)))", "E302"),
    ("(bad ?m - manipulator :semantics (<= ?q 1))", "E205"),
    ("(bad ?m - manipulator :semantics (<= (z nothing) 1))", "E206"),
    ("(bad ?m - manipulator ?x - stick :kinematic (link ?m ?y))", "E402"),
    ("(bad ?m - manipulator :semantics (near ?m ?m))", "E204"),
])
def test_semantics_errors(preds, code):
    assert code in errors(check(dom(preds=preds))), check(dom(preds=preds)).diagnostics


def test_semantics_expression_language_types():
    preds = """(fancy ?m - manipulator ?x - stick ?s - surface :semantics
      (let ((?p (position ?m)) (?r (support-region ?s)))
        (and (inside ?p (grow ?r 0 0 0.3))
             (<= (norm (cross (z-axis ?m) (vec3 0 0 1))) (sin 0.1))
             (>= (dot (x-axis ?x) (rotate (orientation ?m) (vec3 1 0 0))) (cos (/ pi 8)))
             (if (= ?s world) (<= (z ?p) 2) (<= (abs (- (yaw ?m) (atan2 (y ?x) (x ?x)))) 0.2))
             (forall (?o - stick) (or (= ?o ?x) (>= (distance (position ?o) ?p) 0.05)))
             (<= (joint torso_lift_joint) (max 0.1 (x (extent ?x)) 0.3)))))"""
    rep = check(dom(preds=preds))
    assert rep.ok, rep.diagnostics


def test_static_if_conditions_on_scene_data():
    preds = """(tall ?m - manipulator ?s - surface :semantics
      (if (> (z (upper (support-region ?s))) 1.0)
          (<= (z ?m) (+ 0.3 (z (extent ?s))))
          (let ((?h (z (center (support-region ?s))))) (if (<= ?h 0.5) (<= 1 2) (<= 2 1)))))"""
    assert check(dom(preds=preds)).ok, check(dom(preds=preds)).diagnostics
    bad = "(low ?m - manipulator :semantics (if (< (z ?m) 1) (<= 1 2) (<= 2 1)))"
    assert "E302" in errors(check(dom(preds=bad)))


def test_parent_only_types_are_declared_by_use():
    rep = check("(define (domain t) (:requirements :typing) (:types room hall - place)"
                " (:predicates (in ?p - place)))")
    assert rep.ok and not rep.diagnostics


def test_helpers_inline_and_check_per_use():
    defines = """(:define (gap ?a ?b) (distance (position ?a) (position ?b)))
  (:define (close ?d - scalar ?a ?b) (<= (gap ?a ?b) ?d))"""
    preds = "(c2 ?m - manipulator ?x - stick :semantics (close 0.2 ?m ?x))"
    assert check(dom(preds=preds, defines=defines)).ok
    bad = "(c3 ?m - manipulator :semantics (close 0.2 ?m 1))"
    rep = check(dom(preds=bad, defines=defines))
    assert "E300" in errors(rep)
    # the error inside the helper names the offending use too
    d = next(d for d in rep.diagnostics if d.code == "E300")
    assert any("use of the helper" in r.label for r in d.related)


def test_recursive_helper_is_rejected():
    defines = "(:define (loop ?a - scalar) (+ (loop ?a) 1))"
    preds = "(c ?m - manipulator :semantics (<= (loop 1) 2))"
    assert "E304" in errors(check(dom(preds=preds, defines=defines)))


def test_stdlib_include_resolves():
    text = dom(preds="(at ?m - manipulator ?x - stick :semantics (near ?m ?x 0.05))") \
        .replace("(:predicates", '(:include "tmpc/geometry")\n  (:predicates')
    rep = check(text)
    # the local predicate `near` shadows the stdlib helper `near`, with a warning; the 3-argument
    # call then refers to the 2-argument predicate
    assert "W016" in codes(rep) and "E202" in errors(rep)
    text = text.replace("(at ?m - manipulator ?x - stick :semantics (near ?m ?x 0.05))",
                        "(up ?m - manipulator :semantics (upright ?m 0.1))")
    assert check(text).ok, check(text).diagnostics
    missing = text.replace("tmpc/geometry", "tmpc/nope")
    assert "E123" in errors(check(missing))


def test_problem_checks():
    problem = """
(define (problem p) (:domain d)
  (:objects m1 - manipulator s1 - stick t1 - surface)
  (:init (on s1 t1) (empty m1) %s)
  (:goal (and (holding m1 s1) %s)))"""
    assert check(dom() + problem % ("", "")).ok
    assert "E404" in errors(check(dom() + problem % ("(near m1 s1)", "")))
    assert "E206" in errors(check(dom() + problem % ("(empty m2)", "")))
    assert "E204" in errors(check(dom() + problem % ("(empty s1)", "")))
    wrong = (dom() + problem % ("", "")).replace("(:domain d)", "(:domain other)")
    assert "E209" in errors(check(wrong))


def test_cyclic_types():
    rep = check("(define (domain c) (:requirements :typing) (:types a - b b - a))")
    assert "E207" in errors(rep)


def test_requirement_warnings():
    rep = check("(define (domain w) (:requirements :strips) (:predicates (p ?x))"
                "(:action a :parameters (?x) :precondition (not (p ?x)) :effect (p ?x)))")
    assert rep.ok and "W001" in codes(rep)
    unknown = check("(define (domain w) (:requirements :strips :typng))")
    d = next(d for d in unknown.diagnostics if d.code == "E115")
    assert "`:typing`" in d.hint


def test_legacy_geometric_effect_is_a_warning():
    rep = check("""(define (domain l) (:predicates (p ?x -objs :discrete) (g ?x -objs))
      (:action a :parameters (?x -objs) :precondition (p ?x) :effect (and (g ?x) (not (p ?x)))))""")
    assert rep.ok and "W004" in codes(rep)


def test_unknown_constant_in_domain_alone_is_a_warning_and_an_error_with_a_problem():
    text = dom(actions="(:action a :parameters (?m - manipulator) :effect (empty spare))")
    assert check(text).ok and "W013" in codes(check(text))
    problem = "(define (problem p) (:domain d) (:objects m - manipulator) (:goal (empty m)))"
    assert "E206" in errors(check(text + problem))


def test_unused_parameter_warning():
    rep = check("(define (domain u) (:predicates (p)) (:action a :parameters (?x) :effect (p)))")
    assert rep.ok and codes(rep) == ["W002"]


@pytest.mark.parametrize("cost, bad", [("3", False), ("0", False), ("2.5", False), ("-5", True),
                                       ("1e400", True)])
def test_action_costs_are_finite_and_not_negative(cost, bad):
    report = check("(define (domain d) (:requirements :strips :action-costs)\n"
                   "  (:predicates (p)) (:functions (total-cost) - number)\n"
                   f"  (:action a :parameters () :precondition (p)\n"
                   f"   :effect (and (p) (increase (total-cost) {cost}))))\n")
    assert ("E406" in errors(report)) == bad, codes(report)


def test_a_constant_zero_divisor_is_warned():
    report = check("(define (domain d) (:requirements :strips)\n"
                   "  (:predicates (low ?m - manipulator :semantics (<= (/ (x (position ?m)) 0) 1))"
                   "\n  (ok ?m - manipulator :semantics (<= (/ (x (position ?m)) 2) 1))))\n")
    assert [d.code for d in report.diagnostics if d.code == "W301"] == ["W301"], codes(report)
    assert not errors(report)
