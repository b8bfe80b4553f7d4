"""The diagnostic sink: repeats dropped in constant time (a list scan made `check` quadratic in
the number of errors: 8,000 errors took 10 s), order kept, rewrites keep the bookkeeping."""

from __future__ import annotations

from tmpc.lang.diagnostics import Diagnostic, DiagnosticSink, error, warning
from tmpc.lang.source import Span


def test_repeats_are_dropped_without_scanning_the_list(monkeypatch):
    diags = [error("E200", f"unknown predicate `q{i}`", Span("f.pddl", i, i + 1))
             for i in range(3000)]
    calls = 0
    eq = Diagnostic.__eq__

    def counting(a, b):
        nonlocal calls
        calls += 1
        return eq(a, b)
    monkeypatch.setattr(Diagnostic, "__eq__", counting)
    sink = DiagnosticSink()
    sink.extend(diags + diags[:10])
    compared = calls
    monkeypatch.undo()
    assert compared < 200, compared              # a list scan would compare ~4.5 million times
    assert sink.items == diags                   # in order, the ten repeats dropped


def test_errors_are_counted_through_rewrites():
    sink = DiagnosticSink([warning("W002", "unused", None)])
    assert not sink.has_errors
    sink.add(error("E200", "x", None))
    assert sink.has_errors
    sink.rewrite_from(1, lambda d: warning("W002", d.message + " (now a warning)", None))
    assert not sink.has_errors and [d.message for d in sink.items] == ["unused",
                                                                       "x (now a warning)"]
