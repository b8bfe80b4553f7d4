"""Grounding: a :class:`~tmpc.lang.checker.CheckedProgram` -> :class:`GroundProblem`.

The ground problem is the symbolic half of a TMP problem, shared by the SAT task planner, the FF
heuristic and the TMP runtime. It is *symbolic only*: geometric atoms stay references
``(predicate, objects)`` that the runtime decides with the distance functions compiled once per
lifted predicate (docs/design.md §4, "compile lifted, bind late").

What is in it (details in the docstrings of the ``ground_*`` modules):

* **Objects** with their full type sets (ancestors of every declared type, ``either`` included);
  domain constants first, then problem objects, in declaration order.
* **Atoms**: the discrete, kinematic and derived atoms that are relaxed-reachable from the initial
  state (delete effects ignored, geometric atoms possibly true), plus those of the goal. Atoms of
  *static* predicates (never in an effect) are not state atoms: they are evaluated while grounding
  (``static_facts`` keeps them). Ids are ordered by predicate declaration, then object order.
* **Actions**: type-correct bindings whose precondition is not statically false and that are
  relaxed-reachable. Preconditions are normalized (quantifiers expanded over typed objects,
  ``imply`` rewritten, negation normal form, ``=`` and static atoms evaluated) and split into a
  :class:`~tmpc.compiler.ground.formula.Condition`: ``pre_pos``/``pre_neg`` atom ids,
  ``pre_geometric`` literals, and ``pre.extra``, a formula for disjunctions that remain (None for
  plain conjunctions). Effects: ``adds``/``dels`` (add wins over delete), conditional effects
  evaluated in the pre-state, kinematic link/unlink effects, and a cost.
* **Axioms** for derived predicates, stratified (:mod:`tmpc.compiler.ground.derived`).

**States** are ``int`` bitsets over atom ids (bit ``i`` set = atom ``i`` true); derived bits are
part of the state and kept up to date by :meth:`GroundProblem.apply`. Geometric literals are
decided by an optional ``geo(predicate, args) -> bool``; without one they count as satisfied.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Iterable, Iterator, NamedTuple

from tmpc.compiler.ground.derived import Axiom, DerivedEvaluator
from tmpc.compiler.ground.formula import Condition, GeoLiteral, GeoOracle, GFormula, GGeo, holds
from tmpc.compiler.ground.symbols import is_symbol
from tmpc.lang.diagnostics import TmpcError, error
from tmpc.lang.source import Span

#: Default cap on the parameter bindings of one action schema or derived rule.
MAX_BINDINGS = 2_000_000


class GroundingError(TmpcError):
    """A program that checks but cannot be grounded (E600–E609, docs/diagnostics.md)."""


@dataclass(frozen=True)
class GroundObject:
    name: str                   # as the user spelled it
    types: frozenset[str]       # every type it belongs to (keys), `object` included
    constant: bool              # a domain constant

    @property
    def key(self) -> str:
        return self.name.lower()


@dataclass(frozen=True)
class GroundAtom:
    """A state atom; ``kind`` is ``discrete``, ``kinematic`` or ``derived``."""

    predicate: str              # as declared
    args: tuple[str, ...]       # object names as spelled
    kind: str

    def __str__(self) -> str:
        return "(" + " ".join((self.predicate, *self.args)) + ")"


class KinematicEffect(NamedTuple):
    """``link``: ``child`` becomes rigidly attached to ``parent``; ``unlink``: released."""

    op: str
    parent: str
    child: str
    atom: int


@dataclass(frozen=True)
class ConditionalEffect:
    """Adds and deletes that happen when ``condition`` holds in the state before the action."""

    condition: GFormula
    adds: frozenset[int]
    dels: frozenset[int]
    kinematic: tuple[KinematicEffect, ...] = ()
    add_mask: int = field(default=0, repr=False)
    del_mask: int = field(default=0, repr=False)
    _cond: Condition | None = field(default=None, repr=False, compare=False)

    def fires(self, state: int, geo: GeoOracle | None = None) -> bool:
        return self._cond.holds(state, geo)


@dataclass(frozen=True, eq=False)
class GroundAction:
    """One ground action; ``id`` is its index in :attr:`GroundProblem.actions`. Compared and
    hashed by identity (a problem has one object per ground action), so it is a cheap dict key."""

    id: int
    schema: str                 # the action's name as declared
    args: tuple[str, ...]       # object names as spelled, one per parameter
    pre: Condition
    adds: frozenset[int]
    dels: frozenset[int]
    conditional: tuple[ConditionalEffect, ...]
    kinematic: tuple[KinematicEffect, ...]
    cost: float
    add_mask: int = field(repr=False)
    del_mask: int = field(repr=False)
    span: Span | None = field(default=None, repr=False, compare=False)
    #: how plans name it, ``(schema, args)``, when that differs: a variant made for a geometric
    #: symbol (:mod:`tmpc.compiler.ground.symbols`) is shown as the action it was made from
    shown: tuple[str, tuple[str, ...]] | None = field(default=None, repr=False, compare=False)

    @property
    def name(self) -> str:
        schema, args = self.shown or (self.schema, self.args)
        return "(" + " ".join((schema, *args)) + ")"

    @property
    def precondition(self) -> GFormula:
        return self.pre.formula

    @property
    def pre_pos(self) -> frozenset[int]:
        return self.pre.pos

    @property
    def pre_neg(self) -> frozenset[int]:
        return self.pre.neg

    @property
    def pre_geometric(self) -> tuple[GeoLiteral, ...]:
        return self.pre.geometric


@dataclass(frozen=True)
class GroundStats:
    bindings_considered: int    # type-correct bindings that passed the static checks
    candidate_atoms: int        # fluent atoms mentioned by any such binding
    seconds: float


@dataclass(frozen=True, eq=False)
class GroundProblem:
    domain: str
    problem: str
    objects: tuple[GroundObject, ...]
    atoms: tuple[GroundAtom, ...]
    actions: tuple[GroundAction, ...]
    axioms: tuple[Axiom, ...]
    #: the initial state (derived atoms evaluated, geometric literals assumed satisfied)
    init: int
    goal: Condition
    #: true atoms of static predicates, ``(predicate key, object keys)``
    static_facts: frozenset[tuple[str, tuple[str, ...]]]
    #: initial values of numeric fluents, ``(function key, object keys) -> value``
    numeric: dict[tuple[str, tuple[str, ...]], float]
    #: does the domain use action costs (``increase (total-cost) ...``)? Else every cost is 1.
    uses_costs: bool
    #: is the goal reachable in the delete relaxation (geometry possibly true)?
    goal_relaxed_reachable: bool
    #: every geometric atom the actions, axioms and goal refer to
    geometric: tuple[GGeo, ...]
    stats: GroundStats
    _index: dict[tuple[str, tuple[str, ...]], int] = field(repr=False, compare=False)
    _derived: DerivedEvaluator = field(repr=False, compare=False)

    def with_init(self, init: int) -> "GroundProblem":
        """This problem from the initial state ``init`` (derived atoms recomputed)."""
        return replace(self, init=self.evaluate_derived(init))

    # ---- names ------------------------------------------------------------------------------
    def atom_name(self, atom_id: int) -> str:
        """``"(on-surface blue_stick_1 table1)"``, with names as the user spelled them."""
        return str(self.atoms[atom_id])

    def atom_id(self, predicate: str, *args: str) -> int | None:
        """The id of an atom (names compare without case), None if it is not a state atom."""
        return self._index.get((predicate.lower(), tuple(a.lower() for a in args)))

    def shown_atoms(self, state: int) -> list[str]:
        """:meth:`state_atoms` without geometric symbols (:mod:`tmpc.compiler.ground.symbols`):
        the atoms plans and reports list."""
        return [self.atom_name(i) for i in bits(state) if not is_symbol(self.atoms[i].predicate)]

    def state_atoms(self, state: int) -> list[str]:
        """Names of the atoms true in ``state``, in id order."""
        return [self.atom_name(i) for i in bits(state)]

    def state(self, atoms: Iterable[str | tuple]) -> int:
        """A state from atom names ``"(p a b)"`` or tuples ``("p", "a", "b")`` (derived atoms
        recomputed). KeyError for an atom that is not a state atom."""
        out = 0
        for a in atoms:
            parts = tuple(a.strip("() ").split()) if isinstance(a, str) else tuple(a)
            i = self.atom_id(*parts)
            if i is None:
                raise KeyError(f"not a state atom: {a}")
            out |= 1 << i
        return self.evaluate_derived(out)

    def find_action(self, schema: str, *args: str) -> GroundAction | None:
        want = (schema.lower(), tuple(a.lower() for a in args))
        for a in self.actions:
            if (a.schema.lower(), tuple(x.lower() for x in a.args)) == want:
                return a
        return None

    # ---- semantics --------------------------------------------------------------------------
    def evaluate_derived(self, state: int, geo: GeoOracle | None = None) -> int:
        """``state`` with every derived atom recomputed from the axioms."""
        return self._derived(state, geo) if self.axioms or self._derived.mask else state

    def applicable(self, state: int, action: GroundAction, geo: GeoOracle | None = None) -> bool:
        """Does the precondition of ``action`` hold in ``state`` (geometry by ``geo``)?"""
        return action.pre.holds(state, geo)

    def apply(self, state: int, action: GroundAction, geo: GeoOracle | None = None) -> int:
        """The successor: conditional effects decided in ``state``, then deletes, then adds
        (an atom both added and deleted ends true), then derived atoms recomputed."""
        adds, dels = action.add_mask, action.del_mask
        for ce in action.conditional:
            if ce.fires(state, geo):
                adds |= ce.add_mask
                dels |= ce.del_mask
        out = (state & ~dels) | adds
        return self.evaluate_derived(out, geo) if self.axioms else out

    def goal_satisfied(self, state: int, geo: GeoOracle | None = None) -> bool:
        return self.goal.holds(state, geo)

    def successors(self, state: int,
                   geo: GeoOracle | None = None) -> Iterator[tuple[GroundAction, int]]:
        for a in self.actions:
            if a.pre.holds(state, geo):
                yield a, self.apply(state, a, geo)

    def kinematic_effects(self, state: int, action: GroundAction,
                          geo: GeoOracle | None = None) -> tuple[KinematicEffect, ...]:
        """Link/unlink effects of ``action`` in ``state`` (conditional ones included)."""
        out = list(action.kinematic)
        for ce in action.conditional:
            if ce.kinematic and ce.fires(state, geo):
                out.extend(ce.kinematic)
        return tuple(out)


def bits(state: int) -> Iterator[int]:
    """Ids of the set bits of ``state``, ascending."""
    while state:
        low = state & -state
        yield low.bit_length() - 1
        state ^= low


def grounding_error(code: str, message: str, span: Span | None,
                    hint: str | None = None) -> GroundingError:
    return GroundingError(error(code, message, span, hint))


__all__ = ["GroundProblem", "GroundAction", "GroundAtom", "GroundObject", "ConditionalEffect",
           "KinematicEffect", "GroundingError", "grounding_error", "holds", "bits", "MAX_BINDINGS"]
