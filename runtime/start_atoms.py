"""Where the file's `:init` and the scene disagree about what an object stands on, plans start
from the scene (docs/language.md, "Semantics modules").

A semantics module gives a placement predicate (`on-surface`) a meaning that a release must make
true, but the predicate stays symbolic: its initial value is the PDDL file's. The suite's Blocks
World files say `(on-surface a blue-tray)` where their scene has `block_a` on the table (W840).
Planning from the file's atom, every rule the planner learns about `a`'s support is keyed on
the wrong atom: Blocks World E learnt that a fifth block on a tower over `(on-surface a
blue-tray)` hits the ceiling, then moved `a` "to the table", where it already stood, and met the
ceiling again (docs/benchmarks.md).

:func:`settled_placements` says which of those atoms the scene replaces: an `:init` atom
``(P x s)`` of a predicate with a placement meaning that is false in the scene, where ``s`` and
the replacement's support are objects the scene keeps fixed (a surface, not a block: another
object's `clear` would then be wrong too) and the replacement's meaning is the nearest of all
such supports' and within :data:`SETTLE` of holding (`block_a` stands 5 mm into the table's
support region, outside the 5 mm `placed-on` allows from above only). The planner
(:meth:`~tmpc.runtime.problem.PlanningProblem.with_start_symbols`) and the validator
(:class:`~tmpc.runtime.validate.logic.Logic`) both start from the replaced atoms; `tmpc check`
names the replacement in W840.
"""

from __future__ import annotations

from dataclasses import dataclass

from tmpc.compiler.rotations import pose_matrix
from tmpc.lang import ast as A
from tmpc.lang.diagnostics import TmpcError
from tmpc.lang.scope import type_keys
from tmpc.lang.semantics_module import MEANS_SUFFIX
from tmpc.runtime.evaluate import Evaluator, Obj

#: how far (the meaning's unsatisfaction distance, metres here) the scene's support of an
#: object may be from holding for it to replace the file's atom
SETTLE = 0.02

Atom = tuple[str, tuple[str, ...]]      # (predicate key, argument keys)


@dataclass(frozen=True)
class Settled:
    """The file's atom ``old``, false in the scene, and the scene's ``new`` one."""

    old: Atom
    new: Atom
    text: str           # the new atom as the user spells it: "(on-surface a table)"


def disagreements(world) -> list[tuple[A.Atom, Settled | None]]:
    """Each `:init` atom whose predicate has a meaning (``P~means``) that is false in the
    scene (W840), with the scene's atom that replaces it where plans start (the module
    docstring), else None. By the numpy interpreter, no kernel; in file order."""
    program = world.program
    if program is None or program.problem is None:
        return []
    scope, scene = program.scope, world.scene
    poses = {o.name: pose_matrix(o.pose) for o in scene.objects}
    fixed = {o.name.lower() for o in scene.objects if not o.movable}
    ev = Evaluator(scene, None, None, None, poses, scope)
    atoms = [item for item in program.problem.init if isinstance(item, A.Atom)]
    written = {_key(a) for a in atoms}
    out: list[tuple[A.Atom, Settled | None]] = []
    for item in atoms:
        decl = scope.predicates.get(item.pred.key + MEANS_SUFFIX)
        if decl is None or decl.semantics is None:
            continue
        env = {p.name.key: Obj(t.name.text) for p, t in zip(decl.params, item.args)}
        try:
            if bool(ev.value(decl.semantics, env)):
                continue
        except TmpcError:
            continue
        out.append((item, _settle(ev, scope, decl, item, fixed, written)))
    return out


def settled_placements(world) -> list[Settled]:
    """The `:init` atoms the scene replaces (the module docstring), in file order."""
    return [s for _, s in disagreements(world) if s is not None]


def _settle(ev: Evaluator, scope, decl, item: A.Atom, fixed: set[str],
            written: set[Atom]) -> Settled | None:
    """The scene's atom for ``item`` (false in the scene): the fixed support of the second
    argument's type whose meaning is nearest to holding, within :data:`SETTLE`; None for an
    atom that is not a placement of an object on a fixed support."""
    sym = scope.predicates.get(item.pred.key)
    if sym is None or len(item.args) != 2 or item.args[1].name.key not in fixed:
        return None
    x = item.args[0].name.text
    want = type_keys(sym.params[1].type)
    best = None
    for key, info in scope.objects.items():
        if key not in fixed or key == item.args[0].name.key or \
                not scope.compatible(info.types, want):
            continue
        w = _distance(ev, decl, (x, info.name.text))
        if w is not None and (best is None or w < best[0]):
            best = (w, info.name.text)
    if best is None or best[0] > SETTLE:
        return None
    new = (item.pred.key, (item.args[0].name.key, best[1].lower()))
    if new in written:
        return None
    return Settled(_key(item), new, f"({item.pred.text} {x} {best[1]})")


def _key(a: A.Atom) -> Atom:
    return a.pred.key, tuple(t.name.key for t in a.args)


def _distance(ev: Evaluator, decl, args: tuple[str, ...]) -> float | None:
    """The meaning's unsatisfaction distance for ``args`` (None where it cannot be evaluated)."""
    env = {p.name.key: Obj(a) for p, a in zip(decl.params, args)}
    try:
        return float(ev.distance(decl.semantics, env))
    except TmpcError:
        return None


__all__ = ["SETTLE", "Settled", "disagreements", "settled_placements"]
