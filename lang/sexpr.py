"""Level 1 of the parser: text -> s-expression tree with spans, comments and recovery.

The grammar is ``sexpr.lark`` (Lark, LALR, built once per process). Well-formed text takes the
fast path: one LALR parse with an inline transformer. When the brackets do not balance, the token
stream is repaired before parsing, guided by indentation (the way people lay out PDDL):

* a missing ``)`` is placed before the first line whose ``(`` is indented no deeper than a list
  that is still open (a sibling cannot start inside its elder sibling);
* an extra ``)`` is the last ``)`` before a line indented deeper than its siblings.

Each repair is reported as a diagnostic at the place the user must edit, with the opening bracket
as a related location, so a file yields all its errors and a usable partial tree.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache

from lark import Lark, Token
from lark.exceptions import UnexpectedInput

from tmpc.lang.diagnostics import Diagnostic, Related, error
from tmpc.lang.source import SourceFile, Span


@dataclass(frozen=True, slots=True)
class SAtom:
    """A token: ``kind`` is ``symbol`` or ``string``. ``text`` is as written."""

    text: str
    kind: str
    span: Span

    @property
    def lower(self) -> str:
        return self.text.lower()


@dataclass(frozen=True, slots=True)
class SList:
    """A bracketed list. ``closed``: its ``)`` is written (False: it was missing, repaired).
    The span of that ``)`` is derived (:attr:`close`), not stored: a large problem has a list
    per fact, and a span and its two positions cost ~110 bytes each."""

    items: tuple["SExpr", ...]
    span: Span
    closed: bool = False

    @property
    def close(self) -> Span | None:
        """The span of the list's ``)``, its last character (None when it was missing)."""
        return Span(self.span.path, self.span.end - 1, self.span.end) if self.closed else None


SExpr = SAtom | SList


@dataclass(frozen=True, slots=True)
class Comment:
    text: str
    span: Span


@dataclass
class SexprDoc:
    source: SourceFile
    items: list[SExpr]
    comments: list[Comment]
    diagnostics: list[Diagnostic] = field(default_factory=list)


_KIND = {"SYMBOL": "symbol", "STRING": "string"}


#: Comments seen by the lexer during the current parse (the lexer callback appends here).
_comment_sink: list[Token] = []


def _collect_comment(tok: Token) -> Token:
    _comment_sink.append(tok)
    return tok


@lru_cache(maxsize=1)
def _parser() -> Lark:
    return Lark.open_from_package("tmpc.lang", "sexpr.lark", parser="lalr", lexer="basic",
                                  maybe_placeholders=False, cache=True,
                                  lexer_callbacks={"COMMENT": _collect_comment})


def _unterminated(span: Span) -> Diagnostic:
    return error("E003", "unterminated string: this `\"` has no closing `\"` on its line", span,
                 "close the string, or remove the quote")


class _Builder:
    """Turns Lark tokens into SAtom/SList without an intermediate tree."""

    def __init__(self, path: str):
        self.path = path
        self.bad: list[Diagnostic] = []

    def bad_token(self, tok: Token) -> None:
        self.bad.append(_unterminated(Span(self.path, tok.start_pos, tok.end_pos)))

    def atom(self, tok: Token) -> SAtom:
        return SAtom(str(tok), _KIND[tok.type], Span(self.path, tok.start_pos, tok.end_pos))

    def build(self, tree) -> list[SExpr]:
        """Iterative conversion (deep nesting must not hit the recursion limit)."""
        result: dict[int, SExpr] = {}
        stack = [(tree, False)]
        while stack:
            node, done = stack.pop()
            if not done:
                stack.append((node, True))
                stack.extend((c, False) for c in node.children if not isinstance(c, Token))
                continue
            kids = []
            for c in node.children:
                if isinstance(c, Token):
                    if c.type == "BADCHAR":
                        self.bad_token(c)
                    elif c.type in _KIND:
                        kids.append(self.atom(c))
                    else:
                        kids.append(c)
                else:
                    kids.append(result.pop(id(c)))
            if node.data == "list":
                lpar, rpar = kids[0], kids[-1]
                inner = tuple(k for k in kids[1:-1])
                virtual = isinstance(rpar, _VirtualRpar)
                end = rpar.end_pos if not virtual else (inner[-1].span.end if inner else lpar.end_pos)
                result[id(node)] = SList(inner, Span(self.path, lpar.start_pos, end), not virtual)
            else:
                result[id(node)] = kids  # type: ignore[assignment]
        return list(result.pop(id(tree)))


def _lex(text: str) -> tuple[list[Token], list[Token]]:
    """All tokens and the comments separately (the lexer never fails: BADCHAR catches `"`)."""
    tokens, comments = [], []
    for tok in _parser().lex(text, dont_ignore=True):
        if tok.type == "COMMENT":
            comments.append(tok)
        elif tok.type != "WS":
            tokens.append(tok)
    return tokens, comments


#: the deepest nesting of parentheses the reader accepts (E004 beyond it; this level parses any
#: depth, but the reader, checker and formatter recurse per level; real domains stay under 20)
MAX_DEPTH = 100
_BRACKETS = re.compile(r'\\.|[()";\n]')


def too_deep(text: str) -> int | None:
    """The offset of the first ``(`` nested deeper than :data:`MAX_DEPTH` (comments and strings
    skipped), or None."""
    depth, in_comment, in_string = 0, False, False
    for m in _BRACKETS.finditer(text):
        c = m.group()
        if in_comment:
            in_comment = c != "\n"
        elif in_string:
            in_string = c not in ('"', "\n")
        elif c == ";":
            in_comment = True
        elif c == '"':
            in_string = True
        else:
            c = c[-1]
            if c == "(":
                depth += 1
                if depth > MAX_DEPTH:
                    return m.end() - 1
            elif c == ")":
                depth = max(0, depth - 1)
    return None


def depth_error(source: SourceFile) -> Diagnostic | None:
    """E004 at the first ``(`` nested deeper than :data:`MAX_DEPTH`, or None."""
    deep = too_deep(source.text)
    if deep is None:
        return None
    return error("E004", f"parentheses nested deeper than {MAX_DEPTH} levels",
                 Span(source.path, deep, deep + 1),
                 "split the expression (a helper, or an `and` of flatter parts)")


def parse_sexpr(source: SourceFile) -> SexprDoc:
    """Parse a whole file. Never raises for bad input: problems become diagnostics."""
    fast = _scan(source)
    if fast is not None:
        return fast
    return parse_sexpr_lark(source)


#: the grammar's tokens (sexpr.lark) as one alternation, in the lexer's priority order: blank,
#: comment, brackets, string (priority 2 over the bare quote), bare quote, symbol
_TOKEN = re.compile(r'(\s+)|(;[^\n]*)|(\()|(\))|("(?:\\.|[^"\\\n])*")|(")|([^\s()";]+)')


def _scan(source: SourceFile) -> SexprDoc | None:
    """The fast path of well-formed text: the grammar's tokens by one regular expression and the
    lists by a stack (about 4x faster than the LALR parse; the language server re-parses on
    every edit). None when the brackets do not balance: :func:`parse_sexpr_lark` repairs them.
    Its result equals :func:`parse_sexpr_lark`'s (tested on the corpus and by hypothesis)."""
    text, path = source.text, source.path
    stack: list[list] = [[]]
    opens: list[int] = []
    comments, bad = [], []
    # one string per distinct symbol: a large problem names the same objects and predicates
    # hundreds of thousands of times (a 5 MB :init, 250k facts: ~35 MB less)
    symbols: dict[str, str] = {}
    for m in _TOKEN.finditer(text):
        group = m.lastindex
        if group == 1:
            continue
        start, end = m.span()
        if group == 3:
            stack.append([])
            opens.append(start)
        elif group == 4:
            if not opens:
                return None
            items = stack.pop()
            stack[-1].append(SList(tuple(items), Span(path, opens.pop(), end), True))
        elif group == 7:
            word = m.group()
            stack[-1].append(SAtom(symbols.setdefault(word, word), "symbol",
                                   Span(path, start, end)))
        elif group == 2:
            comments.append(Comment(m.group(), Span(path, start, end)))
        elif group == 5:
            stack[-1].append(SAtom(m.group(), "string", Span(path, start, end)))
        else:
            bad.append(_unterminated(Span(path, start, end)))
    if opens:
        return None
    return SexprDoc(source, stack[0], comments, bad)


def parse_sexpr_lark(source: SourceFile) -> SexprDoc:
    """:func:`parse_sexpr` by the LALR grammar (``sexpr.lark``), with bracket repair: the
    reference the fast path is tested against, and the path of unbalanced text."""
    text, path = source.text, source.path
    builder = _Builder(path)
    _comment_sink.clear()
    try:
        tree = _parser().parse(text)      # the fast path: one pass, comments via the callback
        comments = [Comment(str(t), Span(path, t.start_pos, t.end_pos)) for t in _comment_sink]
        return SexprDoc(source, builder.build(tree), comments, builder.bad)
    except UnexpectedInput:
        pass
    finally:
        _comment_sink.clear()
    tokens, comment_toks = _lex(text)
    comments = [Comment(str(t), Span(path, t.start_pos, t.end_pos)) for t in comment_toks]
    fixed, diags = _repair(tokens, source)
    tree = _parse_tokens(fixed)
    items = builder.build(tree)
    return SexprDoc(source, items, comments, diags + builder.bad)


def _parse_tokens(tokens: list[Token]):
    ip = _parser().parse_interactive("")
    for tok in tokens:
        ip.feed_token(tok)
    return ip.feed_eof()


# --------------------------------------------------------------------------------------------
# Bracket repair


@dataclass
class _Open:
    tok: Token
    indent: int            # indentation (0-based column) of the line the list opens on
    child_col: int | None = None   # column of its first direct child that starts a line


def _line_starts(tokens: list[Token]) -> list[bool]:
    starts, prev_line = [], 0
    for t in tokens:
        starts.append(t.line != prev_line)
        prev_line = t.line
    return starts


def _balance(tokens: list[Token]) -> tuple[int, int]:
    """(unclosed opens at the end, unmatched closes)."""
    depth = surplus = 0
    for t in tokens:
        if t.type == "LPAR":
            depth += 1
        elif t.type == "RPAR":
            if depth:
                depth -= 1
            else:
                surplus += 1
    return depth, surplus


class _VirtualRpar(Token):
    """A `)` the repair inserted (it has no place in the text)."""


def _virtual_rpar(at: Token) -> Token:
    return _VirtualRpar("RPAR", ")", at.start_pos, at.line, at.column, at.end_line,
                        at.end_column, at.start_pos)


def _indent_of(tok: Token, line_indent: dict[int, int]) -> int:
    return line_indent.get(tok.line, tok.column - 1)


def _repair(tokens: list[Token], source: SourceFile) -> tuple[list[Token], list[Diagnostic]]:
    deficit, surplus = _balance(tokens)
    diags: list[Diagnostic] = []
    for _ in range(surplus):
        idx = _find_extra_close(tokens)
        if idx is None:
            break
        diags.append(_extra_close_diag(tokens[idx], source, guessed=True))
        tokens = tokens[:idx] + tokens[idx + 1:]
    out: list[Token] = []
    stack: list[_Open] = []
    line_indent: dict[int, int] = {}
    starts = _line_starts(tokens)
    remaining_deficit = _balance(tokens)[0]
    for tok, first in zip(tokens, starts):
        col = tok.column - 1
        if first:
            line_indent[tok.line] = col
            starts_item = tok.type == "LPAR" or (tok.type == "SYMBOL" and tok.startswith(":"))
            while (remaining_deficit and starts_item and len(stack) > 1
                   and stack[-1].indent >= col):
                opened = stack.pop()
                out.append(_virtual_rpar(tok))
                diags.append(_missing_close_diag(opened.tok, out[-2], source))
                remaining_deficit -= 1
        if tok.type == "LPAR":
            stack.append(_Open(tok, _indent_of(tok, line_indent)))
        elif tok.type == "RPAR":
            if not stack:
                diags.append(_extra_close_diag(tok, source, guessed=False))
                continue
            stack.pop()
        out.append(tok)
    while stack:
        opened = stack.pop()
        last = out[-1]
        out.append(_virtual_rpar(last))
        diags.append(_missing_close_diag(opened.tok, last, source, at_eof=True))
    return out, diags


def _find_extra_close(tokens: list[Token]) -> int | None:
    """Index of the `)` that most likely is one too many, by indentation; else the first unmatched.

    A line that starts deeper than the first line-starting child of the innermost open list (or
    than the first top-level form) right after a `)` means that `)` closed something too early.
    """
    root = _Open(Token("LPAR", "("), -1)
    stack: list[_Open] = [root]
    line_indent: dict[int, int] = {}
    prev_close: int | None = None
    for i, (tok, first) in enumerate(zip(tokens, _line_starts(tokens))):
        col = tok.column - 1
        if first:
            line_indent[tok.line] = col
            top = stack[-1]
            if top.child_col is None:
                top.child_col = col
            elif col > top.child_col and prev_close is not None and prev_close == i - 1:
                return prev_close
        if tok.type == "LPAR":
            stack.append(_Open(tok, _indent_of(tok, line_indent)))
        elif tok.type == "RPAR":
            if len(stack) == 1:
                return i
            stack.pop()
            prev_close = i
    return None


def _extra_close_diag(tok: Token, source: SourceFile, guessed: bool) -> Diagnostic:
    span = Span(source.path, tok.start_pos, tok.end_pos)
    if guessed:
        return error("E002", "unexpected `)`: this closes a list too early",
                     span, hint="the next line is indented as if it were still inside the list; "
                     "remove this `)` (or fix the indentation)")
    return error("E002", "unexpected `)` with no matching `(`", span, hint="remove this `)`")


def _missing_close_diag(opener: Token, last: Token, source: SourceFile,
                        at_eof: bool = False) -> Diagnostic:
    head = source.text[opener.end_pos:opener.end_pos + 40].split()
    what = f"`({head[0]}`" if head and "(" not in head[0] else "`(`"
    what = what.replace(")", "")
    open_span = Span(source.path, opener.start_pos, opener.end_pos)
    # right after the last token (a zero-width span at the very end of the file)
    at = Span(source.path, last.end_pos, min(last.end_pos + 1, len(source.text)))
    where = "at the end of the file" if at_eof else "here"
    line, col = source.line_col(opener.start_pos)
    return error("E001", f"missing `)`: the list {what} opened at {line}:{col} is not closed",
                 at, hint=f"add `)` {where} to close it",
                 related=[Related(open_span, "unclosed list opens here")])
