"""Ground formulas: conditions over ground atoms, in negation normal form.

A :data:`GFormula` is a tree of :class:`GAnd`, :class:`GOr`, :class:`GNot` (only around a leaf),
and the leaves :class:`GAtom` (a discrete/kinematic/derived atom: a bit of the symbolic state,
by id), :class:`GGeo` (a geometric atom: a reference ``(predicate, objects)`` the runtime decides
with its distance functions; never a bit of state), :data:`TRUE` and :data:`FALSE`.

The constructors :func:`conj` and :func:`disj` simplify as they build (constants, nesting,
duplicates, complementary literals), so a formula that reduces to a constant *is* that constant.

States are ``int`` bitsets: atom ``i`` is true in ``state`` iff bit ``i`` is set.

Geometric leaves are decided by an optional callback ``geo(predicate, args) -> bool``. Without one
(``geo=None``), every geometric *literal* (positive or negated) counts as satisfied: the discrete
view, in which geometry is "possibly true" and decided later by sampling.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterator, NamedTuple, Union

GeoOracle = Callable[[str, tuple[str, ...]], bool]


@dataclass(frozen=True, slots=True)
class GTrue:
    def __repr__(self) -> str:
        return "TRUE"


@dataclass(frozen=True, slots=True)
class GFalse:
    def __repr__(self) -> str:
        return "FALSE"


TRUE = GTrue()
FALSE = GFalse()


@dataclass(frozen=True, slots=True)
class GAtom:
    """A discrete atom, by id (bit ``id`` of a state)."""

    id: int


@dataclass(frozen=True, slots=True)
class GGeo:
    """A geometric atom: predicate and objects as the user spelled them."""

    predicate: str
    args: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class GNot:
    """Negation of a leaf (formulas are kept in negation normal form)."""

    part: Union[GAtom, GGeo]


@dataclass(frozen=True, slots=True)
class GAnd:
    parts: tuple["GFormula", ...]
    _hash: int = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_hash", hash(("and", self.parts)))

    def __hash__(self) -> int:      # cached: formulas are hashed often while simplifying
        return self._hash


@dataclass(frozen=True, slots=True)
class GOr:
    parts: tuple["GFormula", ...]
    _hash: int = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_hash", hash(("or", self.parts)))

    def __hash__(self) -> int:
        return self._hash


GFormula = Union[GTrue, GFalse, GAtom, GGeo, GNot, GAnd, GOr]
Literal = Union[GAtom, GGeo, GNot]


class GeoLiteral(NamedTuple):
    """A geometric literal of a precondition or goal: ``(predicate, objects, positive)``."""

    predicate: str
    args: tuple[str, ...]
    positive: bool


# ---------------------------------------------------------------------------------------------
# Construction with simplification


def neg(leaf: Union[GAtom, GGeo]) -> GNot:
    return GNot(leaf)


def _complement(lit: GFormula) -> GFormula | None:
    if isinstance(lit, GNot):
        return lit.part
    if isinstance(lit, (GAtom, GGeo)):
        return GNot(lit)
    return None


def conj(parts) -> GFormula:
    """``and`` of ``parts``: flattened, constants folded, duplicates removed."""
    out: dict[GFormula, None] = {}
    for p in parts:
        t = type(p)
        if t is GTrue:
            continue
        if t is GFalse:
            return FALSE
        if t is GAnd:
            out.update(dict.fromkeys(p.parts))
        else:
            out[p] = None
    return _finish(out, GAnd, TRUE, FALSE)


def disj(parts) -> GFormula:
    """``or`` of ``parts``: flattened, constants folded, duplicates removed."""
    out: dict[GFormula, None] = {}
    for p in parts:
        t = type(p)
        if t is GFalse:
            continue
        if t is GTrue:
            return TRUE
        if t is GOr:
            out.update(dict.fromkeys(p.parts))
        else:
            out[p] = None
    return _finish(out, GOr, FALSE, TRUE)


def _finish(out: dict, make, empty: GFormula, complementary: GFormula) -> GFormula:
    if not out:
        return empty
    if len(out) == 1:
        return next(iter(out))
    for q in out:
        if type(q) is GNot and q.part in out:
            return complementary
    return make(tuple(out))


def is_literal(f: GFormula) -> bool:
    return isinstance(f, (GAtom, GGeo, GNot))


def conjuncts(f: GFormula) -> tuple[GFormula, ...]:
    if isinstance(f, GTrue):
        return ()
    return f.parts if isinstance(f, GAnd) else (f,)


def atom_ids(f: GFormula, positive_only: bool = False) -> Iterator[int]:
    """Ids of the discrete atoms ``f`` mentions (only un-negated ones with ``positive_only``)."""
    if isinstance(f, GAtom):
        yield f.id
    elif isinstance(f, GNot):
        if not positive_only and isinstance(f.part, GAtom):
            yield f.part.id
    elif isinstance(f, (GAnd, GOr)):
        for p in f.parts:
            yield from atom_ids(p, positive_only)


def geo_atoms(f: GFormula) -> Iterator[GGeo]:
    if isinstance(f, GGeo):
        yield f
    elif isinstance(f, GNot):
        if isinstance(f.part, GGeo):
            yield f.part
    elif isinstance(f, (GAnd, GOr)):
        for p in f.parts:
            yield from geo_atoms(p)


def remap(f: GFormula, ids: dict[int, int], reached=None) -> GFormula:
    """Renumber atoms by ``ids``. With ``reached`` (a container of old ids), an atom that was
    never reached is false: a positive occurrence becomes FALSE, a negated one TRUE."""
    if isinstance(f, GAtom):
        if reached is not None and not reached[f.id]:
            return FALSE
        return GAtom(ids[f.id])
    if isinstance(f, GNot):
        if isinstance(f.part, GAtom):
            if reached is not None and not reached[f.part.id]:
                return TRUE
            return GNot(GAtom(ids[f.part.id]))
        return f
    if isinstance(f, GAnd):
        return conj(remap(p, ids, reached) for p in f.parts)
    if isinstance(f, GOr):
        return disj(remap(p, ids, reached) for p in f.parts)
    return f


# ---------------------------------------------------------------------------------------------
# Evaluation


def holds(f: GFormula, state: int, geo: GeoOracle | None = None) -> bool:
    """Truth of ``f`` in ``state`` (geometric literals by ``geo``; all satisfied without it)."""
    t = type(f)
    if t is GAtom:
        return (state >> f.id) & 1 == 1
    if t is GAnd:
        return all(holds(p, state, geo) for p in f.parts)
    if t is GOr:
        return any(holds(p, state, geo) for p in f.parts)
    if t is GNot:
        if type(f.part) is GAtom:
            return not (state >> f.part.id) & 1
        return True if geo is None else not geo(f.part.predicate, f.part.args)
    if t is GGeo:
        return True if geo is None else bool(geo(f.predicate, f.args))
    return t is GTrue


def relaxed_holds(f: GFormula, reached) -> bool:
    """Delete-relaxed truth: positive atoms must be in ``reached`` (indexable by id), negated
    literals and geometric atoms are possibly true."""
    t = type(f)
    if t is GAtom:
        return bool(reached[f.id])
    if t is GAnd:
        return all(relaxed_holds(p, reached) for p in f.parts)
    if t is GOr:
        return any(relaxed_holds(p, reached) for p in f.parts)
    return t is not GFalse


Evaluator = Callable[[int, "GeoOracle | None"], bool]


def compile_formula(f: GFormula) -> Evaluator:
    """A fast evaluator ``(state, geo) -> bool`` for ``f``: conjunctions of discrete literals
    become two mask tests; the rest falls back to :func:`holds` per part."""
    lits = [p for p in conjuncts(f) if isinstance(p, GAtom) or
            (isinstance(p, GNot) and isinstance(p.part, GAtom))]
    rest = [p for p in conjuncts(f) if p not in lits]
    pos = sum(1 << p.id for p in lits if isinstance(p, GAtom))
    negm = sum(1 << p.part.id for p in lits if isinstance(p, GNot))
    if isinstance(f, GFalse):
        return lambda state, geo=None: False
    if not rest:
        return lambda state, geo=None: state & pos == pos and not state & negm
    if isinstance(f, GOr):
        subs = [compile_formula(p) for p in f.parts]
        return lambda state, geo=None: any(s(state, geo) for s in subs)
    subs = [compile_formula(p) if isinstance(p, (GAnd, GOr)) else
            (lambda p: lambda state, geo=None: holds(p, state, geo))(p) for p in rest]
    return lambda state, geo=None: (state & pos == pos and not state & negm
                                    and all(s(state, geo) for s in subs))


# ---------------------------------------------------------------------------------------------
# Conditions: the conjunctive part split out


@dataclass(frozen=True)
class Condition:
    """A precondition or goal.

    ``formula`` is the whole condition. Its top-level conjuncts that are literals are split out:
    ``pos``/``neg`` (discrete atom ids that must be true/false) and ``geometric`` (geometric
    literals for the runtime's distance functions). ``extra`` is the conjunction of the remaining
    conjuncts (disjunctions left after normalization), None when the condition is a plain
    conjunction of literals — the common STRIPS case.
    """

    formula: GFormula
    pos: frozenset[int]
    neg: frozenset[int]
    geometric: tuple[GeoLiteral, ...]
    extra: GFormula | None
    pos_mask: int = field(repr=False)
    neg_mask: int = field(repr=False)
    _eval: Evaluator = field(repr=False, compare=False)

    @classmethod
    def of(cls, formula: GFormula) -> "Condition":
        pos, negs, geom, rest = [], [], [], []
        for p in conjuncts(formula):
            if isinstance(p, GAtom):
                pos.append(p.id)
            elif isinstance(p, GNot) and isinstance(p.part, GAtom):
                negs.append(p.part.id)
            elif isinstance(p, GGeo):
                geom.append(GeoLiteral(p.predicate, p.args, True))
            elif isinstance(p, GNot):
                geom.append(GeoLiteral(p.part.predicate, p.part.args, False))
            elif not isinstance(p, GTrue):
                rest.append(p)
        extra = conj(rest) if rest else None
        return cls(formula, frozenset(pos), frozenset(negs), tuple(geom), extra,
                   sum(1 << i for i in set(pos)), sum(1 << i for i in set(negs)),
                   compile_formula(formula))

    @property
    def is_conjunctive(self) -> bool:
        return self.extra is None

    def holds(self, state: int, geo: GeoOracle | None = None) -> bool:
        return self._eval(state, geo)

    def dnf(self, limit: int = 10_000) -> list[tuple[frozenset[int], frozenset[int],
                                                     tuple[GeoLiteral, ...]]]:
        """The condition as a disjunction of conjunctions ``(pos, neg, geometric)``; at most
        ``limit`` of them (ValueError beyond: the caller should keep the formula)."""
        out = []
        for lits in _dnf(self.formula, limit):
            pos = frozenset(x.id for x in lits if isinstance(x, GAtom))
            negs = frozenset(x.part.id for x in lits
                             if isinstance(x, GNot) and isinstance(x.part, GAtom))
            geom = tuple(GeoLiteral(x.predicate, x.args, True) for x in lits
                         if isinstance(x, GGeo)) + tuple(
                GeoLiteral(x.part.predicate, x.part.args, False) for x in lits
                if isinstance(x, GNot) and isinstance(x.part, GGeo))
            if not pos & negs:
                out.append((pos, negs, geom))
        return out


def small_dnf(f: GFormula, limit: int = 64) -> list[tuple[GFormula, ...]] | None:
    """``f`` as at most ``limit`` conjunctions of literals (in a stable order), or None."""
    try:
        return [tuple(sorted(c, key=_lit_order)) for c in _dnf(f, limit)]
    except ValueError:
        return None


def _lit_order(lit) -> tuple:
    leaf = lit.part if isinstance(lit, GNot) else lit
    return (isinstance(leaf, GGeo), leaf.id if isinstance(leaf, GAtom) else (leaf.predicate, leaf.args),
            isinstance(lit, GNot))


def _dnf(f: GFormula, limit: int) -> list[frozenset]:
    if isinstance(f, GTrue):
        return [frozenset()]
    if isinstance(f, GFalse):
        return []
    if is_literal(f):
        return [frozenset((f,))]
    if isinstance(f, GOr):
        out = [c for p in f.parts for c in _dnf(p, limit)]
    else:
        out = [frozenset()]
        for p in f.parts:
            out = [a | b for a in out for b in _dnf(p, limit)]
            if len(out) > limit:
                break
    if len(out) > limit:
        raise ValueError(f"more than {limit} disjuncts")
    return list(dict.fromkeys(out))
