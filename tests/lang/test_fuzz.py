"""Robustness: mutated inputs only ever produce diagnostics (never another exception), and the
formatter never changes the meaning of a file that parses."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.support import EXAMPLES, FIXTURES, STDLIB, check
from tmpc.lang.formatter import format_doc
from tmpc.lang.reader import parse_source
from tmpc.lang.source import SourceFile

SEEDS = [p.read_text() for p in sorted(EXAMPLES.rglob("*.pddl"))] + \
    [p.read_text() for p in sorted(STDLIB.glob("*.tmpc"))] + \
    [p.read_text() for p in sorted(FIXTURES.rglob("*.pddl"))[:40]]

TOKENS = ["(", ")", ")", "(", " ", "\n", ";", '"', "-", "?x", ":effect", ":precondition",
          "(and", "(not", "(forall (?y)", "- object", "-objs", ":semantics", "(<= 1", "(let ((?a 1))",
          "(if", ":kinematic", "(link ?m ?x)", "(define", "(:action a", "1e309", "\t", "\r\n",
          "(either a b)", "(:include \"tmpc/geometry\")", "\x00", "é", "(:derived (p ?x)", "?"]


@st.composite
def mutated(draw):
    text = draw(st.sampled_from(SEEDS))
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.integers(0, 2))
        pos = draw(st.integers(0, len(text)))
        if op == 0:      # delete a span
            end = min(len(text), pos + draw(st.integers(1, 20)))
            text = text[:pos] + text[end:]
        elif op == 1:    # insert a token
            text = text[:pos] + draw(st.sampled_from(TOKENS)) + text[pos:]
        else:            # duplicate a span
            end = min(len(text), pos + draw(st.integers(1, 40)))
            text = text[:pos] + text[pos:end] + text[pos:]
    return text


SETTINGS = settings(max_examples=300, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@SETTINGS
@given(mutated())
def test_parser_and_checker_only_return_diagnostics(text):
    report = check(text)          # any exception other than a returned diagnostic fails
    for d in report.diagnostics:
        assert d.code and d.message
        if d.span is not None and d.span.path == "test.pddl":
            assert 0 <= d.span.start <= d.span.end <= len(text)


@SETTINGS
@given(mutated())
def test_format_preserves_meaning_whenever_it_parses(text):
    parsed = parse_source(SourceFile("f.pddl", text))
    if not parsed.ok:
        return
    out = format_doc(parsed.sexpr)
    again = parse_source(SourceFile("f.pddl", out))
    assert again.ok and again.definitions == parsed.definitions
    assert format_doc(again.sexpr) == out


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=300))
def test_arbitrary_text(text):
    check(text)


def test_seed_corpus_is_loaded():
    assert len(SEEDS) >= 3 and all(isinstance(s, str) for s in SEEDS)
    assert Path(EXAMPLES).is_dir()


def _same_parse(text: str) -> None:
    from tmpc.lang.sexpr import parse_sexpr, parse_sexpr_lark
    src = SourceFile("t.pddl", text)
    fast, ref = parse_sexpr(src), parse_sexpr_lark(src)
    assert (fast.items, fast.comments) == (ref.items, ref.comments)
    # the same diagnostics (the fast path gives them in text order, the grammar's builder in
    # the order it closes lists)
    assert sorted((d.span.start, d.code, d.message) for d in fast.diagnostics) == \
        sorted((d.span.start, d.code, d.message) for d in ref.diagnostics)


def test_the_fast_sexpr_path_equals_the_lark_grammar_on_the_corpus():
    for text in SEEDS:
        _same_parse(text)


@SETTINGS
@given(mutated())
def test_the_fast_sexpr_path_equals_the_lark_grammar_on_mutations(text):
    _same_parse(text)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.text(alphabet=st.sampled_from('() "\\;\n\t\u00a0\u2028ab?-:é🤖'), max_size=80))
def test_the_fast_sexpr_path_equals_the_lark_grammar_on_token_soup(text):
    _same_parse(text)
