"""What crosses the worker's process boundary besides plain results: diagnostics as JSON.

A diagnostic is ``{"code", "severity", "message", "hint", "path", "start", "end", "related":
[{"path", "start", "end", "label"}]}``: ``start``/``end`` are the 0-based character offsets of
its :class:`~tmpc.lang.source.Span` (``path``, ``start`` and ``end`` are null when it has none).
The language server turns offsets into LSP positions against the text it holds.
"""

from __future__ import annotations

from tmpc.lang.diagnostics import Diagnostic
from tmpc.lang.source import Span


def diagnostic_to_json(d: Diagnostic) -> dict:
    """``d`` in the worker's JSON form (see the module docstring)."""
    return {"code": d.code, "severity": d.severity.value, "message": d.message, "hint": d.hint,
            **_span(d.span),
            "related": [{**_span(r.span), "label": r.label} for r in d.related]}


def _span(span: Span | None) -> dict:
    if span is None:
        return {"path": None, "start": None, "end": None}
    return {"path": str(span.path), "start": span.start, "end": span.end}
