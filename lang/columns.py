"""AST sequences kept as columns: a large problem's `:init` facts and `:objects` names.

A problem of hundreds of thousands of facts would hold an ``Atom`` with a ``Name``, a ``Const``
per argument and a span for each (~600 bytes a fact, 20x its text). Here a fact is the index of
its list in the s-expression columns (:class:`~tmpc.lang.sexpr.Packed`), and a node is built,
equal to the one the reader builds, when it is read. Every consumer sees a sequence of the same
AST nodes; the checker reads the columns directly (:meth:`InitFacts.facts`).
"""

from __future__ import annotations

from abc import abstractmethod
from array import array

from tmpc.lang import ast as A
from tmpc.lang.sexpr import OPEN, Packed, ValueSequence
from tmpc.lang.source import Span


class _Columns(ValueSequence):
    """Entries that are a child of ``src`` (``ref[j] >= 0``) or an object (``others[j]``)."""

    __slots__ = ("src", "ref", "others")

    def __init__(self, src: Packed):
        self.src = src
        # a child's index, or -1 (4 bytes when the offsets are: fewer children than characters)
        self.ref = array("i" if src.pos.itemsize == 4 else "q")
        self.others: dict[int, object] = {}

    def add_other(self, x) -> None:
        self.others[len(self.ref)] = x
        self.ref.append(-1)

    def __len__(self) -> int:
        return len(self.ref)

    def __getitem__(self, j):
        if isinstance(j, slice):
            return tuple(self[i] for i in range(*j.indices(len(self.ref))))
        if j < 0:
            j += len(self.ref)
        k = self.ref[j]
        return self.others[j] if k < 0 else self.build(j, k)

    def __iter__(self):
        ref, others, build = self.ref, self.others, self.build
        for j in range(len(ref)):
            k = ref[j]
            yield others[j] if k < 0 else build(j, k)

    @abstractmethod
    def build(self, j: int, k: int):
        """The AST node of entry ``j``, packed as child ``k`` of ``src`` (each subclass's shape)."""

    def _span(self, t: int) -> Span:
        src = self.src
        start = src.pos[t]
        return Span(src.path, start, start + len(src.names[src.sym[t]]))

    def key(self, j: int):
        """What equality compares of entry ``j`` (spans excluded)."""
        return self[j]

    def __eq__(self, other) -> bool:
        if type(other) is type(self):          # the same columns: compare keys, build nothing
            return len(self) == len(other) and \
                all(self.key(j) == other.key(j) for j in range(len(self)))
        return super().__eq__(other)

    __hash__ = ValueSequence.__hash__          # (defining __eq__ would unset it)


class InitFacts(_Columns):
    """`:init`: a fact ``(p a b)`` or ``(= (f a b) 3)`` of plain names is the index of its list
    in ``src``."""

    __slots__ = ()

    def build(self, j: int, k: int, spans: bool = True):
        src = self.src
        names, sym, pos, path = src.names, src.sym, src.pos, src.path
        t, end = src.first[k], src.first[k + 1]
        span = self._span if spans else _no_span
        numeric = sym[t + 2] == OPEN            # `(` `=` `(` f args... `)` value `)`
        h = t + 3 if numeric else t + 1
        stop = end - 3 if numeric else end - 1
        args = []
        for i in range(h + 1, stop):
            sp = span(i)
            args.append(A.Const(A.Name(names[sym[i]], span=sp), span=sp))
        head = A.Name(names[sym[h]], span=span(h))
        whole = Span(path, pos[t], pos[end - 1] + 1) if spans else None
        if not numeric:
            return A.Atom(head, tuple(args), span=whole)
        text = names[sym[end - 2]]
        return A.NumericInit(
            A.FuncTerm(head, tuple(args), span=Span(path, pos[t + 2], pos[end - 3] + 1)
                       if spans else None),
            A.Num(float(text), text, span=span(end - 2)), span=whole)

    def facts(self):
        """``(j, numeric, symbol ids of the predicate or function and its arguments)`` of each
        packed fact, and ``(j, None, None)`` for the others: what the checker reads without
        building nodes."""
        src = self.src
        first, sym, ref = src.first, src.sym, self.ref
        for j in range(len(ref)):
            k = ref[j]
            if k < 0:
                yield j, None, None
                continue
            t, end = first[k], first[k + 1]
            if sym[t + 2] == OPEN:
                yield j, True, sym[t + 3:end - 3]
            else:
                yield j, False, sym[t + 1:end - 1]

    def key(self, j: int):
        """A packed fact's texts (and a numeric fact's value): what its node's equality
        compares, without the node."""
        k = self.ref[j]
        if k < 0:
            return self.others[j]
        src = self.src
        names, sym = src.names, src.sym
        t, end = src.first[k], src.first[k + 1]
        if sym[t + 2] == OPEN:
            return (True, tuple([names[s] for s in sym[t + 3:end - 3]]),
                    float(names[sym[end - 2]]))
        return (False, tuple([names[s] for s in sym[t + 1:end - 1]]))

    def __eq__(self, other) -> bool:
        if type(other) is InitFacts and len(other) == len(self) and \
                any((a < 0) != (b < 0) for a, b in zip(self.ref, other.ref)):
            return all(a == b for a, b in zip(self, other))     # packed against built: nodes
        return super().__eq__(other)

    __hash__ = _Columns.__hash__


def _no_span(t: int) -> None:
    return None


class TypedNames(_Columns):
    """`:objects` (and other typed name lists): a name is the index of its symbol in ``src``,
    with the index of its group in ``groups``: (its type, the span of the ``- type`` that ends
    the group) or (None, None) for the names left untyped."""

    __slots__ = ("grp", "groups")

    def __init__(self, src: Packed):
        super().__init__(src)
        self.grp = array("i")
        self.groups: list[tuple[A.TypeRef | None, Span | None]] = []

    def add(self, k: int, group: int) -> None:
        self.ref.append(k)
        self.grp.append(group)

    def add_other(self, x) -> None:
        super().add_other(x)
        self.grp.append(-1)

    def build(self, j: int, k: int) -> A.Typed:
        nm = A.Name(self.src.names[self.src.sym[self.src.first[k]]],
                    span=self._span(self.src.first[k]))
        tref, dash = self.groups[self.grp[j]]
        return A.Typed(nm, tref, span=nm.span.cover(dash) if dash is not None else nm.span)

    def name_text(self, j: int) -> str:
        return self.src.names[self.src.sym[self.src.first[self.ref[j]]]]

    def name(self, j: int) -> A.Name:
        k = self.ref[j]
        if k < 0:
            return self.others[j].name
        return A.Name(self.src.names[self.src.sym[self.src.first[k]]],
                      span=self._span(self.src.first[k]))

    def type_of(self, j: int) -> A.TypeRef | None:
        return self.others[j].type if self.ref[j] < 0 else self.groups[self.grp[j]][0]

    def key(self, j: int):
        k = self.ref[j]
        if k < 0:
            return self.others[j]
        return A.Typed(A.Name(self.src.names[self.src.sym[self.src.first[k]]]),
                       self.groups[self.grp[j]][0])
