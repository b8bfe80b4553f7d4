"""`tmpc eval INPUT --state S.json (--expr EXPR | --predicate NAME ARG...) [--collisions]`.

Evaluates at one state: an expression's value (positions in the world frame, from forward
kinematics), a geometric predicate's truth, and with ``--collisions`` whether the state is valid
and every colliding pair. A predicate's distance and gradient come from its compiled kernel.
"""

from __future__ import annotations

import json
import sys

from tmpc.compiler.artifact import open_world
from tmpc.compiler.compile import compile_world
from tmpc.compiler.state import world_poses
from tmpc.lang.diagnostics import TmpcError
from tmpc.lang.reader_formulas import parse_expr
from tmpc.lang.source import SourceFile
from tmpc.runtime.collision import collision_world
from tmpc.runtime.evaluate import Evaluator, to_json_value
from tmpc.runtime.probe import predicate_at, read_state


def run_eval(args, print_diags) -> int:
    world = open_world(args.input)
    compiled = compile_world(world)
    state = read_state(world, compiled.model, args.state)
    frames = compiled.fk(state.q) if compiled.fk is not None else None
    poses = world_poses(state, compiled.model, frames)
    out: dict = {}
    text_lines = []
    if args.predicate:
        out.update(predicate_at(compiled, state, args.predicate))
        label = "(" + " ".join(args.predicate) + ")"
        text_lines.append(f"{label} = {json.dumps(out['value'])}")
        text_lines.append(f"  distance {out['distance']:.6g}")
        grad = ", ".join(f"{k} {v:+.4g}" for k, v in out["gradient"].items() if abs(v) > 1e-12)
        text_lines.append(f"  gradient (d distance / d q): {grad or 'zero'}")
    if args.expr is not None:
        expr, _ = parse_expr(args.expr)
        label = args.expr
        ev = Evaluator(world.scene, compiled.model, state.q, frames, poses,
                       world.program.scope if world.program else None)
        try:
            raw = ev.value(expr)
            value = to_json_value(raw)
            if isinstance(raw, bool):
                out["distance"] = ev.distance(expr)
        except TmpcError as exc:
            exc.files.setdefault(expr.span.path, SourceFile(expr.span.path, label))
            raise
        out["value"] = value
        text_lines.append(f"{label} = {json.dumps(value)}")
        if "distance" in out:
            text_lines.append(f"  distance {out['distance']:.6g}")
    if args.collisions:
        report = collision_world(world, compiled, args.tolerance).check(
            state.q, poses=state.poses, attached=state.held)
        out["valid"] = bool(report.valid)
        out["collisions"] = [{"a": a, "b": b, "depth": float(d)} for a, b, d in report.pairs]
        if report.valid:
            text_lines.append("collisions: none (the state is valid)")
        else:
            text_lines.append(f"collisions: {len(report.pairs)} colliding pair"
                              f"{'s' if len(report.pairs) != 1 else ''} (the state is invalid)")
            text_lines += [f"  {a} <-> {b} (penetration {d:.4f} m)" for a, b, d in report.pairs]
    if args.json:
        sys.stdout.write(json.dumps(out, indent=2) + "\n")
    else:
        sys.stdout.write("\n".join(text_lines) + "\n")
    return 0
