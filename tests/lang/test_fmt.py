"""The formatter: layout rules, comments, and the `tmpc fmt` command."""

from __future__ import annotations

import subprocess
import sys

from tmpc.lang.formatter import format_doc
from tmpc.lang.sexpr import parse_sexpr
from tmpc.lang.source import SourceFile


def fmt(text: str) -> str:
    return format_doc(parse_sexpr(SourceFile("t.pddl", text)))


def test_layout_of_a_domain():
    out = fmt("(DEFINE (DOMAIN d) (:REQUIREMENTS :STRIPS) (:predicates (p ?x) (q))"
              "(:action a :parameters (?x) :precondition (AND (p ?x)) :effect (not (p ?x))))")
    assert out == ("(define (domain d)\n"
                   "  (:requirements :strips)\n"
                   "  (:predicates\n"
                   "    (p ?x)\n"
                   "    (q))\n"
                   "  (:action a\n"
                   "    :parameters (?x)\n"
                   "    :precondition (and (p ?x))\n"
                   "    :effect (not (p ?x))))\n")


def test_comments_stay_where_they_were():
    text = ("; header\n(define (domain d) ; trailing\n  (:predicates\n    ; about p\n    (p ?x)"
            " ; p!\n\n    (q)\n    ; last\n  ))\n")
    out = fmt(text)
    assert out == ("; header\n(define (domain d) ; trailing\n  (:predicates\n    ; about p\n"
                   "    (p ?x) ; p!\n\n    (q)\n    ; last\n  ))\n")
    assert fmt(out) == out


def test_long_lists_break_and_keep_key_value_pairs():
    atoms = " ".join(f"(on-table block{i})" for i in range(12))
    out = fmt(f"(define (problem p) (:domain d) (:init {atoms}) (:goal (and {atoms})))")
    lines = out.splitlines()
    assert lines[2] == "  (:init" and lines[3] == "    (on-table block0)"
    assert "  (:goal (and" in out
    assert max(len(line) for line in lines) <= 100


def test_typed_lists_break_by_group_and_keep_glued_dashes():
    names = " ".join(f"obj{i}" for i in range(30))
    out = fmt(f"(define (problem p) (:domain d) (:objects {names} -objs t1 t2 -surface))")
    assert "    t1 t2 -surface)" in out
    assert "-objs\n" in out


def run(*args, stdin=None):
    return subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", *args], input=stdin,
                          capture_output=True, text=True)


def test_fmt_command_in_place_check_and_stdin(tmp_path):
    f = tmp_path / "d.pddl"
    ugly = "(define (domain d)   (:predicates (p)))"
    f.write_text(ugly)
    r = run("fmt", "--check", str(f))
    assert r.returncode == 1 and "would reformat" in r.stderr
    assert f.read_text() == ugly                         # --check changes nothing
    r = run("fmt", str(f))
    assert r.returncode == 0 and f.read_text() == "(define (domain d)\n  (:predicates\n    (p)))\n"
    assert run("fmt", "--check", str(f)).returncode == 0
    assert [p.name for p in tmp_path.iterdir()] == ["d.pddl"]   # no temp files left behind
    r = run("fmt", "-", stdin=ugly)
    assert r.returncode == 0 and r.stdout == f.read_text()


def test_fmt_refuses_files_with_syntax_errors(tmp_path):
    f = tmp_path / "d.pddl"
    f.write_text("(define (domain d)\n  (:predicates (p))\n")
    r = run("fmt", str(f))
    assert r.returncode == 1 and "E001" in r.stderr
    assert f.read_text() == "(define (domain d)\n  (:predicates (p))\n"


def test_fmt_writes_through_a_symlink(tmp_path):
    """`fmt link.pddl` formats the file the link points to; the link stays a link."""
    target = tmp_path / "real.pddl"
    target.write_text("(define (domain d) (:predicates (p)) (:action a :parameters () "
                      ":precondition (p) :effect (not (p))))\n")
    link = tmp_path / "link.pddl"
    link.symlink_to(target)
    r = run("fmt", str(link))
    assert r.returncode == 0, r.stderr
    assert link.is_symlink() and link.resolve() == target
    assert run("fmt", "--check", str(target)).returncode == 0


def test_a_declaration_keeps_its_parameters_on_its_opening_line():
    """It came out one token per line once its semantics did not fit on one line."""
    from tmpc.lang.formatter import format_doc
    from tmpc.lang.reader import parse_source
    from tmpc.lang.source import SourceFile
    src = ("(define (domain d) (:requirements :strips) (:predicates (reach ?g - gripper ?c - cube "
           ":semantics (and (<= (distance (position ?g) (position ?c)) 0.05) "
           "(<= (z (position ?g)) (+ (z (position ?c)) 0.2))))))\n")
    out = format_doc(parse_source(SourceFile("d.pddl", src)).sexpr)
    assert out == ("(define (domain d)\n  (:requirements :strips)\n  (:predicates\n"
                   "    (reach ?g - gripper ?c - cube\n"
                   "      :semantics (and\n"
                   "        (<= (distance (position ?g) (position ?c)) 0.05)\n"
                   "        (<= (z (position ?g)) (+ (z (position ?c)) 0.2))))))\n")


def test_the_bundled_examples_are_formatted():
    from tests.support import EXAMPLES
    from tmpc.lang.formatter import format_doc
    from tmpc.lang.reader import parse_source
    from tmpc.lang.source import SourceFile
    files = sorted(EXAMPLES.glob("*/*.pddl"))
    assert len(files) >= 8
    for f in files:
        src = SourceFile.read(f)
        assert format_doc(parse_source(src).sexpr) == src.text, f"`tmpc fmt {f}` changes it"
