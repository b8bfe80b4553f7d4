"""tmpc positions and diagnostics -> LSP types. Every offset <-> position conversion goes through
:meth:`tmpc.lang.source.SourceFile.lsp_position` / :meth:`~tmpc.lang.source.SourceFile.lsp_offset`
(UTF-16 code units)."""

from __future__ import annotations

from lsprotocol import types as T
from pygls.uris import from_fs_path

from tmpc.lang.diagnostics import Diagnostic, Severity
from tmpc.lang.source import SourceFile, Span

_SEVERITY = {Severity.ERROR: T.DiagnosticSeverity.Error,
             Severity.WARNING: T.DiagnosticSeverity.Warning,
             Severity.NOTE: T.DiagnosticSeverity.Information}


def position(src: SourceFile, offset: int) -> T.Position:
    line, ch = src.lsp_position(offset)
    return T.Position(line=line, character=ch)


def to_range(src: SourceFile, start: int, end: int) -> T.Range:
    return T.Range(start=position(src, start), end=position(src, end))


def span_range(src: SourceFile | None, span: Span | None) -> T.Range:
    if src is None or span is None:
        return T.Range(start=T.Position(line=0, character=0), end=T.Position(line=0, character=0))
    return to_range(src, span.start, span.end)


def offset(src: SourceFile, pos: T.Position) -> int:
    return src.lsp_offset(pos.line, pos.character)


def uri(path: str) -> str:
    return from_fs_path(path) or path


def diagnostic(d: Diagnostic, files: dict[str, SourceFile], norm) -> T.Diagnostic:
    """``files`` maps normalised paths to sources; ``norm`` normalises a span's path."""
    src = files.get(norm(d.span.path)) if d.span is not None else None
    related = []
    for r in d.related:
        rsrc = files.get(norm(r.span.path)) if r.span is not None else None
        if rsrc is not None:
            related.append(T.DiagnosticRelatedInformation(
                location=T.Location(uri=uri(norm(r.span.path)), range=span_range(rsrc, r.span)),
                message=r.label))
    message = d.message + (f"\nhint: {d.hint}" if d.hint else "")
    return T.Diagnostic(range=span_range(src, d.span), message=message,
                        severity=_SEVERITY[d.severity], code=d.code, source="tmpc",
                        related_information=related or None,
                        data={"code": d.code, "hint": d.hint})
