"""Analyses of a ground problem that the SAT encoding (:mod:`tmpc.compiler.smt.encode`) builds on:
which atoms are relevant (read by something), the delete-relaxed planning graph levels (the first
step each action can be, the goal's level, every reachable atom), and strongly connected components
of the derived-atom dependency graph."""

from __future__ import annotations

from tmpc.compiler.ground import GFormula, GroundProblem, atom_ids, relaxed_holds


def relevant_atoms(problem: GroundProblem) -> set[int]:
    """Atoms a precondition, an effect condition, the goal or (transitively) the axiom of a
    relevant derived atom reads."""
    out: set[int] = set()
    for a in problem.actions:
        out |= a.pre.pos | a.pre.neg
        if a.pre.extra is not None:
            out.update(atom_ids(a.pre.extra))
        for ce in a.conditional:
            out.update(atom_ids(ce.condition))
    out.update(atom_ids(problem.goal.formula))
    bodies: dict[int, list[GFormula]] = {}
    for ax in problem.axioms:
        bodies.setdefault(ax.head, []).append(ax.body)
    todo = [i for i in out if i in bodies]
    while todo:
        h = todo.pop()
        for body in bodies[h]:
            for i in atom_ids(body):
                if i not in out:
                    out.add(i)
                    if i in bodies:
                        todo.append(i)
    return out


class _Bits:
    """``reached[i]`` over an int bitset, for :func:`relaxed_holds`."""

    __slots__ = ("mask",)

    def __init__(self, mask: int):
        self.mask = mask

    def __getitem__(self, i: int) -> bool:
        return (self.mask >> i) & 1 == 1


def relaxed_levels(problem: GroundProblem) -> tuple[list[int], int | None]:
    """Per action, the first step it can be in the delete relaxation (its precondition's level
    plus one), and the goal's level (None if unreachable). Derived atoms are closed in each
    level; negated and geometric literals are possibly true."""
    first, goal_level, _ = relaxed_fixpoint(problem)
    return first, goal_level


def relaxed_fixpoint(problem: GroundProblem) -> tuple[list[int], int | None, int]:
    """:func:`relaxed_levels` and the bitset of every relaxed-reachable atom."""
    big = 1 << 30
    first = [big] * len(problem.actions)
    reached = _Bits(_close_derived(problem, problem.init))
    pending = list(problem.actions)
    level = 0
    goal_level = None
    while True:
        if goal_level is None and relaxed_holds(problem.goal.formula, reached):
            goal_level = level
        adds, rest = 0, []
        for a in pending:
            pm = a.pre.pos_mask
            if reached.mask & pm == pm and (a.pre.extra is None or
                                             relaxed_holds(a.pre.extra, reached)):
                first[a.id] = level + 1
                adds |= a.add_mask
                for ce in a.conditional:
                    adds |= ce.add_mask     # a relaxation: conditions may hold later
            else:
                rest.append(a)
        if not adds & ~reached.mask:
            break                           # a fixpoint: the rest are never applicable
        reached = _Bits(_close_derived(problem, reached.mask | adds))
        pending = rest
        level += 1
    if goal_level is None and relaxed_holds(problem.goal.formula, reached):
        goal_level = level
    return first, goal_level, reached.mask


def _close_derived(problem: GroundProblem, mask: int) -> int:
    if not problem.axioms:
        return mask
    changed = True
    while changed:
        changed = False
        view = _Bits(mask)
        for ax in problem.axioms:
            if not (mask >> ax.head) & 1 and relaxed_holds(ax.body, view):
                mask |= 1 << ax.head
                view = _Bits(mask)
                changed = True
    return mask


def components(nodes: list[int], edges: dict[int, set[int]]) -> list[list[int]]:
    """Strongly connected components (iterative Tarjan)."""
    index: dict[int, int] = {}
    low: dict[int, int] = {}
    on_stack: set[int] = set()
    stack: list[int] = []
    out: list[list[int]] = []
    counter = 0
    for root in nodes:
        if root in index:
            continue
        work = [(root, iter(sorted(edges.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    advanced = True
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                out.append(comp)
    return out


__all__ = ["relevant_atoms", "relaxed_levels", "relaxed_fixpoint", "components"]
