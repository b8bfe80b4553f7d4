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
from array import array
from collections.abc import Sequence
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


class ValueSequence(Sequence):
    """A sequence that compares, hashes and prints as a value (as the tuple it stands for)."""

    __slots__ = ()

    def __eq__(self, other) -> bool:
        if not isinstance(other, Sequence) or isinstance(other, str):
            return NotImplemented
        return len(self) == len(other) and all(a == b for a, b in zip(self, other))

    def __ne__(self, other) -> bool:
        eq = self.__eq__(other)
        return eq if eq is NotImplemented else not eq

    def __hash__(self) -> int:
        return hash(tuple(self))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({len(self)} items)"


class Packed(ValueSequence):
    """The children of a long list (a problem's `:init`, `:objects`, a large goal) as columns
    of tokens instead of objects: an SAtom with its span, and a fact of them, cost many times
    their text; here a token is three small integers. Indexing builds the SAtom/SList on
    demand, equal to the one a tuple would hold; a slice is a view on the same columns.

    Columns: ``sym``, per token, the id of its text in ``names`` (a string's text keeps its
    quotes), or :data:`OPEN` / :data:`CLOSE` for a bracket; ``pos``, its start offset; per child
    ``first``, the index of its first token (one more entry at the end). A child too large to be
    rebuilt on every access (over :data:`MAX_PACKED_CHILD` tokens, or one that holds a packed
    list) is kept as an object in ``others`` instead, with no tokens."""

    __slots__ = ("path", "names", "sym", "pos", "first", "others", "lo", "hi")

    def __init__(self, path: str, names: list[str], offsets: str = "q"):
        """``offsets``: the array type of offsets and token indices (``"I"``, 4 bytes, in a
        text under 4 G characters)."""
        self.path, self.names = path, names
        self.sym, self.pos = array("i"), array(offsets)
        self.first = array(offsets, [0])
        self.others: dict[int, SExpr] = {}
        self.lo, self.hi = 0, 0

    # ---- building (the scanner) ----------------------------------------------------------
    def add(self, x: SExpr, ids: dict[str, int]) -> None:
        """Append a child given as an object (its texts get ids from ``ids``)."""
        mark = len(self.sym)
        if not self._flatten(x, ids):
            del self.sym[mark:]
            del self.pos[mark:]
            self.others[self.hi] = x
        self.end_child()

    def _flatten(self, x: SExpr, ids: dict[str, int]) -> bool:
        if isinstance(x, SAtom):
            sid = ids.get(x.text)
            if sid is None:
                sid = ids[x.text] = len(self.names)
                self.names.append(x.text)
            self.sym.append(sid)
            self.pos.append(x.span.start)
            return True
        if type(x.items) is not tuple or not x.closed:
            return False
        self.sym.append(OPEN)
        self.pos.append(x.span.start)
        for y in x.items:
            if not self._flatten(y, ids):
                return False
        self.sym.append(CLOSE)
        self.pos.append(x.span.end - 1)
        return True

    def end_child(self) -> None:
        """The tokens since the last child make one more child."""
        k, n = self.hi, len(self.sym)
        self.first.append(n)
        self.hi += 1
        if n - self.first[k] > MAX_PACKED_CHILD:
            x = self.at(k)
            del self.sym[self.first[k]:]
            del self.pos[self.first[k]:]
            self.first[k + 1] = self.first[k]
            self.others[k] = x

    # ---- reading -------------------------------------------------------------------------
    def __len__(self) -> int:
        return self.hi - self.lo

    def __getitem__(self, i):
        if isinstance(i, slice):
            lo, hi, step = i.indices(self.hi - self.lo)
            if step != 1:
                return tuple(self[k] for k in range(lo, hi, step))
            view = object.__new__(Packed)
            for k in Packed.__slots__:
                setattr(view, k, getattr(self, k))
            view.lo, view.hi = self.lo + lo, self.lo + max(lo, hi)
            return view
        n = self.hi - self.lo
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(i)
        return self.at(self.lo + i)

    def __iter__(self):
        at = self.at
        for k in range(self.lo, self.hi):
            yield at(k)

    def at(self, k: int) -> SExpr:
        """The child at absolute index ``k`` (the columns' index, not the view's)."""
        t, end = self.first[k], self.first[k + 1]
        if t == end:
            return self.others[k]
        sym, pos, names, path = self.sym, self.pos, self.names, self.path
        if end - t == 1:
            return self.atom(t)
        inner = sym[t + 1:end - 1]
        if not inner or min(inner) >= 0:                  # a list of atoms (a fact)
            return SList(tuple([SAtom(names[s], "string" if names[s][0] == '"' else "symbol",
                                      Span(path, p, p + len(names[s])))
                                for s, p in zip(inner, pos[t + 1:end - 1])]),
                         Span(path, pos[t], pos[end - 1] + 1), True)
        stack: list[list] = []
        opens: list[int] = []
        for i in range(t, end):
            s = sym[i]
            if s == OPEN:
                stack.append([])
                opens.append(pos[i])
            elif s == CLOSE:
                x = SList(tuple(stack.pop()), Span(path, opens.pop(), pos[i] + 1), True)
                if not stack:
                    return x
                stack[-1].append(x)
            else:
                text, start = names[s], pos[i]
                stack[-1].append(SAtom(text, "string" if text[0] == '"' else "symbol",
                                       Span(path, start, start + len(text))))
        raise AssertionError("unbalanced packed child")

    def atom(self, t: int) -> SAtom:
        text, start = self.names[self.sym[t]], self.pos[t]
        return SAtom(text, "string" if text[0] == '"' else "symbol",
                     Span(self.path, start, start + len(text)))

    def start(self, k: int) -> int:
        """The start offset of child ``k`` (absolute index)."""
        t = self.first[k]
        return self.pos[t] if t < self.first[k + 1] else self.others[k].span.start

    def end(self, k: int) -> int:
        """The end offset of child ``k`` (absolute index)."""
        t = self.first[k + 1] - 1
        if t < self.first[k]:
            return self.others[k].span.end
        s = self.sym[t]
        return self.pos[t] + (1 if s == CLOSE else len(self.names[s]))


#: token ids of the brackets in :attr:`Packed.sym`
OPEN, CLOSE = -1, -2
#: a packed child over this many tokens is kept as an object (an action of a large domain)
MAX_PACKED_CHILD = 256
#: a list packs its children once it has this many (short lists stay tuples)
PACK_AT = 16


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
def sexpr_parser() -> Lark:
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
    for tok in sexpr_parser().lex(text, dont_ignore=True):
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
    lists by a stack (cheaper than the LALR parse; the language server re-parses on every
    edit). None when the brackets do not balance: :func:`parse_sexpr_lark` repairs them.
    Its result equals :func:`parse_sexpr_lark`'s (tested on the corpus and by hypothesis)."""
    text, path = source.text, source.path
    stack: list = [[]]          # the children of each open list: a list, or a Packed
    opens: list[int] = []       # where each list of ``stack`` opens
    comments, bad = [], []
    # one string per distinct symbol (a large problem names the same objects and predicates
    # hundreds of thousands of times), and its id in the columns of packed lists
    names: list[str] = []
    ids: dict[str, int] = {}
    offsets = "I" if len(text) < 2 ** 32 else "q"
    # inside a packed list: its columns, and the depth inside its current child
    packed: Packed | None = None
    depth = 0
    for m in _TOKEN.finditer(text):
        group = m.lastindex
        if group == 1:
            continue
        start, end = m.span()
        if group == 7 or group == 5:
            word = m.group()
            sid = ids.get(word)
            if sid is None:
                sid = ids[word] = len(names)
                names.append(word)
            if packed is not None:
                packed.sym.append(sid)
                packed.pos.append(start)
                if not depth:
                    packed.end_child()
                continue
            x = SAtom(names[sid], "symbol" if group == 7 else "string", Span(path, start, end))
        elif group == 3:
            if packed is not None:
                packed.sym.append(OPEN)
                packed.pos.append(start)
                depth += 1
            else:
                stack.append([])
                opens.append(start)
            continue
        elif group == 4:
            if depth:
                packed.sym.append(CLOSE)
                packed.pos.append(start)
                depth -= 1
                if not depth:
                    packed.end_child()
                continue
            if not opens:
                return None
            items = stack.pop()
            packed = None
            x = SList(tuple(items) if type(items) is list else items,
                      Span(path, opens.pop(), end), True)
        elif group == 2:
            comments.append(Comment(m.group(), Span(path, start, end)))
            continue
        else:
            bad.append(_unterminated(Span(path, start, end)))
            continue
        top = stack[-1]
        if type(top) is list:
            top.append(x)
            # sections and deeper (`:init`, `:objects`, a goal's `and`), not the top level nor
            # a `define`'s children (a large domain's actions are read whole anyway)
            if len(top) >= PACK_AT and len(stack) > 2:
                packed = Packed(path, names, offsets)
                for y in top:
                    packed.add(y, ids)
                stack[-1] = packed
        else:
            top.add(x, ids)
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
        tree = sexpr_parser().parse(text)      # the fast path: one pass, comments via the callback
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
    ip = sexpr_parser().parse_interactive("")
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


def _visual_columns(tokens: list[Token], source: SourceFile) -> list[int]:
    """Each token's 0-based column as an editor shows it: a tab moves to the next multiple of 8
    (a line indented with a tab is deeper than one indented with four spaces)."""
    lines = source.text.split("\n")
    out = []
    for tok in tokens:
        line = lines[tok.line - 1] if 0 < tok.line <= len(lines) else ""
        prefix = line[:tok.column - 1]
        out.append(len(prefix.expandtabs(8)) if "\t" in prefix else tok.column - 1)
    return out


def _repair(tokens: list[Token], source: SourceFile) -> tuple[list[Token], list[Diagnostic]]:
    deficit, surplus = _balance(tokens)
    diags: list[Diagnostic] = []
    for _ in range(surplus):
        idx = _find_extra_close(tokens, _visual_columns(tokens, source))
        if idx is None:
            break
        diags.append(_extra_close_diag(tokens[idx], source, guessed=True))
        tokens = tokens[:idx] + tokens[idx + 1:]
    out: list[Token] = []
    stack: list[_Open] = []
    line_indent: dict[int, int] = {}
    starts = _line_starts(tokens)
    remaining_deficit = _balance(tokens)[0]
    for tok, first, col in zip(tokens, starts, _visual_columns(tokens, source)):
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


def _find_extra_close(tokens: list[Token], cols: list[int]) -> int | None:
    """Index of the `)` that most likely is one too many, by indentation; else the first unmatched.

    A line that starts deeper than the first line-starting child of the innermost open list (or
    than the first top-level form) right after a `)` means that `)` closed something too early.
    """
    root = _Open(Token("LPAR", "("), -1)
    stack: list[_Open] = [root]
    line_indent: dict[int, int] = {}
    prev_close: int | None = None
    for i, (tok, first, col) in enumerate(zip(tokens, _line_starts(tokens), cols)):
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
