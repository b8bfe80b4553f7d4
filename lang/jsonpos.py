"""JSON with positions: plain Python values plus a span for every value and member key.

Scene files and problem specs are JSON; a semantic error found later (a quaternion that is not a
unit, an unknown parent) must point at the value that caused it. :func:`parse_json` returns the
values exactly as :func:`json.loads` would (dict, list, str, int, float, bool, None) together with
two maps keyed by JSON pointer (RFC 6901, e.g. ``/objects/3/pose/rotation``; the document itself
is ``""``): the span of each value and the span of each object member's key.

The grammar is ``json.lark`` (Lark, LALR, built once per process); an inline transformer builds
the values while the parser runs, so no parse tree is materialised. Syntax errors become a
:class:`~tmpc.lang.diagnostics.SceneError` with code E500 and the position of the offending token.
A key given twice in one object is E500 too (JSON allows it, but the second silently wins).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from tmpc.lang.diagnostics import Related, SceneError, error
from tmpc.lang.source import SourceFile, Span

__all__ = ["JsonDoc", "parse_json", "pointer", "escape_pointer"]


def escape_pointer(key: str) -> str:
    """One reference token of a JSON pointer: ``~`` -> ``~0``, ``/`` -> ``~1``."""
    return key.replace("~", "~0").replace("/", "~1")


def pointer(*parts: str | int) -> str:
    """``pointer("objects", 3, "pose")`` -> ``"/objects/3/pose"``."""
    return "".join("/" + escape_pointer(str(p)) for p in parts)


@dataclass(frozen=True, slots=True)
class JsonDoc:
    """A parsed JSON document: ``value`` plus spans by JSON pointer."""

    source: SourceFile
    value: Any
    #: pointer -> span of the value (for containers: from the opening to the closing bracket)
    spans: dict[str, Span]
    #: pointer of an object member -> span of its key (with the quotes)
    key_spans: dict[str, Span]

    def span(self, ptr: str) -> Span:
        """Span of the value at ``ptr``, else of its nearest ancestor that exists."""
        while ptr not in self.spans and ptr:
            ptr = ptr.rsplit("/", 1)[0]
        return self.spans[ptr]

    def key_span(self, ptr: str) -> Span:
        """Span of the member key at ``ptr`` (the value's span for array items and the root)."""
        return self.key_spans.get(ptr) or self.span(ptr)


# A node while building: (value, start, end, kids). kids is None for scalars, a list of nodes
# for arrays and a list of (key, key_start, key_end, node) for objects.
_Node = tuple


class _Fault(Exception):
    """A syntax problem found in a callback (positions only; parse_json adds the file)."""

    def __init__(self, message: str, start: int, end: int, hint: str,
                 related: tuple[int, int] | None = None):
        super().__init__(message)
        self.message, self.start, self.end, self.hint, self.related = (message, start, end, hint,
                                                                       related)


class _Build(Transformer):
    """Inline LALR callbacks: each rule becomes a node as soon as it is reduced."""

    def __init__(self):
        super().__init__(visit_tokens=False)

    def string(self, children: list[Token]) -> _Node:
        tok = children[0]
        return (_decode(tok), tok.start_pos, tok.end_pos, None)

    def number(self, children: list[Token]) -> _Node:
        tok = children[0]
        text = str(tok)
        value = float(text) if ("." in text or "e" in text or "E" in text) else int(text)
        return (value, tok.start_pos, tok.end_pos, None)

    def literal(self, children: list[Token]) -> _Node:
        tok = children[0]
        return (_LITERALS[tok.type], tok.start_pos, tok.end_pos, None)

    def member(self, children: list) -> tuple:
        key_tok, node = children
        return (_decode(key_tok), key_tok.start_pos, key_tok.end_pos, node)

    def object(self, children: list) -> _Node:
        members = [m for m in children[1:-1] if m is not None]
        value: dict[str, Any] = {}
        for key, ks, ke, node in members:
            if key in value:
                first = next(m for m in members if m[0] == key)
                raise _Fault(f"key \"{key}\" given twice in one object", ks, ke,
                             "remove one of them (JSON readers keep only the last)",
                             (first[1], first[2]))
            value[key] = node[0]
        return (value, children[0].start_pos, children[-1].end_pos, members)

    def array(self, children: list) -> _Node:
        items = [c for c in children[1:-1] if c is not None]
        return ([n[0] for n in items], children[0].start_pos, children[-1].end_pos, items)


_LITERALS = {"TRUE": True, "FALSE": False, "NULL": None}


def _name(path: str) -> str:
    return path.replace("\\", "/").rsplit("/", 1)[-1] or path


def _decode(tok: Token) -> str:
    try:
        return json.loads(tok)
    except json.JSONDecodeError as exc:
        pos = tok.start_pos + exc.pos
        what = "control character in a string" if "control" in exc.msg else "bad escape in a string"
        raise _Fault(what, pos, pos + 1, "JSON strings allow only the escapes \\\" \\\\ \\/ \\b \\f "
                     "\\n \\r \\t \\uXXXX; write a tab or newline as \\t or \\n") from None


@lru_cache(maxsize=1)
def _parser() -> Lark:
    # Positions come from the tokens the inline transformer sees (bracket and literal terminals
    # are named so they are kept), so the parser need not propagate them into tree metadata.
    return Lark.open_from_package("tmpc.lang", "json.lark", parser="lalr", lexer="basic",
                                  maybe_placeholders=True, transformer=_Build(), cache=True)


def parse_json(source: SourceFile) -> JsonDoc:
    """Parse ``source`` as JSON. Raises SceneError (E500) on a syntax error."""
    path, text = source.path, source.text
    try:
        root = _parser().parse(text)
    except UnexpectedInput as exc:
        raise SceneError(_syntax_error(exc, source), {path: source}) from None
    except _Fault as f:
        related = [Related(Span(path, *f.related), "first given here")] if f.related else []
        raise SceneError(error("E500", f"{_name(path)}: {f.message}", Span(path, f.start, f.end),
                               f.hint, related), {path: source}) from None
    spans, key_spans = _index(root, path)
    return JsonDoc(source, root[0], spans, key_spans)


def _index(root: _Node, path: str) -> tuple[dict[str, Span], dict[str, Span]]:
    """Walk the node tree top-down (iteratively) and record spans by pointer."""
    spans: dict[str, Span] = {}
    key_spans: dict[str, Span] = {}
    stack = [("", root)]
    while stack:
        ptr, (value, start, end, kids) = stack.pop()
        spans[ptr] = Span(path, start, end)
        if kids is None:
            continue
        if isinstance(value, dict):
            for key, ks, ke, node in kids:
                p = ptr + "/" + (escape_pointer(key) if ("~" in key or "/" in key) else key)
                key_spans[p] = Span(path, ks, ke)
                stack.append((p, node))
        else:
            for i, node in enumerate(kids):
                stack.append((f"{ptr}/{i}", node))
    return spans, key_spans


# --------------------------------------------------------------------------------------------
# Syntax errors

_TERMINAL_TEXT = {
    "LBRACE": "`{`", "RBRACE": "`}`", "LBRACK": "`[`", "RBRACK": "`]`", "COMMA": "`,`",
    "COLON": "`:`", "STRING": "a string", "NUMBER": "a number", "TRUE": "`true`",
    "FALSE": "`false`", "NULL": "`null`", "$END": "the end of the file",
}


def _expected(names) -> str:
    shown = sorted({_TERMINAL_TEXT.get(n, n) for n in names if n in _TERMINAL_TEXT})
    if not shown:
        return "a JSON value"
    if len(shown) > 4 and "a string" in shown and "a number" in shown:
        return "a value"
    return ", ".join(shown[:-1]) + (" or " if len(shown) > 1 else "") + shown[-1]


def _syntax_error(exc: UnexpectedInput, source: SourceFile):
    path, text = source.path, source.text
    name = _name(path)
    if isinstance(exc, UnexpectedCharacters):
        pos = exc.pos_in_stream
        ch = text[pos]
        msg, hint = f"{name}: unexpected character `{ch}`", None
        if ch == '"':
            msg, hint = f"{name}: unterminated string", "close the string with `\"` on the same line"
        elif ch == "'":
            hint = "JSON strings use double quotes: \"like this\""
        elif ch == "/" and text[pos:pos + 2] in ("//", "/*"):
            hint = "JSON has no comments; remove it (or put notes in an extra key)"
        elif ch.isalpha() or ch in "+.":
            word = text[pos:pos + 12].split()[0].rstrip(",]}")
            msg = f"{name}: `{word}` is not a JSON value"
            hint = ("JSON has no NaN/Infinity; numbers are like -1.5e3" if word[:3] in
                    ("NaN", "Inf", "nan", "inf") or word[:1] in "+." else
                    "strings need double quotes; the literals are true, false and null (lower case)")
        return error("E500", msg, Span(path, pos, pos + 1), hint)
    if isinstance(exc, UnexpectedEOF):
        pos = len(text.rstrip())
        return error("E500", f"{name}: unexpected end of file; expected {_expected(exc.expected)}",
                     Span(path, pos, pos), "a bracket is not closed")
    assert isinstance(exc, UnexpectedToken)
    tok = exc.token
    try:        # the exact set for this state (exc.expected can include merged LALR states)
        accepts = exc.interactive_parser.accepts() or exc.expected
    except Exception:   # accepts() runs callbacks on copies; any fault there is not this error
        accepts = exc.expected
    expected = _expected(accepts)
    if tok.type == "$END":
        pos = len(text.rstrip())
        if not text.strip():
            return error("E500", f"{name}: the file is empty; expected a JSON value",
                         Span(path, 0, 0), "a scene or spec is a JSON object: { ... }")
        closer = "`]`" if "RBRACK" in accepts else "`}`" if "RBRACE" in accepts else "a bracket"
        return error("E500", f"{name}: unexpected end of file; expected {expected}",
                     Span(path, pos, pos), f"{closer} is missing at the end")
    span = Span(path, tok.start_pos, tok.end_pos)
    prev = text[:tok.start_pos].rstrip()
    hint = None
    if tok.type in ("RBRACE", "RBRACK") and prev.endswith(","):
        hint = "JSON does not allow a comma before a closing bracket; remove it"
    elif tok.type == "NUMBER" and prev.endswith("0") and text[tok.start_pos - 1] == "0":
        hint = "JSON numbers have no leading zeros: write 1, not 01"
    elif "COMMA" in accepts and tok.type in ("STRING", "NUMBER", "LBRACE", "LBRACK", "TRUE",
                                             "FALSE", "NULL"):
        hint = "a `,` is missing before this"
    elif tok.type in ("RBRACE", "RBRACK") and {"RBRACE", "RBRACK"} & set(accepts):
        hint = "the brackets do not match"
    found = {"STRING": f"string {tok}", "NUMBER": f"number {tok}"}.get(
        tok.type, _TERMINAL_TEXT.get(tok.type, repr(str(tok))))
    return error("E500", f"{name}: unexpected {found}; expected {expected}", span, hint)
