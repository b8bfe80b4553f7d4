"""Level 1: s-expressions, spans, comments, bracket repair."""

from __future__ import annotations

import pytest

from tmpc.lang.sexpr import SList, parse_sexpr
from tmpc.lang.source import SourceFile


def parse(text: str):
    return parse_sexpr(SourceFile("t.pddl", text))


def loc(doc, diag):
    return doc.source.line_col(diag.span.start)


def test_atoms_lists_spans_and_comments():
    doc = parse('(a ?b :c "s" -1.5e3) ; tail\n; full line\n(x)')
    assert not doc.diagnostics
    first = doc.items[0]
    assert isinstance(first, SList)
    assert [a.text for a in first.items] == ["a", "?b", ":c", '"s"', "-1.5e3"]
    assert [a.kind for a in first.items] == ["symbol"] * 3 + ["string", "symbol"]
    assert doc.source.text[first.span.start:first.span.end] == '(a ?b :c "s" -1.5e3)'
    assert first.close is not None and doc.source.text[first.close.start] == ")"
    assert [c.text for c in doc.comments] == ["; tail", "; full line"]
    assert doc.source.line_col(doc.items[1].span.start) == (3, 1)


def test_crlf_tabs_and_bom_are_whitespace(tmp_path):
    p = tmp_path / "f.pddl"
    p.write_bytes(b"\xef\xbb\xbf(define\r\n\t(domain d))\r\n")
    doc = parse_sexpr(SourceFile.read(p))
    assert not doc.diagnostics
    assert doc.items[0].items[1].items[1].text == "d"


def test_missing_paren_is_reported_where_it_belongs():
    text = ("(define (domain d)\n"
            "  (:action a\n"
            "    :parameters ()\n"
            "    :effect (and (p))\n"          # `)` of the action missing here
            "  (:action b\n"
            "    :parameters ()\n"
            "    :effect (and (p))))\n")
    doc = parse(text)
    assert [d.code for d in doc.diagnostics] == ["E001"]
    d = doc.diagnostics[0]
    assert loc(doc, d) == (4, 22)                       # right after `(and (p))`
    assert doc.source.line_col(d.related[0].span.start) == (2, 3)   # the unclosed `(:action`
    # recovery: both actions are siblings inside define again
    define = doc.items[0]
    assert [it.items[1].text for it in define.items[2:]] == ["a", "b"]


def test_missing_paren_at_end_of_file():
    doc = parse("(define (domain d)\n  (:predicates (p))\n")
    assert [d.code for d in doc.diagnostics] == ["E001"]
    assert "end of the file" in doc.diagnostics[0].hint
    assert len(doc.items) == 1


def test_extra_paren_found_by_indentation():
    text = ("(define (domain d)\n"
            "  (:action a\n"
            "    :precondition (p))\n"        # extra `)` closes the action early
            "    :effect (q))\n"
            "  (:action b :effect (q)))\n")
    doc = parse(text)
    assert [d.code for d in doc.diagnostics] == ["E002"]
    assert loc(doc, doc.diagnostics[0]) == (3, 22)
    define = doc.items[0]
    assert [it.items[1].text for it in define.items[2:]] == ["a", "b"]


def test_unmatched_close_at_top_level():
    doc = parse("(a))")
    assert [d.code for d in doc.diagnostics] == ["E002"]
    assert loc(doc, doc.diagnostics[0]) == (1, 4)


def test_unterminated_string_is_reported_and_dropped():
    doc = parse('(a "oops)\n')
    assert [d.code for d in doc.diagnostics] == ["E003"]
    assert loc(doc, doc.diagnostics[0]) == (1, 4)
    assert [it.text for it in doc.items[0].items] == ["a", "oops"]


def test_deep_nesting_does_not_hit_recursion_limit():
    depth = 5000
    doc = parse("(" * depth + "x" + ")" * depth)
    assert not doc.diagnostics
    node, n = doc.items[0], 1
    while isinstance(node, SList) and node.items and isinstance(node.items[0], SList):
        node, n = node.items[0], n + 1
    assert n == depth


@pytest.mark.parametrize("text", ["", "   \n", "; only a comment\n"])
def test_empty_inputs(text):
    doc = parse(text)
    assert doc.items == [] and not doc.diagnostics


def test_lsp_positions_are_zero_based():
    src = SourceFile("t", "ab\ncd")
    assert src.line_col(3) == (2, 1)
    assert src.lsp_position(3) == (1, 0)
    assert src.offset(2, 2) == 4


def test_a_large_problem_keeps_one_string_per_name_and_no_close_spans():
    """A 5 MB :init (250k facts) took 417 MB to check (L 5): the tree now shares one string
    per distinct symbol and derives a list's `)` span instead of storing one per list; both
    parse paths (fast and repairing) agree on it."""
    from tmpc.lang.sexpr import parse_sexpr_lark
    src = SourceFile("p.pddl", "(:init (on b1 b2) (on b1 b3) (on b2 b1))")
    for doc in (parse_sexpr(src), parse_sexpr_lark(src)):
        facts = doc.items[0].items[1:]
        assert facts[0].items[1].text == "b1" and facts[0].span.end == 17
        assert "close" not in SList.__slots__ and facts[0].close.start == 16
    fast = parse_sexpr(src).items[0].items[1:]
    assert fast[0].items[0].text is fast[2].items[0].text                 # one "on"
    assert fast[0].items[1].text is fast[1].items[1].text is fast[2].items[2].text
    unclosed = parse_sexpr(SourceFile("q.pddl", "(:init (on b1 b2)"))
    assert unclosed.items[0].close is None and unclosed.items[0].items[1].close is not None


def test_reading_pauses_the_cyclic_collector():
    """The collector walked the growing tree again and again: two thirds of a large problem's
    parse (L 5). It is paused while a file is read, and left as it was after."""
    import gc

    from tmpc.lang import reader
    seen = []
    real = reader.parse_sexpr
    try:
        reader.parse_sexpr = lambda source: (seen.append(gc.isenabled()), real(source))[1]
        assert gc.isenabled()
        reader.parse_text("(define (domain d))")
        assert seen == [False] and gc.isenabled()
        gc.disable()
        reader.parse_text("(define (domain d))")
        assert not gc.isenabled()
    finally:
        gc.enable()
        reader.parse_sexpr = real
