"""Diagnostics: the one shape every user-facing problem takes.

A :class:`Diagnostic` has a code (``E…`` error, ``W…`` warning), a span, a message, an optional
hint and optional labelled related spans. :func:`render` prints it rustc-style with the source
line and a caret; :func:`to_json` gives the machine form. Every code is one of the vocabulary
:mod:`tmpc.lang.codes` (documented in ``docs/diagnostics.md``): a :class:`Diagnostic` with a code
not in it, or with another severity than the table's (an ``E…`` code made with :func:`warning`),
raises :class:`DiagnosticCodeError`, a bug in tmpc rather than a problem of the user's.

Exceptions (:class:`TmpcError` and subclasses) carry diagnostics for code paths that must stop.
"""

from __future__ import annotations

import json
import os
import re
import sys
from dataclasses import dataclass, field
from enum import Enum
from typing import Iterable, Mapping

from tmpc.lang.codes import CODES
from tmpc.lang.source import SourceFile, Span


class Severity(str, Enum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True, slots=True)
class Related:
    """A secondary location with a short label (e.g. where a name was first defined)."""

    span: Span
    label: str


class DiagnosticCodeError(AssertionError):
    """An internal error: a diagnostic made with a code that is not in :mod:`tmpc.lang.codes`,
    or with a severity other than the one the table gives the code."""


@dataclass(frozen=True, slots=True)
class Diagnostic:
    code: str
    severity: Severity
    message: str
    span: Span | None
    hint: str | None = None
    related: tuple[Related, ...] = ()

    def __post_init__(self) -> None:
        # one dict lookup: a mistyped or undocumented code fails where it is made
        entry = CODES.get(self.code)
        if entry is None:
            raise DiagnosticCodeError(f"diagnostic code {self.code!r} is not in tmpc.lang.codes "
                                      "(add it there and to docs/diagnostics.md)")
        if entry.severity != self.severity:
            made = getattr(self.severity, "value", self.severity)
            raise DiagnosticCodeError(f"diagnostic code {self.code} has severity "
                                      f"{entry.severity!r} in tmpc.lang.codes, made as {made!r}")

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR


def not_utf8(path, exc: UnicodeDecodeError, hint: str) -> tuple["Diagnostic", dict]:
    """E011 at the line:col of the first byte that is not UTF-8, and the file to show it in."""
    span, shown = SourceFile.undecodable(path, exc)
    return error("E011", f"{path} is not UTF-8 text (byte {exc.start}: "
                 f"0x{exc.object[exc.start]:02x})", span, hint), {str(path): shown}


def error(code: str, message: str, span: Span | None, hint: str | None = None,
          related: Iterable[Related] = ()) -> Diagnostic:
    return Diagnostic(code, Severity.ERROR, message, span, hint, tuple(related))


def warning(code: str, message: str, span: Span | None, hint: str | None = None,
            related: Iterable[Related] = ()) -> Diagnostic:
    return Diagnostic(code, Severity.WARNING, message, span, hint, tuple(related))


@dataclass
class DiagnosticSink:
    """Collects diagnostics in order; deduplicates exact repeats."""

    items: list[Diagnostic] = field(default_factory=list)
    #: what ``items`` holds, for constant-time repeats (a list scan is quadratic in the errors)
    _seen: set = field(default_factory=set, repr=False, compare=False)
    _errors: int = field(default=0, repr=False, compare=False)

    def __post_init__(self) -> None:
        items, self.items = self.items, []
        self.extend(items)

    def add(self, diag: Diagnostic) -> None:
        if diag not in self._seen:
            self._seen.add(diag)
            self.items.append(diag)
            self._errors += diag.is_error

    def extend(self, diags: Iterable[Diagnostic]) -> None:
        for d in diags:
            self.add(d)

    def rewrite_from(self, start: int, fn) -> None:
        """Replace every item from ``start`` on by ``fn(item)``."""
        old = self.items[start:]
        del self.items[start:]
        for d in old:
            self._seen.discard(d)
            self._errors -= d.is_error
        self.extend(fn(d) for d in old)

    @property
    def has_errors(self) -> bool:
        return self._errors > 0


class TmpcError(Exception):
    """Base of every error a user can cause. Carries diagnostics; the CLI renders them."""

    exit_code = 1

    def __init__(self, diagnostics: Diagnostic | Iterable[Diagnostic],
                 files: Mapping[str, SourceFile] | None = None):
        if isinstance(diagnostics, Diagnostic):
            diagnostics = [diagnostics]
        self.diagnostics = list(diagnostics)
        #: the source files the spans point into, so the CLI can show the lines
        self.files = dict(files or {})
        super().__init__("; ".join(f"[{d.code}] {d.message}" for d in self.diagnostics))


class ParseError(TmpcError):
    """Syntax errors in a source file."""


class CheckError(TmpcError):
    """A program parsed but is not well-formed (names, types, kinds)."""


class InputError(TmpcError):
    """A file cannot be read, or a command-line input is malformed."""


class SceneError(TmpcError):
    """A scene, robot (URDF), mesh or run configuration is missing or malformed."""


class LuaError(TmpcError):
    """A legacy Lua predicate file fails to load or run (syntax, runtime error, sandbox, limits)."""


# --------------------------------------------------------------------------------------------
# Rendering

_COLORS = {"error": "\x1b[1;31m", "warning": "\x1b[1;33m", "note": "\x1b[1;36m"}
_BOLD, _BLUE, _RESET = "\x1b[1m", "\x1b[1;34m", "\x1b[0m"


def use_color(stream=sys.stderr) -> bool:
    if os.environ.get("NO_COLOR"):
        return False
    return bool(getattr(stream, "isatty", lambda: False)())


def _location(diag: Diagnostic, files: Mapping[str, SourceFile]) -> str:
    if diag.span is None:
        return ""
    src = files.get(diag.span.path)
    if src is None:
        return f"{diag.span.path}: "
    line, col = src.line_col(diag.span.start)
    return f"{diag.span.path}:{line}:{col}: "


#: the widest source excerpt a snippet shows (a long line is cut around the caret)
SNIPPET_WIDTH = 120
#: the longest message shown (a message echoing a huge name is cut in the middle)
MESSAGE_WIDTH = 400
#: control characters and bidirectional overrides, shown as U+FFFD (one column: carets align)
_UNPRINTABLE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u200e\u200f\u202a-\u202e"
                          "\u2066-\u2069]")


def printable(text: str) -> str:
    """``text`` with control characters (NUL, ESC, ...) and bidirectional overrides replaced:
    a diagnostic never moves the terminal's cursor, colours it or reorders what follows."""
    return _UNPRINTABLE.sub("\ufffd", text)


def _clip(text: str, width: int = MESSAGE_WIDTH) -> str:
    if len(text) <= width:
        return text
    half = (width - 5) // 2
    return f"{text[:half]} ... {text[-half:]}"


def _snippet(span: Span, src: SourceFile, label: str, color: bool, mark: str) -> list[str]:
    line, col = src.line_col(span.start)
    end_line, end_col = src.line_col(max(span.start, span.end - 1))
    text = printable(src.line_text(line).replace("\t", " "))
    width = max(1, (end_col - col + 1) if end_line == line else len(text) - col + 1)
    if len(text) > SNIPPET_WIDTH:      # a window around the caret, marked as cut on each side
        start = max(0, min(col - 1 - SNIPPET_WIDTH // 3, len(text) - SNIPPET_WIDTH))
        cut = text[start:start + SNIPPET_WIDTH]
        text = ("..." if start else "") + cut + ("..." if start + SNIPPET_WIDTH < len(text) else "")
        col = col - start + (3 if start else 0)
        width = max(1, min(width, SNIPPET_WIDTH - (col - 1) + (3 if start else 0)))
    gutter = " " * len(str(line))
    b, r = (_BLUE, _RESET) if color else ("", "")
    caret = " " * (col - 1) + mark * width + (f" {label}" if label else "")
    return [f"{gutter} {b}|{r}", f"{b}{line}{r} {b}|{r} {text}", f"{gutter} {b}|{r} {caret}"]


def render(diag: Diagnostic, files: Mapping[str, SourceFile], color: bool = False) -> str:
    """``PATH:LINE:COL: error[CODE]: message`` then the source line, a caret, hint, related."""
    sev = diag.severity.value
    head = f"{_COLORS[sev]}{sev}[{diag.code}]{_RESET}" if color else f"{sev}[{diag.code}]"
    lines = [f"{printable(_location(diag, files))}{head}: {printable(_clip(diag.message))}"]
    src = files.get(diag.span.path) if diag.span else None
    if src is not None and diag.span is not None:
        lines += _snippet(diag.span, src, "", color, "^")
    for rel in diag.related:
        rsrc = files.get(rel.span.path)
        if rsrc is None:
            lines.append(printable(f"  = note: {_clip(rel.label)} ({rel.span.path})"))
            continue
        rline, rcol = rsrc.line_col(rel.span.start)
        lines.append(printable(f"  = note: {_clip(rel.label)} at {rel.span.path}:{rline}:{rcol}"))
        lines += ["  " + s for s in _snippet(rel.span, rsrc, "", color, "-")]
    if diag.hint:
        lines.append(f"  = help: {printable(_clip(diag.hint))}")
    return "\n".join(lines)


def _json_span(span: Span | None, files: Mapping[str, SourceFile]) -> dict | None:
    if span is None:
        return None
    out: dict = {"path": span.path, "start": span.start, "end": span.end}
    src = files.get(span.path)
    if src is not None:
        out["line"], out["column"] = src.line_col(span.start)
        out["end_line"], out["end_column"] = src.line_col(span.end)
    return out


def to_json(diag: Diagnostic, files: Mapping[str, SourceFile]) -> dict:
    return {
        "code": diag.code,
        "severity": diag.severity.value,
        "message": _clip(diag.message),
        "span": _json_span(diag.span, files),
        "hint": diag.hint,
        "related": [{"label": r.label, "span": _json_span(r.span, files)} for r in diag.related],
    }


def render_json(diags: Iterable[Diagnostic], files: Mapping[str, SourceFile]) -> str:
    return json.dumps([to_json(d, files) for d in diags], indent=2)


def sort_key(diag: Diagnostic) -> tuple:
    span = diag.span
    return (span.path, span.start) if span else ("", -1)
