"""`tmpc check --static` on a run configuration: geometric conditions nothing in the scene can
satisfy.

For every geometric predicate and every action schema's geometric precondition, one ground
instance the problem uses is projected from a batch of uniform configurations within the joint and
base bounds (the compiler's projection sampler, objects where the scene puts them). A condition no
start reaches is reported as W614 at its declaration: "no state found" — sampling cannot prove
unsatisfiability, so the warning says how hard it tried. Conditions on objects only (no robot
frame in reach) are decided by the same projection: if they do not hold, no configuration helps.
When the time budget runs out the rest are reported as not checked (W613).
"""

from __future__ import annotations

import time

import numpy as np

from tmpc.compiler.compile import compile_world
from tmpc.compiler.kernels import make_projector, state_inputs, uniform_starts
from tmpc.compiler.smt import not_checked_note  # the W613 "not checked" note
from tmpc.compiler.state import initial_state
from tmpc.lang.diagnostics import Diagnostic, TmpcError, warning

#: projection starts per condition
STARTS = 256


def geometric_checks(world, budget_s: float = 60.0, seed: int = 0) -> list[Diagnostic]:
    prog = world.program
    if prog is None or prog.problem is None or world.scene.robot is None:
        return []
    t0 = time.perf_counter()
    compiled = compile_world(world)
    try:
        gp = compiled.ground
    except TmpcError:
        return []           # the SAT checks already say the problem is too large to ground
    model = compiled.model
    s0 = initial_state(world.scene, model)
    _, obj_T, parent = state_inputs(compiled.tables, s0)
    rng = np.random.default_rng(seed)
    out: list[Diagnostic] = []
    todo = []
    for decl in prog.domain.predicates:
        if decl.kind.value != "geometric":
            continue
        insts = [g.args for g in gp.geometric if g.predicate.lower() == decl.name.key]
        if insts:
            todo.append(("predicate", decl.name.text, _spread(insts), decl.span))
    schemas: dict[str, list] = {}
    for act in gp.actions:
        if act.pre_geometric:
            schemas.setdefault(act.schema, []).append(act.args)
    for schema, insts in schemas.items():
        decl = prog.scope.actions.get(schema.lower())
        todo.append(("action", schema, _spread(insts), getattr(decl, "span", None)))
    for i, (kind, name, instances, span) in enumerate(todo):
        if time.perf_counter() - t0 > budget_s:
            left = ", ".join(f"{k} `{n}`" for k, n, _, _ in todo[i:])
            out.append(not_checked_note(
                f"geometric checks not run (time budget {budget_s:g} s spent): {left}", span))
            break
        formula = compiled.action(name) if kind == "action" else compiled.predicate(name)
        kernel, _ = compiled.kernels(formula)
        project = make_projector(kernel, model.lower, model.upper, iterations=30,
                                 wraps=model.wraps)
        best = np.inf
        for args in instances:      # a condition may be false for one instance in the start
            ids = compiled.bind_args(formula, list(args))     # scene (an object not held yet)
            Q0 = uniform_starts(rng, model.lower, model.upper, STARTS)
            _, holds, dist = (np.asarray(x) for x in project(Q0, obj_T, parent, ids))
            if holds.any():
                break
            best = min(best, float(dist.min()))
        else:
            args = instances[0]
            what = f"the geometric precondition of action `{name}`" if kind == "action" else \
                f"geometric predicate `{name}`"
            inst = "(" + " ".join((name, *args)) + ")"
            out.append(warning(
                "W614", f"{what} held in none of {STARTS} projections within the joint and base "
                f"bounds, for {inst} and {len(instances) - 1} other instance(s), objects where "
                f"the scene puts them (smallest distance left {best:.3g}); it may be "
                "unsatisfiable in this scene", span,
                "check its numbers against the scene (`tmpc eval --predicate` shows the "
                "distance and gradient at a state)"))
    return out


def _spread(instances: list, k: int = 4) -> list:
    """Up to ``k`` instances spread over the list (different objects, not the first k)."""
    if len(instances) <= k:
        return list(instances)
    step = len(instances) / k
    return [instances[int(i * step)] for i in range(k)]
