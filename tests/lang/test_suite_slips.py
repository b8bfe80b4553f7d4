"""The slips of the Lagriffoul suite's PDDL (and planet's own) are warnings with positions: a
file that ends before its `(define`'s `)` (W510), an init fact naming an undeclared object
(W015), robot links used as undeclared typed constants (W018); the same mistakes stay errors
where they are no legacy habit."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support import EXAMPLES, check, codes, pos_of
from tmpc.lang.program import check_paths
from tmpc.lang.reader import parse_source, parse_text
from tmpc.lang.source import SourceFile

DATA = EXAMPLES / "lagriffoul" / "data"
PAIRS = [(DATA / "problem1" / "hanoi.pddl", p) for p in sorted(DATA.glob("problem1/*_pb_*"))] + \
    [(DATA / "problem2" / "blocksworld.pddl", p) for p in sorted(DATA.glob("problem2/*_pb_*"))] + \
    [(DATA / "problem3" / "clutter.pddl", DATA / "problem3" / "clutter_pb7.pddl"),
     (DATA / "problem4" / "nonmono.pddl", DATA / "problem4" / "nonmono_pb.pddl")] + \
    [(DATA / "problem5" / "kitchen.pddl", p) for p in sorted(DATA.glob("problem5/*_pb.pddl"))]


def line_col(path: Path, offset: int) -> tuple[int, int]:
    return SourceFile.read(path).line_col(offset)


@pytest.mark.parametrize("domain, problem", PAIRS, ids=lambda p: p.stem)
def test_every_pair_of_the_suite_checks(domain, problem):
    rep = check_paths([domain, problem])
    errors = [d for d in rep.diagnostics if d.is_error]
    assert rep.ok and not errors, [(d.code, d.message) for d in errors]
    assert {d.code for d in rep.diagnostics} <= {"W001", "W015", "W510"}
    assert all(d.span is not None for d in rep.diagnostics)
    text = problem.read_text()
    # W510 exactly where a `)` is missing at the end: the count of brackets says so
    missing = text.count("(") - text.count(")")
    w510 = [d for d in rep.diagnostics if d.code == "W510"]
    assert len(w510) == (missing > 0)
    if w510:
        assert line_col(problem, w510[0].span.start) == pos_of(text, text.rstrip()[-1],
                                                               text.rstrip().count(text.rstrip()[-1]) - 1)


def test_the_repair_reads_what_the_closed_file_reads():
    """The tree read from a file missing its last `)` equals the tree of the file with `)`
    added by hand (the tab-indented lines of blocksworld_pb_D..J would mislead the
    indentation-guided repair into closing `(:init` early)."""
    for name in ("blocksworld_pb_C", "blocksworld_pb_J"):
        path = DATA / "problem2" / f"{name}.pddl"
        parsed = parse_source(SourceFile.read(path))
        fixed = parse_text(path.read_text().rstrip() + ")\n", str(path))
        assert fixed.ok and not fixed.diagnostics
        assert [d.code for d in parsed.diagnostics] == ["W510"]
        (a,), (b,) = parsed.definitions, fixed.definitions
        assert len(a.init) == len(b.init) and str(a.goal) == str(b.goal)
        assert [str(x) for x in a.init] == [str(x) for x in b.init]


def test_undeclared_d_is_a_warning_at_its_fact():
    rep = check_paths([DATA / "problem2" / "blocksworld.pddl",
                       DATA / "problem2" / "blocksworld_pb_C.pddl"])
    (w,) = [d for d in rep.diagnostics if d.code == "W015"]
    path = DATA / "problem2" / "blocksworld_pb_C.pddl"
    assert "`d`" in w.message
    assert line_col(path, w.span.start) == pos_of(path.read_text(), "(clear d)")


def test_the_same_slips_stay_errors_elsewhere():
    # a domain missing its last `)`: still E001 (tests/fixtures/bad/e001-missing-paren-at-eof)
    rep = check("(define (domain t) (:requirements :tmpc) (:predicates (p))\n"
                "  (:action a :parameters () :precondition (p) :effect (not (p)))\n")
    assert "E001" in codes(rep) and "W510" not in codes(rep)
    # a file whose missing `)` is not at the end (adding it there does not read): E001
    rep = check("(define (domain t) (:predicates (p)\n  (:action a :parameters () :effect (p)))\n")
    assert "E001" in codes(rep) and "W510" not in codes(rep)
    # a classical domain declaring :typing: an undeclared object in init is E206
    dom = """(define (domain d) (:requirements :strips :typing) (:types b)
      (:predicates (p ?x - b)) (:action a :parameters (?x - b) :precondition (p ?x) :effect
      (not (p ?x))))"""
    prob = "(define (problem q) (:domain d) (:objects x - b) (:init (p x) (p y)) (:goal (p x)))"
    assert "E206" in codes(check(dom + prob))
    assert "W015" in codes(check(dom.replace(":typing", "") + prob))


PLANET_DOMAIN = """(define (domain nohit)
  (:requirements :strips)
  (:predicates (holding ?x - obj :discrete) (free :discrete) (on ?x - obj ?s - surface)
               (donthits ?l - link ?x - obj))
  (:action pick :parameters (?x - obj ?s - surface)
    :precondition (and (free) (on ?x ?s) (donthits l_upper_arm_link ?x)
                       (donthits r_upper_arm_link ?x))
    :effect (and (holding ?x) (not (free))))
  (:action place :parameters (?x - obj ?s - surface)
    :precondition (and (holding ?x) (donthits l_upper_arm_link ?x))
    :effect (and (free) (not (holding ?x)))))
(define (problem p) (:domain nohit) (:objects o - obj t - surface) (:init (free))
  (:goal (holding o)))
"""


def test_planet_robot_links_take_the_type_the_parameter_wants():
    """planet's clutter_nohit.pddl: `(donthits l_upper_arm_link ?x)` with `?l - link` and the
    link never declared. W018 once per link, then every use checks (no E204)."""
    rep = check(PLANET_DOMAIN)
    assert rep.ok, [(d.code, d.message) for d in rep.diagnostics if d.is_error]
    assert codes(rep).count("W018") == 2
    # a declared object of the wrong type is still E204
    bad = PLANET_DOMAIN.replace("(donthits r_upper_arm_link ?x)", "(donthits ?s ?x)")
    assert "E204" in codes(check(bad))
