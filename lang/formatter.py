"""`tmpc fmt`: canonical layout of PDDL / tmpc files, comments kept.

Works on the s-expression tree (not the AST) so comments and the user's spelling of names survive;
only layout and keyword case change. A list is printed on one line when it fits in
:data:`WIDTH` columns and holds no comment; otherwise it breaks with its children indented by two,
keeping ``:key value`` pairs and ``name - type`` groups together. One blank line between items is
kept where the source had one or more. The property tests check ``parse(fmt(x)) == parse(x)`` and
``fmt(fmt(x)) == fmt(x)``.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from itertools import chain
from typing import Any

from tmpc.lang.reader_common import head, is_keyword, sym
from tmpc.lang.sexpr import Comment, SAtom, SExpr, SexprDoc, SList

WIDTH = 100
INDENT = 2
#: Reserved PDDL words printed in lower case when they head a list.
RESERVED_HEADS = frozenset({"define", "domain", "problem", "module", "and", "or", "not", "imply",
                            "forall", "exists", "when", "either", "increase", "decrease",
                            "assign", "scale-up", "scale-down"})
#: Sections that always break (one child per line).
ALWAYS_BREAK = frozenset({"define", ":predicates", ":init", ":action", ":derived", ":functions"})
#: How many items after the head stay on the first line when a list breaks.
HEADER = {"define": 1, ":action": 1, ":derived": 1, ":define": 1, "forall": 1, "exists": 1,
          "let": 1, "when": 1, "if": 1, ":metric": 1}
#: Sections / values that are typed lists (break by `name... - type` group).
TYPED_SECTIONS = frozenset({":types", ":objects", ":constants"})


@dataclass(slots=True)
class _Line:
    """One output line: absolute indentation, code, and an optional trailing `;` comment."""

    indent: int
    code: str
    comment: str | None = None

    def render(self) -> str:
        parts = [self.code] if self.code else []
        if self.comment is not None:
            parts.append(self.comment)
        return (" " * self.indent + " ".join(parts)).rstrip() if parts else ""


class Formatter:
    def __init__(self, doc: SexprDoc):
        self.doc = doc
        self.text = doc.source.text
        self.comments = doc.comments
        self.starts = [c.span.start for c in doc.comments]

    # ---- entry ---------------------------------------------------------------------------
    # Lines are produced lazily, one at a time (generators), and the text in chunks: a large
    # problem's `:init` is never a list of lines, nor of its facts.
    def format(self) -> str:
        return "".join(self.chunks())

    def chunks(self, lines_per_chunk: int = 4096) -> Iterator[str]:
        """The formatted text in pieces of a few thousand lines (blank lines at both ends
        dropped, a newline at the end)."""
        lines = self.children(self.doc.items, None, 0, len(self.text), 0)
        buf: list[str] = []
        blanks, started = 0, False
        for ln in lines:
            r = ln.render()
            if not r:
                blanks += started
                continue
            if blanks:
                buf.append("\n" * blanks)
                blanks = 0
            buf.append(r)
            buf.append("\n")
            started = True
            if len(buf) >= 2 * lines_per_chunk:
                yield "".join(buf)
                buf = []
        if buf:
            yield "".join(buf)

    def children(self, groups, first_line_end, start: int, end: int, indent: int,
                 trail: int = 0) -> Iterator[_Line]:
        """Lines of ``groups`` (one per line at ``indent``) with their comments and blank lines.

        ``trail``: closing brackets the parent appends to the last line (counted in the width).
        """
        emitted = False
        for (kind, payload, blank), last in _with_last(self._entries(groups, first_line_end,
                                                                     start, end)):
            if blank and emitted:
                yield _Line(0, "")
            if kind == "comment":
                emitted = True
                yield _Line(indent, "", payload.text.rstrip())
                continue
            group, trailing = payload
            sub = self.node_group(group, indent, trail if last else 0)
            if trailing is not None:
                sub = _on_last(sub, lambda ln, c=trailing.text.rstrip(): setattr(ln, "comment", c))
            for ln in sub:
                emitted = True
                yield ln

    # ---- comments and blank lines between items ------------------------------------------
    def _comments_between(self, start: int, end: int) -> list[Comment]:
        i = bisect.bisect_left(self.starts, start)
        j = bisect.bisect_left(self.starts, end)
        return self.comments[i:j]

    def _line(self, pos: int) -> int:
        return self.doc.source.line_col(pos)[0]

    def _entries(self, groups, first_line_end: int | None, start: int, end: int) -> Iterator:
        """Interleave groups with the comments between them.

        Yields (``"comment"``, Comment, blank_before) and (``"node"``, (group, trailing), blank)
        items; a comment on the line where the previous group ends trails that group. Only the
        last entry can still change (a trailing comment), so the others are yielded as soon as
        the next one is known.
        """
        out: list = []
        shown = False                   # entries before ``out`` were yielded already
        prev_end = start
        prev_line = self._line(first_line_end) if first_line_end is not None else None

        def take_comments(upto: int) -> None:
            nonlocal prev_end
            for c in self._comments_between(prev_end, upto):
                last = out[-1] if out else None
                if prev_line is not None and self._line(c.span.start) == prev_line and \
                        last is not None and last[0] == "node" and last[1][1] is None:
                    out[-1] = ("node", (last[1][0], c), last[2])
                else:
                    out.append(("comment", c, self._blank(prev_end, c.span.start,
                                                          shown or bool(out))))
                prev_end = c.span.end

        for group in groups:
            g_start, g_end = _first(group).span.start, _last(group).span.end
            take_comments(g_start)
            out.append(("node", (group, None), self._blank(prev_end, g_start, shown or bool(out))))
            prev_end, prev_line = g_end, self._line(max(g_start, g_end - 1))
            if len(out) > 1:
                yield from out[:-1]
                del out[:-1]
                shown = True
        take_comments(end)
        yield from out

    def _blank(self, a: int, b: int, after: bool) -> bool:
        return after and self.text.count("\n", a, b) >= 2

    # ---- nodes -----------------------------------------------------------------------------
    def node_group(self, group, indent: int, trail: int = 0) -> Iterator[_Line]:
        """A node, a `:key value` pair or a typed group, starting a line at ``indent``."""
        if not isinstance(group, tuple):
            yield from self.node(group, indent, indent, trail)
            return
        flat = [self.flat(n) for n in group]
        if all(f is not None for f in flat) and \
                indent + sum(len(f) + 1 for f in flat) - 1 + trail <= WIDTH:
            yield _Line(indent, " ".join(flat))
            return
        if any(f is None for f in flat[:-1]):
            for i, n in enumerate(group):
                yield from self.node(n, indent, indent, trail if i == len(group) - 1 else 0)
            return
        lead = " ".join(flat[:-1])
        rest = self.node(group[-1], indent + len(lead) + 1, indent, trail)
        first = next(rest)
        yield _Line(indent, lead + " " + first.code, first.comment)
        yield from rest

    def node(self, x: SExpr, col: int, indent: int, trail: int = 0) -> Iterator[_Line]:
        if isinstance(x, SAtom):
            return iter((_Line(indent, self.atom_text(x, head_pos=False)),))
        if head(x) not in ALWAYS_BREAK:
            flat = self.flat(x)
            if flat is not None and col + len(flat) + trail <= WIDTH:
                return iter((_Line(indent, flat),))
        return self.broken(x, col, indent, trail)

    def broken(self, x: SList, col: int, indent: int, trail: int = 0) -> Iterator[_Line]:
        """``x`` over several lines; it starts at column ``col``, its children at indent + 2."""
        h = head(x)
        items = x.items
        n_head = self._header_size(x, h, col)
        header = [self.atom_text(it, head_pos=True) if i == 0 and isinstance(it, SAtom)
                  else self.flat(it) for i, it in enumerate(items[:n_head])]
        first_end = items[n_head - 1].span.end if n_head else x.span.start + 1
        end = x.close.start if x.close else x.span.end
        rest = items[n_head:]
        if h in TYPED_SECTIONS or (h or "").startswith("?"):
            rest = list(self.group(rest, h))      # typed groups, computed once
            h_rest = _GROUPED
        else:
            h_rest = h
        groups = iter(self.group(rest, h_rest))
        g0, g1 = next(groups, None), next(groups, None)
        if n_head and g0 is not None and g1 is None and isinstance(g0, SList) and \
                (h or "")[:1] == ":" and h not in ALWAYS_BREAK and \
                not self._comments_between(first_end, end):
            # a section's single child hangs on the opening line: `(:goal (and` ... `))`
            lead = "(" + " ".join(header) + " "
            lines = self.node(g0, col + len(lead), indent, trail + 1)
            l0, l1 = next(lines), next(lines, None)
            # multi-line children hang only in sections without a header (`:goal`); a helper's
            # body (`:define (sig) body`) hangs only when it fits on the line.
            if col + len(lead) + len(l0.code) <= WIDTH and \
                    (l1 is None or not HEADER.get(h or "", 0)):
                l0 = _Line(indent, lead + l0.code, l0.comment)
                more = (l0,) if l1 is None else (l0, l1)
                yield from _on_last(chain(more, lines), _close)
                return
        if g0 is not None and all(isinstance(g, SAtom) for g in self.group(rest, h_rest)) and \
                not self._comments_between(first_end, end):
            yield from self.filled(header, self.group(rest, h_rest), indent, trail)
            return
        body = self.children(self.group(rest, h_rest), first_end, first_end, end,
                             indent + INDENT, trail + 1)
        opening = _Line(indent, "(" + " ".join(header))
        # a comment on the opening line trails it
        b0 = next(body, None)
        if b0 is not None and b0.code == "" and b0.comment is not None and \
                self._line(first_end) == self._comment_line(b0):
            opening.comment = b0.comment
            b0 = next(body, None)
        last = opening
        for ln in chain((b0,) if b0 is not None else (), body):
            yield last
            last = ln
        if last.comment is not None and last is not opening:
            # a comment inside the list ends the last line: `)` goes below it, so the comment
            # stays inside the list and a second `fmt` changes nothing
            yield last
            yield _Line(indent, ")")
        else:
            last.code += ")"
            yield last

    def _header_size(self, x: SList, h: str | None, col: int) -> int:
        """Items kept on the opening line: the head and HEADER[h] more, but none after a comment,
        none that is multi-line and none past the width. Parameter lists have no header."""
        items = x.items
        if not items or not isinstance(items[0], SAtom) or (h or "").startswith("?"):
            return 0
        n = 1 + HEADER.get(h or "", 0)
        if h and not h.startswith(":") and h not in HEADER and h not in RESERVED_HEADS:
            # a declaration's name and its parameters stay on the opening line:
            # `(reach ?g - gripper ?c - cube` then `:semantics ...` below
            while n < len(items) and isinstance(items[n], SAtom) and not is_keyword(items[n]):
                n += 1
        width = col + 1
        for i, it in enumerate(items[:n]):
            f = self.flat(it)
            width += (len(f) + 1) if f is not None else 0
            if f is None or self._comments_between(x.span.start, it.span.end) or \
                    (i and width > WIDTH):
                return i
        return min(n, len(items))

    def filled(self, header: list[str], atoms: Iterable[SAtom], indent: int,
               trail: int) -> Iterator[_Line]:
        """Only atoms after the header: as many per line as fit (`:requirements`, long lists)."""
        yield _Line(indent, "(" + " ".join(header))
        cur = _Line(indent + INDENT, "")
        for a, last in _with_last(atoms):
            word = self.atom_text(a, head_pos=False)
            extra = trail + 1 if last else 0
            if cur.code and cur.indent + len(cur.code) + 1 + len(word) + extra > WIDTH:
                yield cur
                cur = _Line(indent + INDENT, "")
            cur.code = f"{cur.code} {word}" if cur.code else word
        cur.code += ")"
        yield cur

    def _comment_line(self, line: _Line) -> int:
        for c in self.comments:
            if c.text.rstrip() == line.comment:
                return self._line(c.span.start)
        return -1

    def group(self, items, h: str | None) -> Iterator:
        """Keep `:key value` pairs and typed groups together as tuples (lazily: ``items`` may
        be a large packed list)."""
        if h is _GROUPED:
            yield from items
            return
        if h in TYPED_SECTIONS or (h or "").startswith("?"):
            for g in _typed_groups(items):
                yield from self._split_at_comments(g)
            return
        it = iter(items)
        x = next(it, None)
        while x is not None:
            y = next(it, None)
            if y is not None and is_keyword(x) and not is_keyword(y) and \
                    not self._comments_between(x.span.end, y.span.start):
                yield (x, y)
                x = next(it, None)
                continue
            yield x
            x = y

    def _split_at_comments(self, group) -> list:
        """A group with comments between its items becomes runs, so no comment is lost."""
        if not isinstance(group, tuple):
            return [group]
        runs, cur = [], [group[0]]
        for prev, it in zip(group, group[1:]):
            if self._comments_between(prev.span.end, it.span.start):
                runs.append(tuple(cur) if len(cur) > 1 else cur[0])
                cur = []
            cur.append(it)
        runs.append(tuple(cur) if len(cur) > 1 else cur[0])
        return runs

    # ---- flat rendering --------------------------------------------------------------------
    def flat(self, x: SExpr) -> str | None:
        """One-line text of ``x``, or None if it contains a comment."""
        if isinstance(x, SAtom):
            return self.atom_text(x, head_pos=False)
        if self._comments_between(x.span.start, x.span.end):
            return None
        parts = []
        for i, it in enumerate(x.items):
            if isinstance(it, SAtom):
                parts.append(self.atom_text(it, head_pos=i == 0))
            else:
                f = self.flat(it)
                if f is None:
                    return None
                parts.append(f)
        return "(" + " ".join(parts) + ")"

    @staticmethod
    def atom_text(x: SAtom, head_pos: bool) -> str:
        if x.kind != "symbol":
            return x.text
        low = x.text.lower()
        if low.startswith(":") or (head_pos and low in RESERVED_HEADS) or \
                low in ("minimize", "maximize"):
            return low
        return x.text


def _with_last(items: Iterable) -> Iterator[tuple]:
    """``(item, is_last)`` for each item."""
    it = iter(items)
    prev = next(it, _NONE)
    if prev is _NONE:
        return
    for x in it:
        yield prev, False
        prev = x
    yield prev, True


_NONE = object()
#: :meth:`Formatter.group` of items that are groups already
_GROUPED: Any = object()


def _on_last(lines: Iterable[_Line], change) -> Iterator[_Line]:
    """``lines`` with ``change`` applied to the last one."""
    for ln, last in _with_last(lines):
        if last:
            change(ln)
        yield ln


def _close(ln: _Line) -> None:
    ln.code += ")"


def _typed_groups(items) -> list:
    out, cur = [], []
    i = 0
    while i < len(items):
        it = items[i]
        cur.append(it)
        if isinstance(it, SAtom) and it.kind == "symbol" and it.text.startswith("-"):
            if it.text == "-" and i + 1 < len(items):
                cur.append(items[i + 1])
                i += 1
            out.append(tuple(cur) if len(cur) > 1 else cur[0])
            cur = []
        i += 1
    if cur:
        out.append(tuple(cur) if len(cur) > 1 else cur[0])
    return out


def _first(group) -> SExpr:
    return group[0] if isinstance(group, tuple) else group


def _last(group) -> SExpr:
    return group[-1] if isinstance(group, tuple) else group


def format_doc(doc: SexprDoc) -> str:
    return Formatter(doc).format()


__all__ = ["format_doc", "WIDTH", "sym"]
