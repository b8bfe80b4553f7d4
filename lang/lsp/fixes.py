"""Quick fixes for diagnostics: did-you-mean replacements, a missing requirement, and declaring
an unknown predicate, type or object where the file declares them."""

from __future__ import annotations

import re

from lsprotocol import types as T

from tmpc.lang.lsp.convert import position, uri
from tmpc.lang.reader_common import head
from tmpc.lang.sexpr import SList, parse_sexpr
from tmpc.lang.source import SourceFile

_DID_YOU_MEAN = re.compile(r"did you mean `([^`]+)`\?")
_ADD_REQ = re.compile(r"add `(:[\w-]+)` to the domain's `:requirements`")
_NAME = re.compile(r"`([^`]+)`")


def quick_fixes(diag: T.Diagnostic, path: str, src: SourceFile,
                domain: tuple[str, SourceFile] | None) -> list[T.CodeAction]:
    """Fixes for one diagnostic of ``path``; ``domain`` is the domain file checked with it
    (where declarations go when the diagnostic is in a problem)."""
    data = diag.data if isinstance(diag.data, dict) else {}
    code, hint = data.get("code") or diag.code, data.get("hint") or ""
    out: list[T.CodeAction] = []
    m = _DID_YOU_MEAN.search(hint)
    if m:
        out.append(_action(f"Change to `{m.group(1)}`", diag, path,
                           [T.TextEdit(range=diag.range, new_text=m.group(1))], preferred=True))
    m = _ADD_REQ.search(hint)
    if code == "W001" and m:
        edit = _add_to_section(src, ":requirements", m.group(1))
        if edit is not None:
            out.append(_action(f"Add `{m.group(1)}` to :requirements", diag, path, [edit]))
    name = _first_name(diag.message)
    target = domain if domain is not None else (path, src)
    if code == "E200" and name:
        arity = _arity(src, diag)
        params = " ".join(f"?x{i + 1}" for i in range(arity))
        edit = _add_to_section(target[1], ":predicates", f"({name}{' ' if params else ''}{params})")
        if edit is not None:
            out.append(_action(f"Declare predicate `{name}`", diag, target[0], [edit]))
    if code == "W012" and name:
        edit = _add_to_section(target[1], ":types", name)
        if edit is not None:
            out.append(_action(f"Declare type `{name}`", diag, target[0], [edit]))
    if code == "E206" and name:
        section = ":objects" if _has_section(src, ":objects") else ":constants"
        where = (path, src) if section == ":objects" else target
        edit = _add_to_section(where[1], section, name)
        if edit is not None:
            out.append(_action(f"Declare `{name}` in {section}", diag, where[0], [edit]))
    return out


def _action(title, diag, path, edits, preferred=False) -> T.CodeAction:
    return T.CodeAction(title=title, kind=T.CodeActionKind.QuickFix, diagnostics=[diag],
                        is_preferred=preferred or None,
                        edit=T.WorkspaceEdit(changes={uri(path): edits}))


def _first_name(message: str) -> str | None:
    m = _NAME.search(message)
    return m.group(1) if m else None


def _define(src: SourceFile) -> SList | None:
    """The file's first ``(define ...)``."""
    return next((top for top in parse_sexpr(src).items
                 if isinstance(top, SList) and head(top) == "define"), None)


def _sections(define: SList | None):
    for sec in define.items[2:] if define is not None else ():
        if isinstance(sec, SList):
            yield head(sec), sec


def _has_section(src: SourceFile, key: str) -> bool:
    return any(h == key for h, _ in _sections(_define(src)))


def _add_to_section(src: SourceFile, key: str, text: str) -> T.TextEdit | None:
    """Insert ``text`` before the ``)`` of the file's ``(KEY ...)`` section, or add the section
    after the definition's header when there is none."""
    define = _define(src)
    for h, sec in _sections(define):
        if h == key and sec.close is not None:
            at = position(src, sec.close.start)
            sep = "\n    " if key == ":predicates" else " "
            return T.TextEdit(range=T.Range(start=at, end=at), new_text=sep + text)
    if define is not None and len(define.items) > 1:
        at = position(src, define.items[1].span.end)
        return T.TextEdit(range=T.Range(start=at, end=at), new_text=f"\n  ({key} {text})")
    return None


def _arity(src: SourceFile, diag: T.Diagnostic) -> int:
    """How many arguments the atom whose name the diagnostic marks has."""
    start = src.lsp_offset(diag.range.start.line, diag.range.start.character)
    depth, i, n = 0, start, 0
    text = src.text
    in_word = False
    while i < len(text):
        c = text[i]
        if c == "(":
            depth += 1
        elif c == ")":
            if depth == 0:
                break
            depth -= 1
        if depth == 0:
            if c.isspace():
                in_word = False
            elif not in_word and c != ")":
                in_word = True
                n += 1
        i += 1
    return max(n - 1, 0)
