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
from dataclasses import dataclass

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


@dataclass
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
    def format(self) -> str:
        lines = self.children(self.doc.items, None, 0, len(self.text), 0)
        out = "\n".join(ln.render() for ln in lines).strip("\n")
        return out + "\n" if out else ""

    def children(self, groups, first_line_end, start: int, end: int, indent: int,
                 trail: int = 0) -> list[_Line]:
        """Lines of ``groups`` (one per line at ``indent``) with their comments and blank lines.

        ``trail``: closing brackets the parent appends to the last line (counted in the width).
        """
        lines: list[_Line] = []
        entries = self._entries(groups, first_line_end, start, end)
        for k, (kind, payload, blank) in enumerate(entries):
            if blank and lines:
                lines.append(_Line(0, ""))
            if kind == "comment":
                lines.append(_Line(indent, "", payload.text.rstrip()))
                continue
            group, trailing = payload
            sub = self.node_group(group, indent, trail if k == len(entries) - 1 else 0)
            if trailing is not None:
                sub[-1].comment = trailing.text.rstrip()
            lines += sub
        return lines

    # ---- comments and blank lines between items ------------------------------------------
    def _comments_between(self, start: int, end: int) -> list[Comment]:
        i = bisect.bisect_left(self.starts, start)
        j = bisect.bisect_left(self.starts, end)
        return self.comments[i:j]

    def _line(self, pos: int) -> int:
        return self.doc.source.line_col(pos)[0]

    def _entries(self, groups, first_line_end: int | None, start: int, end: int) -> list:
        """Interleave groups with the comments between them.

        Returns (``"comment"``, Comment, blank_before) and (``"node"``, (group, trailing), blank)
        items; a comment on the line where the previous group ends trails that group.
        """
        out: list = []
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
                    out.append(("comment", c, self._blank(prev_end, c.span.start, out)))
                prev_end = c.span.end

        for group in groups:
            g_start, g_end = _first(group).span.start, _last(group).span.end
            take_comments(g_start)
            out.append(("node", (group, None), self._blank(prev_end, g_start, out)))
            prev_end, prev_line = g_end, self._line(max(g_start, g_end - 1))
        take_comments(end)
        return out

    def _blank(self, a: int, b: int, out: list) -> bool:
        return bool(out) and self.text.count("\n", a, b) >= 2

    # ---- nodes -----------------------------------------------------------------------------
    def node_group(self, group, indent: int, trail: int = 0) -> list[_Line]:
        """A node, a `:key value` pair or a typed group, starting a line at ``indent``."""
        if not isinstance(group, tuple):
            return self.node(group, indent, indent, trail)
        flat = [self.flat(n) for n in group]
        if all(f is not None for f in flat) and \
                indent + sum(len(f) + 1 for f in flat) - 1 + trail <= WIDTH:
            return [_Line(indent, " ".join(flat))]
        if any(f is None for f in flat[:-1]):
            return [ln for i, n in enumerate(group)
                    for ln in self.node(n, indent, indent, trail if i == len(group) - 1 else 0)]
        lead = " ".join(flat[:-1])
        rest = self.node(group[-1], indent + len(lead) + 1, indent, trail)
        rest[0] = _Line(indent, lead + " " + rest[0].code, rest[0].comment)
        return rest

    def node(self, x: SExpr, col: int, indent: int, trail: int = 0) -> list[_Line]:
        if isinstance(x, SAtom):
            return [_Line(indent, self.atom_text(x, head_pos=False))]
        flat = self.flat(x)
        if flat is not None and col + len(flat) + trail <= WIDTH and head(x) not in ALWAYS_BREAK:
            return [_Line(indent, flat)]
        return self.broken(x, col, indent, trail)

    def broken(self, x: SList, col: int, indent: int, trail: int = 0) -> list[_Line]:
        """``x`` over several lines; it starts at column ``col``, its children at indent + 2."""
        h = head(x)
        items = list(x.items)
        n_head = self._header_size(x, h, col)
        header = [self.atom_text(it, head_pos=True) if i == 0 and isinstance(it, SAtom)
                  else self.flat(it) for i, it in enumerate(items[:n_head])]
        first_end = items[n_head - 1].span.end if n_head else x.span.start + 1
        end = x.close.start if x.close else x.span.end
        groups = self.group(items[n_head:], h)
        if n_head and len(groups) == 1 and isinstance(groups[0], SList) and (h or "")[:1] == ":" \
                and h not in ALWAYS_BREAK and not self._comments_between(first_end, end):
            # a section's single child hangs on the opening line: `(:goal (and` ... `))`
            lead = "(" + " ".join(header) + " "
            lines = self.node(groups[0], col + len(lead), indent, trail + 1)
            # multi-line children hang only in sections without a header (`:goal`); a helper's
            # body (`:define (sig) body`) hangs only when it fits on the line.
            if col + len(lead) + len(lines[0].code) <= WIDTH and \
                    (len(lines) == 1 or not HEADER.get(h or "", 0)):
                lines[0] = _Line(indent, lead + lines[0].code, lines[0].comment)
                lines[-1].code += ")"
                return lines
        if groups and all(isinstance(g, SAtom) for g in groups) and \
                not self._comments_between(first_end, end):
            return self.filled(header, groups, indent, trail)
        body = self.children(groups, first_end, first_end, end, indent + INDENT, trail + 1)
        lines = [_Line(indent, "(" + " ".join(header))]
        # a comment on the opening line trails it
        if body and body[0].code == "" and body[0].comment is not None and \
                self._line(first_end) == self._comment_line(body[0]):
            lines[0].comment = body.pop(0).comment
        lines += body
        if lines[-1].comment is not None and len(lines) > 1:
            # a comment inside the list ends the last line: `)` goes below it, so the comment
            # stays inside the list and a second `fmt` changes nothing
            lines.append(_Line(indent, ")"))
        else:
            lines[-1].code += ")"
        return lines

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

    def filled(self, header: list[str], atoms: list[SAtom], indent: int, trail: int):
        """Only atoms after the header: as many per line as fit (`:requirements`, long lists)."""
        lines = [_Line(indent, "(" + " ".join(header))]
        cur = _Line(indent + INDENT, "")
        for i, a in enumerate(atoms):
            word = self.atom_text(a, head_pos=False)
            extra = trail + 1 if i == len(atoms) - 1 else 0
            if cur.code and cur.indent + len(cur.code) + 1 + len(word) + extra > WIDTH:
                lines.append(cur)
                cur = _Line(indent + INDENT, "")
            cur.code = f"{cur.code} {word}" if cur.code else word
        lines.append(cur)
        lines[-1].code += ")"
        return lines

    def _comment_line(self, line: _Line) -> int:
        for c in self.comments:
            if c.text.rstrip() == line.comment:
                return self._line(c.span.start)
        return -1

    def group(self, items: list[SExpr], h: str | None) -> list:
        """Keep `:key value` pairs and typed groups together as tuples."""
        if h in TYPED_SECTIONS or (h or "").startswith("?"):
            return [run for g in _typed_groups(items) for run in self._split_at_comments(g)]
        out: list = []
        i = 0
        while i < len(items):
            it = items[i]
            if is_keyword(it) and i + 1 < len(items) and not is_keyword(items[i + 1]) and \
                    not self._comments_between(it.span.end, items[i + 1].span.start):
                out.append((it, items[i + 1]))
                i += 2
                continue
            out.append(it)
            i += 1
        return out

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


def _typed_groups(items: list[SExpr]) -> list:
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
