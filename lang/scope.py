"""Symbol tables the checker builds: the type hierarchy, objects, predicates, functions, helpers."""

from __future__ import annotations

from dataclasses import dataclass, field

from tmpc.lang import ast as A

OBJECT = "object"


@dataclass
class TypeHierarchy:
    """PDDL types as a DAG (a type declared twice with different parents has both)."""

    parents: dict[str, set[str]] = field(default_factory=lambda: {OBJECT: set()})
    decl: dict[str, A.Name] = field(default_factory=dict)

    def declare(self, name: A.Name, parents: tuple[A.Name, ...]) -> None:
        key = name.key
        self.decl.setdefault(key, name)
        entry = self.parents.setdefault(key, set())
        for p in parents or ():
            if p.key != key:
                entry.add(p.key)
        if key != OBJECT and not entry:
            entry.add(OBJECT)

    def __contains__(self, key: str) -> bool:
        return key in self.parents

    def ancestors(self, key: str) -> set[str]:
        out, todo = set(), [key]
        while todo:
            t = todo.pop()
            if t in out:
                continue
            out.add(t)
            todo.extend(self.parents.get(t, ()))
        out.add(OBJECT)
        return out

    def is_subtype(self, sub: str, sup: str) -> bool:
        return sup == OBJECT or sup in self.ancestors(sub)

    def cycle(self) -> list[str] | None:
        """One cycle of declared types, if any (``a - b``, ``b - a``)."""
        color: dict[str, int] = {}

        def visit(t: str, path: list[str]) -> list[str] | None:
            color[t] = 1
            for p in self.parents.get(t, ()):
                if color.get(p) == 1:
                    return path[path.index(p):] + [p] if p in path else [t, p]
                if p not in color:
                    found = visit(p, path + [p])
                    if found:
                        return found
            color[t] = 2
            return None

        for t in list(self.parents):
            if t not in color:
                found = visit(t, [t])
                if found:
                    return found
        return None


def type_keys(t: A.TypeRef | None) -> tuple[str, ...]:
    """The alternatives of a type reference; untyped means ``object``."""
    if t is None or not t.names:
        return (OBJECT,)
    return tuple(n.key for n in t.names)


class ObjectInfo:
    """An object or constant: its name (where it is declared), types and origin.

    A large problem has hundreds of thousands: the types tuple is shared, and the name of a
    packed ``:objects`` entry is built when asked for (``source`` and ``index``)."""

    __slots__ = ("_name", "_index", "types", "constant")

    def __init__(self, name, types: tuple[str, ...], constant: bool, index: int = -1):
        self._name, self._index = name, index
        self.types = types
        self.constant = constant          # declared in the domain's :constants

    @property
    def name(self) -> A.Name:
        return self._name if self._index < 0 else self._name.name(self._index)

    def __eq__(self, other) -> bool:
        return isinstance(other, ObjectInfo) and (self.name, self.types, self.constant) == \
            (other.name, other.types, other.constant)

    def __hash__(self) -> int:
        return hash((self.name, self.types, self.constant))

    def __repr__(self) -> str:
        return f"ObjectInfo(name={self.name!r}, types={self.types!r}, constant={self.constant})"


@dataclass
class Scope:
    """What names mean in a checked program (domain + optional problem + included modules)."""

    types: TypeHierarchy = field(default_factory=TypeHierarchy)
    objects: dict[str, ObjectInfo] = field(default_factory=dict)
    predicates: dict[str, A.PredicateDecl] = field(default_factory=dict)
    derived: dict[str, list[A.Derived]] = field(default_factory=dict)
    functions: dict[str, A.FunctionDecl] = field(default_factory=dict)
    helpers: dict[str, A.DefineDecl] = field(default_factory=dict)
    #: helpers of included modules; local helpers and predicates shadow them
    module_helpers: dict[str, A.DefineDecl] = field(default_factory=dict)

    def helper(self, key: str) -> A.DefineDecl | None:
        """A local helper, else an included one unless a local predicate shadows it."""
        if key in self.helpers:
            return self.helpers[key]
        if key in self.predicates and self.predicates[key].span is not None:
            return None
        return self.module_helpers.get(key)
    actions: dict[str, A.Action] = field(default_factory=dict)

    def compatible(self, actual: tuple[str, ...], expected: tuple[str, ...]) -> bool:
        """Can a term of type ``actual`` (any of) fill a slot of type ``expected`` (any of)?

        Lenient for `either`: some alternative must fit (static typing of PDDL is permissive).
        """
        return any(self.types.is_subtype(a, e) for a in actual for e in expected)
