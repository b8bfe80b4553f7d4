"""Long lists kept as columns (sexpr.Packed, columns.InitFacts/TypedNames) read exactly as the
plain tree does: the same nodes with the same spans, the same diagnostics, the same check."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from tests.bench.gen import large_problem, logistics_domain
from tests.support import EXAMPLES, pddl_files
from tmpc.lang import sexpr
from tmpc.lang.columns import InitFacts, TypedNames
from tmpc.lang.formatter import format_doc
from tmpc.lang.program import check_paths
from tmpc.lang.reader import parse_source
from tmpc.lang.sexpr import Packed
from tmpc.lang.source import SourceFile

#: every shape `:init` and `:objects` may hold, plain or not, right or wrong (20+ entries each,
#: so they pack)
ODD = """(define (problem odd) (:domain big-logistics)
  (:objects c1 c2 - city l1 L2 l3 "s" ?v :k - location -5 t1 - truck p1 p2 p3 p4 p5 p6 p7 p8
            p9 p10 p11 - (either package truck) p12 - package q1 q2 - - bad)
  (:init (in-city l1 c1) (IN-CITY L2 c2) (at p1 l1) (at p2 nowhere) (at p3 c1) (at p4)
    (= (weight p1) 3) (= (weight p2) -2.5e1) (= (weight) 1) (= (weight p3) x) (= p1 p2)
    (not (at p5 l1)) (at ?x l1) (at p6 :k) (at p7 "l1") (at (p8) l1) () x "str" (unknown a b)
    (route t1 l1 L2) (road l1 l3) (delivered p9) (delivered p10) ; a comment
    (at p11 l3) (at p12 l3) (weight p1) (= (weight p4) 7) (at p1 l1)   (delivered q1))
  (:goal (and (delivered p1) (at p2 l1) (not (at p3 l1)) (= p1 p2) (< (weight p1) 3) (?x)
    (and (delivered p2)) (delivered ?v) (unknown a) (at p4 :k) ("s") () (or (delivered p5))
    (delivered p6) (AT p7 L2) (at p8) (exists (?p - package) (delivered ?p)) (delivered p9)
    (= (weight p1) 3) (:goal) (delivered p10 p11) (route t1 l1 l3) (at t1 l1))))
"""


def _nodes(x, out):
    """Every node of an AST or s-expression value with its span, in order."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        out.append((type(x).__name__, getattr(x, "span", None)))
        for f in dataclasses.fields(x):
            _nodes(getattr(x, f.name), out)
    elif isinstance(x, (tuple, list, Packed, InitFacts, TypedNames)):
        out.append(("seq", len(x)))
        for y in x:
            _nodes(y, out)
    else:
        out.append(x)
    return out


def _parse(text: str, packed: bool, monkeypatch):
    monkeypatch.setattr(sexpr, "PACK_AT", 16 if packed else 10**9)
    return parse_source(SourceFile("/p/problem.pddl", text))


@pytest.mark.parametrize("text", [ODD, large_problem(20_000)], ids=["odd", "generated"])
def test_columns_read_as_the_tree(text, monkeypatch):
    plain, packed = _parse(text, False, monkeypatch), _parse(text, True, monkeypatch)
    problem = packed.definitions[0]
    assert isinstance(problem.init, InitFacts) and isinstance(problem.objects, TypedNames)
    if text is ODD:
        assert isinstance(problem.goal.parts, InitFacts)
    assert _nodes(packed.sexpr.items, []) == _nodes(plain.sexpr.items, [])
    assert _nodes(packed.definitions, []) == _nodes(plain.definitions, [])
    assert packed.definitions == plain.definitions and plain.definitions == packed.definitions
    assert packed.diagnostics == plain.diagnostics
    assert format_doc(packed.sexpr) == format_doc(plain.sexpr)


def test_columns_check_as_the_tree(tmp_path, monkeypatch):
    (tmp_path / "domain.pddl").write_text(logistics_domain())
    (tmp_path / "problem.pddl").write_text(ODD)
    files = [tmp_path / "domain.pddl", tmp_path / "problem.pddl"]
    packed = check_paths(files).diagnostics
    monkeypatch.setattr(sexpr, "PACK_AT", 10**9)
    plain = check_paths(files).diagnostics
    assert [d.code for d in packed] == [d.code for d in plain]
    assert packed == plain and len(plain) > 10


@pytest.mark.parametrize("path", pddl_files("classical", "legacy", "tmpc", "bad") +
                         sorted(EXAMPLES.rglob("*.pddl")), ids=str)
def test_corpus_reads_the_same_packed(path: Path, monkeypatch):
    text = path.read_text()
    plain, packed = _parse(text, False, monkeypatch), _parse(text, True, monkeypatch)
    assert _nodes(packed.definitions, []) == _nodes(plain.definitions, [])
    assert packed.diagnostics == plain.diagnostics


def test_packed_init_equality_compares_values_not_layout(monkeypatch):
    def init(facts: str):
        text = f"(define (problem q) (:domain d) (:init {facts * 20}))"
        return _parse(text, True, monkeypatch).definitions[0].init
    a, b = init("(= (weight p1) 3) (at p1 l1) "), init("(= (WEIGHT p1)   3.0)\n(at p1 l1)")
    assert isinstance(a, InitFacts) and isinstance(b, InitFacts)
    assert a != b                                       # `WEIGHT` is spelled differently
    assert init("(= (weight p1) 3) (at p1 l1) ") == init("(= (weight p1) 3.0)\n(at  p1 l1)")
    assert init("(at p1 l1) ") != init("(at p1 l2) ")
    assert init("(at p1 l1) ") == tuple(init("(at p1 l1) "))
    assert init("(at p1 l1) ") != init("(at p1 ?l) ")       # packed against built
