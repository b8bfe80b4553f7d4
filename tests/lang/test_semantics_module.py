"""Semantics modules: a classical domain's unchanged files + a module of meanings -> a tmpc
program (tmpc.lang.semantics_module), and their errors."""

from pathlib import Path

import pytest

from tmpc.lang import ast as A
from tmpc.lang.program import check_paths
from tmpc.lang.reader import parse_text

ROOT = Path(__file__).resolve().parents[2]
SUITE = ROOT / "examples" / "lagriffoul"
SEMANTICS = SUITE / "semantics"
SHARED = ROOT.parent / "shared" / "benchmarks" / "lagriffoul"
DATA = SUITE / "data" if (SUITE / "data").is_dir() else SHARED

DOMAIN = """(define (domain bw)
  (:requirements :strips)
  (:predicates (on-surface ?x - objs ?s - surface) (arm-empty) (holding ?x - objs))
  (:action pickup :parameters (?ob - objs ?s - surface)
    :precondition (and (on-surface ?ob ?s) (arm-empty))
    :effect (and (holding ?ob) (not (on-surface ?ob ?s)) (not (arm-empty))))
  (:action putdown :parameters (?ob - objs ?s - surface)
    :precondition (holding ?ob)
    :effect (and (arm-empty) (on-surface ?ob ?s) (not (holding ?ob)))))
"""
PROBLEM = """(define (problem p) (:domain bw)
  (:objects t1 t2 - surface a - objs)
  (:init (on-surface a t1) (arm-empty))
  (:goal (on-surface a t2)))
"""
MODULE = """(define (semantics bw-geometry)
  (:domain bw)
  (:requirements :tmpc)
  (:include "tmpc/lagriffoul")
  (:hand r_gripper_tool_frame)
  (:predicates
    (holding ?x - objs :kinematic (link ?hand ?x))
    (grasp ?h - tmpc-hand ?x - objs :semantics (grasped-by ?h ?x))
    (on-surface ?x - objs ?s - surface :semantics (placed-on ?x ?s)))
  (:action pickup :precondition (grasp ?hand ?ob)))
"""


def _check(tmp_path, module=MODULE, domain=DOMAIN, problem=PROBLEM):
    d, p, m = tmp_path / "d.pddl", tmp_path / "p.pddl", tmp_path / "m.tmpc"
    d.write_text(domain)
    p.write_text(problem)
    m.write_text(module)
    return check_paths([d, p], semantics={str(p.resolve()): m})


def test_module_turns_the_classical_domain_into_a_tmpc_program(tmp_path):
    report = _check(tmp_path)
    assert report.ok, [d.message for d in report.diagnostics]
    prog = report.programs[0]
    decls = {p.name.key: p for p in prog.domain.predicates}
    # holding: kinematic, with the hand as first parameter
    assert decls["holding"].kind is A.Kind.KINEMATIC
    assert [p.name.text for p in decls["holding"].params] == ["?hand", "?x"]
    # on-surface stays a symbol (effects change it); its meaning is a hidden geometric predicate
    assert decls["on-surface"].kind is A.Kind.DISCRETE
    assert decls["on-surface~means"].kind is A.Kind.GEOMETRIC
    acts = {a.name.key: a for a in prog.domain.actions}
    pick = [p for p in acts["pickup"].precondition.parts]
    assert any(isinstance(x, A.Atom) and x.pred.key == "grasp"
               and x.args[0].name.text == "r_gripper_tool_frame" for x in pick)
    put = acts["putdown"].precondition.parts
    # the release that adds on-surface must make its meaning true, with the action's arguments
    means = [x for x in put if isinstance(x, A.Atom) and x.pred.key == "on-surface~means"]
    assert [a.name.text for a in means[0].args] == ["?ob", "?s"]
    # every holding atom gains the hand (the precondition of putdown included)
    held = [x for x in put if isinstance(x, A.Atom) and x.pred.key == "holding"]
    assert [a.name.text for a in held[0].args] == ["r_gripper_tool_frame", "?ob"]
    # the problem's init and goal are unchanged symbols
    assert {a.pred.key for a in prog.problem.init} == {"on-surface", "arm-empty"}


def test_carries_splits_a_one_step_move_into_grasp_and_release(tmp_path):
    domain = """(define (domain h) (:requirements :strips)
      (:predicates (on ?x ?y) (clear ?x))
      (:action move :parameters (?d ?from ?to)
        :precondition (and (on ?d ?from) (clear ?d) (clear ?to))
        :effect (and (on ?d ?to) (clear ?from) (not (on ?d ?from)) (not (clear ?to)))))"""
    problem = """(define (problem p) (:domain h) (:objects a p1 p2)
      (:init (on a p1) (clear a) (clear p2)) (:goal (on a p2)))"""
    module = """(define (semantics hg) (:domain h) (:requirements :tmpc)
      (:include "tmpc/lagriffoul") (:hand r_gripper_tool_frame)
      (:predicates (grasp ?h - tmpc-hand ?x :semantics (grasped-by ?h ?x))
                   (on ?x ?y :semantics (placed-on ?x ?y)))
      (:action move :carries ?d :precondition (grasp ?hand ?d)))"""
    report = _check(tmp_path, module, domain, problem)
    assert report.ok, [d.message for d in report.diagnostics]
    prog = report.programs[0]
    acts = {a.name.key: a for a in prog.domain.actions}
    assert set(acts) == {"move~grasp", "move"}
    grasp_pre = {x.pred.key for x in acts["move~grasp"].precondition.parts}
    assert {"on", "clear", "grasp", "tmpc-hand-free"} <= grasp_pre
    release_pre = {x.pred.key for x in acts["move"].precondition.parts}
    assert release_pre == {"move~pending", "on~means"}
    kin = {p.name.key: p for p in prog.domain.predicates}["tmpc-carrying"]
    assert kin.kind is A.Kind.KINEMATIC
    assert any(a.pred.key == "tmpc-hand-free" for a in prog.problem.init)


@pytest.mark.parametrize("module, code", [
    # a predicate with another arity than the domain's
    (MODULE.replace("(holding ?x - objs :kinematic", "(holding ?x - objs ?y - objs :kinematic"),
     "E126"),
    # ?hand without (:hand ...)
    (MODULE.replace("(:hand r_gripper_tool_frame)", ""), "E125"),
    # an action the domain does not have
    (MODULE.replace("(:action pickup", "(:action pick-up"), "E127"),
    # :carries naming no parameter
    (MODULE.replace("(:action pickup :precondition", "(:action pickup :carries ?nope "
                                                     ":precondition"), "E128"),
])
def test_module_errors_point_into_the_module(tmp_path, module, code):
    report = _check(tmp_path, module)
    errs = [d for d in report.diagnostics if d.is_error]
    assert code in {d.code for d in errs}, [(d.code, d.message) for d in errs]
    d = next(d for d in errs if d.code == code)
    assert d.span is not None and d.span.path.endswith("m.tmpc")


@pytest.mark.parametrize("module, problem, code, where, text", [
    # the module names another domain
    (MODULE.replace("(:domain bw)", "(:domain blocksworld)"), PROBLEM, "W019", "m.tmpc",
     "blocksworld"),
    # an action given parameters: the domain's are kept
    (MODULE.replace("(:action pickup :precondition", "(:action pickup :parameters (?o) "
                                                     ":precondition"), PROBLEM, "W020",
     "m.tmpc", "?o"),
    # an :init atom of a predicate the module makes geometric (no effect changes `near`)
    (MODULE.replace("(on-surface ?x - objs ?s - surface :semantics (placed-on ?x ?s))",
                    "(on-surface ?x - objs ?s - surface :semantics (placed-on ?x ?s))\n"
                    "    (near ?x - objs ?s - surface :semantics (placed-on ?x ?s))"),
     PROBLEM.replace("(arm-empty))", "(arm-empty) (near a t1))"), "W021", "p.pddl", "(near a t1)"),
])
def test_module_notes_are_warnings_each_with_its_code_and_place(tmp_path, module, problem, code,
                                                                where, text):
    report = _check(tmp_path, module, DOMAIN, problem)
    assert not [d for d in report.diagnostics if d.is_error], \
        [(d.code, d.message) for d in report.diagnostics]
    ours = [d for d in report.diagnostics if d.code == code]
    assert len(ours) == 1, [(d.code, d.message) for d in report.diagnostics]
    d = ours[0]
    assert d.span is not None and d.span.path.endswith(where)
    src = (tmp_path / where).read_text()
    assert text in src[d.span.start:d.span.end + len(text)], (src[d.span.start:], d.span)
    assert {x.code for x in report.diagnostics} & {"W019", "W020", "W021"} == {code}


def test_a_file_without_a_semantics_module_is_e125(tmp_path):
    report = _check(tmp_path, "(define (module x) (:requirements :tmpc))")
    assert "E125" in {d.code for d in report.diagnostics if d.is_error}


def test_tabs_count_as_editors_show_them_when_repairing_parens():
    # the suite's blocks-world problems indent a line with a tab and miss the final `)`: the
    # file is closed at its end (W510), not the `:init` at the tab line
    text = "(define (problem p)\n    (:init \n          (a)\n\t  (b)\n          (c) )\n" \
           "   (:goal (a))\n"
    parsed = parse_text(text, "p.pddl")
    assert [d.code for d in parsed.diagnostics] == ["W510"]
    init = parsed.definitions[0].init
    assert [a.pred.text for a in init] == ["a", "b", "c"]


@pytest.mark.parametrize("problem, module", [
    ("problem1/hanoi_pb_3.pddl", "hanoi"),
    ("problem2/blocksworld_pb_E.pddl", "blocksworld"),
    ("problem3/clutter_pb7.pddl", "clutter"),
    ("problem4/nonmono_pb.pddl", "clutter"),
])
def test_the_suite_modules_check_with_the_unchanged_files(problem, module):
    pb = DATA / problem
    domain = next(p for p in pb.parent.glob("*.pddl") if "_pb" not in p.name)
    report = check_paths([domain, pb], semantics={str(pb.resolve()): SEMANTICS / f"{module}.tmpc"})
    assert report.ok, [(d.code, d.message) for d in report.diagnostics if d.is_error]
    assert len(report.programs) == 1


def test_mutated_semantics_modules_give_diagnostics_never_a_traceback(tmp_path):
    """Fuzz: a semantics module cut, with tokens dropped, swapped or duplicated, is read and
    applied with diagnostics only."""
    import random
    rng = random.Random(7)
    tokens = MODULE.replace("(", " ( ").replace(")", " ) ").split()
    for trial in range(60):
        t = list(tokens)
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(len(t))
            op = rng.choice(("drop", "dup", "swap", "cut", "junk"))
            if op == "drop":
                del t[i]
            elif op == "dup":
                t.insert(i, t[i])
            elif op == "swap":
                j = rng.randrange(len(t))
                t[i], t[j] = t[j], t[i]
            elif op == "cut":
                t = t[:i]
            else:
                t.insert(i, rng.choice(("?hand", ":carries", "(:hand)", ":kinematic", "?x",
                                        "(link ?hand)", "(:domain)")))
            if not t:
                t = ["("]
        report = _check(tmp_path, " ".join(t))
        assert all(d.code for d in report.diagnostics)


def test_a_semantics_module_checked_alone_is_read_for_its_syntax(tmp_path):
    """`tmpc check module.tmpc` without the run manifest: no false errors about `?hand` or the
    domain's parameters (the module is checked when a manifest applies it), but its syntax
    errors are reported."""
    report = check_paths([SEMANTICS / "blocksworld.tmpc"])
    assert report.ok and not report.programs, [d.message for d in report.diagnostics]
    broken = tmp_path / "m.tmpc"
    broken.write_text(MODULE.replace("(:hand r_gripper_tool_frame)", "(:hand r_gripper_tool_frame"))
    assert "E001" in {d.code for d in check_paths([broken]).diagnostics}
