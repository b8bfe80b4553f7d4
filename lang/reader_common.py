"""Shared helpers of the level-2 readers (s-expressions -> AST): token classes, typed lists."""

from __future__ import annotations

import difflib
import re
from typing import Iterable, Sequence

from array import array

from tmpc.lang import ast as A
from tmpc.lang.columns import InitFacts, TypedNames
from tmpc.lang.diagnostics import Diagnostic, DiagnosticSink, error, warning
from tmpc.lang.sexpr import CLOSE, OPEN, Packed, SAtom, SExpr, SList
from tmpc.lang.symbols import NUMERIC_COMPARISONS
from tmpc.lang.source import Span

NUMBER_RE = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\Z")
NAME_RE = re.compile(r"[A-Za-z_@][^\s()\";?]*\Z")


def is_sym(x: SExpr) -> bool:
    return isinstance(x, SAtom) and x.kind == "symbol"


def sym(x: SExpr | None) -> str | None:
    """Lower-cased symbol text, or None if ``x`` is not a symbol."""
    return x.text.lower() if isinstance(x, SAtom) and x.kind == "symbol" else None


def head(x: SExpr) -> str | None:
    """Lower-cased head symbol of a list, or None."""
    if isinstance(x, SList) and x.items:
        return sym(x.items[0])
    return None


def is_var(x: SExpr) -> bool:
    return is_sym(x) and x.text.startswith("?") and len(x.text) > 1


def is_number(x: SExpr) -> bool:
    return is_sym(x) and NUMBER_RE.match(x.text) is not None


def is_keyword(x: SExpr) -> bool:
    return is_sym(x) and x.text.startswith(":")


def suggest(word: str, choices: Iterable[str]) -> str | None:
    """``did you mean `x`?`` text or None."""
    close = difflib.get_close_matches(word.lower(), list(choices), n=1, cutoff=0.6)
    return f"did you mean `{close[0]}`?" if close else None


def describe(x: SExpr) -> str:
    if isinstance(x, SList):
        h = head(x)
        return f"the list `({h} ...)`" if h else "a list"
    if x.kind == "string":
        return f"the string {x.text}"
    return f"`{x.text}`"


class ReaderBase:
    """Diagnostics plus the small readers every section uses."""

    def __init__(self, sink: DiagnosticSink):
        self.sink = sink

    def err(self, code: str, msg: str, span: Span | None, hint: str | None = None, **kw) -> None:
        self.sink.add(error(code, msg, span, hint, **kw))

    def add(self, diag: Diagnostic) -> None:
        self.sink.add(diag)

    # ---- atoms ---------------------------------------------------------------------------
    def name(self, x: SExpr, what: str) -> A.Name | None:
        if is_sym(x) and not is_var(x) and not is_keyword(x):
            return A.Name(x.text, span=x.span)
        self.err("E117", f"expected {what}, found {describe(x)}", x.span)
        return None

    def var(self, x: SExpr, what: str = "a ?variable") -> A.Name | None:
        if is_var(x):
            return A.Name(x.text, span=x.span)
        hint = f"write `?{x.text}`" if is_sym(x) and NAME_RE.match(x.text) else None
        self.err("E118", f"expected {what}, found {describe(x)}", x.span, hint)
        return None

    def term(self, x: SExpr) -> A.Term | None:
        if is_var(x):
            return A.Var(A.Name(x.text, span=x.span), span=x.span)
        if is_sym(x) and not is_keyword(x):
            return A.Const(A.Name(x.text, span=x.span), span=x.span)
        self.err("E117", f"expected an object name or a ?variable, found {describe(x)}", x.span,
                 "atom arguments are names or ?variables; nested lists are not terms")
        return None

    def number(self, x: SExpr) -> A.Num | None:
        if is_number(x):
            return A.Num(float(x.text), x.text, span=x.span)
        self.err("E114", f"expected a number, found {describe(x)}", x.span)
        return None

    # ---- typed lists -----------------------------------------------------------------------
    def typed_list(self, items: Sequence[SExpr], variables: bool, what: str) -> tuple[A.Typed, ...]:
        """``a b - t c - (either t1 t2) d`` (and the legacy glued form ``a b -t``).

        ``variables`` selects ``?x`` entries (parameters) or names (objects, types).
        """
        if not variables and isinstance(items, Packed):
            return self._packed_typed_list(items, what)
        out: list[A.Typed] = []
        pending: list[A.Name] = []
        i, n = 0, len(items)
        while i < n:
            x = items[i]
            if is_sym(x) and x.text.startswith("-") and not is_number(x):
                tref, i = self._type_after_dash(items, i, what)
                if tref is None:
                    if i < 0:
                        break
                    continue
                if not pending:
                    # In parameter lists this is a real mistake (the names after it stay untyped);
                    # in object lists IPC files have it harmlessly (woodworking `- board`).
                    self.sink.add((error if variables else warning)(
                        "E110" if variables else "W009",
                        f"type `{_type_text(tref)}` in {what} follows no name", x.span,
                        "a type comes after the names it types: `?a ?b - type`"))
                for nm in pending:
                    out.append(A.Typed(nm, tref, span=nm.span.cover(x.span)))
                pending = []
                continue
            entry = self._typed_entry(x, variables, what)
            if entry is not None:
                pending.append(entry)
            i += 1
        out.extend(A.Typed(nm, None, span=nm.span) for nm in pending)
        return tuple(out)

    def _type_after_dash(self, items, i: int, what: str) -> tuple[A.TypeRef | None, int]:
        """At the `-` symbol ``items[i]`` of a typed list: (its type, the index after it); or,
        after an E110, (None, the index to go on from), or (None, -1): stop reading."""
        x, n = items[i], len(items)
        glued = x.text[1:]
        if glued:
            return A.TypeRef((A.Name(glued, span=Span(x.span.path, x.span.start + 1,
                                                      x.span.end)),), span=x.span), i + 1
        if i + 1 < n and not is_var(items[i + 1]):
            return self.type_ref(items[i + 1]), i + 2
        if i + 1 < n:
            self.err("E110", f"`-` in {what} must be followed by a type, found "
                     f"`{items[i + 1].text}`", x.span.cover(items[i + 1].span),
                     "write `?x - type`; a ?variable cannot be a type")
            return None, i + 1
        self.err("E110", f"`-` at the end of {what} must be followed by a type",
                 x.span, "write `?x - type` (or remove the `-`)")
        return None, -1

    def _packed_typed_list(self, items: Packed, what: str) -> TypedNames:
        """:meth:`typed_list` of names kept as columns (a large problem's `:objects`): a plain
        name stays the index of its symbol; the rest is read as :meth:`typed_list` reads it."""
        out = TypedNames(items)
        first, sym, names = items.first, items.sym, items.names
        pending = array("q")        # a packed name's index, or -1: the Name in ``named``
        named: dict[int, A.Name] = {}
        plain: dict[int, bool] = {}
        i, n = 0, len(items)
        while i < n:
            k = items.lo + i
            t = first[k]
            if first[k + 1] - t == 1:
                s = sym[t]
                ok = plain.get(s)
                if ok is None:
                    ok = plain[s] = s >= 0 and _plain_name(names[s])
                if ok:
                    pending.append(k)
                    i += 1
                    continue
            x = items[i]
            if is_sym(x) and x.text.startswith("-") and not is_number(x):
                tref, i = self._type_after_dash(items, i, what)
                if tref is None:
                    if i < 0:
                        break
                    continue
                if not pending:
                    self.sink.add(warning("W009", f"type `{_type_text(tref)}` in {what} follows "
                                          "no name", x.span,
                                          "a type comes after the names it types: `?a ?b - type`"))
                self._group(out, pending, named, tref, x.span)
                pending, named = array("q"), {}
                continue
            entry = self._typed_entry(x, False, what)
            if entry is not None:
                named[len(pending)] = entry
                pending.append(-1)
            i += 1
        self._group(out, pending, named, None, None)
        return out

    @staticmethod
    def _group(out: TypedNames, pending, named: dict, tref, dash: Span | None) -> None:
        g = len(out.groups)
        out.groups.append((tref, dash))
        for p, k in enumerate(pending):
            if k >= 0:
                out.add(k, g)
            else:
                nm = named[p]
                out.add_other(A.Typed(nm, tref, span=nm.span.cover(dash) if dash else nm.span))

    def _typed_entry(self, x: SExpr, variables: bool, what: str) -> A.Name | None:
        if variables:
            if is_var(x):
                if "-" in x.text[2:]:
                    self._glued_dash_hint(x)
                return A.Name(x.text, span=x.span)
            return self.var(x, f"a ?variable in {what}")
        if is_sym(x) and not is_var(x) and not is_keyword(x):
            return A.Name(x.text, span=x.span)
        self.err("E117", f"expected a name in {what}, found {describe(x)}", x.span)
        return None

    def _glued_dash_hint(self, x: SAtom) -> None:
        """``?x-stick`` is a legal variable name; remember it so the checker can say more."""
        self.glued_candidates.append(x)

    glued_candidates: list

    def type_ref(self, x: SExpr) -> A.TypeRef:
        if isinstance(x, SList):
            if head(x) == "either" and len(x.items) > 1:
                names = [self.name(t, "a type name") for t in x.items[1:]]
                return A.TypeRef(tuple(n for n in names if n), span=x.span)
            self.err("E110", f"expected a type or `(either ...)`, found {describe(x)}", x.span)
            return A.TypeRef((), span=x.span)
        nm = self.name(x, "a type name after `-`")
        if nm is None and is_sym(x) and x.text == "-":
            return A.TypeRef((), span=x.span)
        return A.TypeRef((nm,) if nm else (), span=x.span)


def _plain_name(text: str) -> bool:
    """A symbol :meth:`ReaderBase.typed_list` reads as a name (not a string, a ``- type``, a
    ?variable or a :keyword)."""
    if text[0] in '"?:':
        return False
    return not text.startswith("-") or NUMBER_RE.match(text) is not None


def _type_text(t: A.TypeRef) -> str:
    if len(t.names) == 1:
        return t.names[0].text
    return "(either " + " ".join(n.text for n in t.names) + ")"


def packed_facts(body: Packed, plain_head, numeric: bool, read) -> InitFacts:
    """The facts of ``body`` (a large `:init`, or a large goal's `and`): a list of plain names
    whose head ``plain_head`` accepts (``numeric``: or `(= (f a b) NUMBER)`) stays an index into
    the columns; any other child is read by ``read`` (kept unless None)."""
    out = InitFacts(body)
    first, sym, names = body.first, body.sym, body.names
    preds: dict[int, bool] = {}
    args: dict[int, bool] = {}
    for k in range(body.lo, body.hi):
        t, end = first[k], first[k + 1]
        plain = end - t >= 3 and sym[t] == OPEN
        if plain and sym[t + 2] == OPEN:
            # `(= (f a b) 3)`: its function as a fact's predicate, then a number
            plain = numeric and end - t >= 7 and sym[t + 1] >= 0 and names[sym[t + 1]] == "=" \
                and sym[end - 3] == CLOSE and sym[end - 2] >= 0 \
                and NUMBER_RE.match(names[sym[end - 2]]) is not None
            t, end = t + 2, end - 2
        if plain:
            s = sym[t + 1]
            ok = preds.get(s)
            if ok is None:
                ok = preds[s] = s >= 0 and plain_head(names[s])
            plain = ok
            for i in range(t + 2, end - 1):
                if not plain:
                    break
                s = sym[i]
                ok = args.get(s)
                if ok is None:
                    ok = args[s] = s >= 0 and _plain_arg(names[s])
                plain = ok
        if plain:
            out.ref.append(k)
        else:
            item = read(body.at(k))
            if item is not None:
                out.add_other(item)
    return out


def plain_init_pred(text: str) -> bool:
    """A fact's head that :meth:`tmpc.lang.reader.Reader.init_item` reads as a predicate name of
    an atom."""
    return text[0] not in '"?' and text.lower() not in ("=", "not") and \
        NUMBER_RE.match(text) is None


def plain_goal_pred(text: str) -> bool:
    """An atom's head :meth:`tmpc.lang.reader_formulas.FormulaReader.formula` reads as a
    predicate name."""
    return text[0] not in '"?:' and text.lower() not in GOAL_HEADS and \
        NUMBER_RE.match(text) is None


GOAL_HEADS = frozenset({"and", "or", "not", "imply", "exists", "forall", *NUMERIC_COMPARISONS})


def _plain_arg(text: str) -> bool:
    """An argument :meth:`tmpc.lang.reader.Reader.term` reads as a constant."""
    return text[0] not in '"?:'
