"""`tmpc eval INPUT --state S.json (--expr EXPR | --predicate NAME ARG...) [--collisions]`.

Evaluates at one state: an expression's value (positions in the world frame, from forward
kinematics), a geometric predicate's truth, and with ``--collisions`` whether the state is valid
and every colliding pair. (Distances and gradients arrive with the compiler's kernels.)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from tmpc.lang import ast as A
from tmpc.lang.diagnostics import DiagnosticSink, InputError, ParseError, TmpcError, error
from tmpc.lang.source import SourceFile


def parse_expr(text: str) -> tuple[A.Expr, SourceFile]:
    from tmpc.lang.reader_formulas import FormulaReader
    from tmpc.lang.sexpr import parse_sexpr
    src = SourceFile("<expr>", text)
    doc = parse_sexpr(src)
    sink = DiagnosticSink(list(doc.diagnostics))
    if len(doc.items) != 1 and not sink.has_errors:
        sink.add(error("E113", "expected exactly one expression", src.span(0, len(text))))
    reader = FormulaReader(sink)
    value = reader.expr(doc.items[0]) if doc.items else None
    if sink.has_errors or value is None:
        raise ParseError(sink.items or [error("E113", "empty expression", None)], {src.path: src})
    return value, src


def read_state(world, path: str | None):
    from tmpc.compiler.state import initial_state, state_from_json
    base = initial_state(world.scene, world.model)
    if path is None:
        return base
    try:
        text = sys.stdin.read() if path == "-" else Path(path).read_text(encoding="utf-8")
        data = json.loads(text)
    except OSError as exc:
        raise InputError(error("E010", f"cannot read {path}: {exc.strerror}", None)) from None
    except json.JSONDecodeError as exc:
        raise InputError(error("E580", f"{path}:{exc.lineno}:{exc.colno}: not valid JSON: "
                               f"{exc.msg}", None)) from None
    return state_from_json(data, world.scene, world.model, base, path)


def _predicate_kernel_eval(world, state, request: list[str]) -> dict:
    """Truth, distance and gradient of a geometric predicate, from its compiled kernel."""
    from tmpc.compiler.compile import CompiledProgram
    from tmpc.compiler.jaxcfg import configured
    from tmpc.compiler.jaxgen import state_inputs
    from tmpc.runtime.sample_command import load_external
    if world.program is None:
        raise InputError(error("E582", "--predicate needs a domain: pass a run configuration "
                               "(manifest TOML, planet TOML or tmit-star spec)", None))
    compiled = CompiledProgram(world.program, world.scene, world.model,
                               external=load_external(world))
    formula = compiled.predicate(request[0])
    ids = compiled.bind_args(formula, request[1:])
    kernel, _ = compiled.kernels(formula)
    q, obj_T, parent = state_inputs(compiled.world, state)
    truth, dist = kernel(q, obj_T, parent, ids)
    jax = configured()
    grad = jax.grad(lambda q: kernel(q, obj_T, parent, ids)[1])(q) if len(q) else []
    names = world.model.q_names if world.model is not None else ()
    return {"value": bool(truth), "distance": float(dist),
            "gradient": {n: float(g) for n, g in zip(names, grad)}}


def run_eval(args, print_diags) -> int:
    from tmpc.runtime.evaluate import Evaluator, to_json_value
    from tmpc.runtime.world import load_world
    from tmpc.compiler.state import world_poses
    world = load_world(args.input)
    state = read_state(world, args.state)
    frames = world.fk(state.q) if world.fk is not None else None
    poses = world_poses(state, world.model, frames)
    out: dict = {}
    text_lines = []
    if args.predicate:
        out.update(_predicate_kernel_eval(world, state, args.predicate))
        label = "(" + " ".join(args.predicate) + ")"
        text_lines.append(f"{label} = {json.dumps(out['value'])}")
        text_lines.append(f"  distance {out['distance']:.6g}")
        grad = ", ".join(f"{k} {v:+.4g}" for k, v in out["gradient"].items() if abs(v) > 1e-12)
        text_lines.append(f"  gradient (d distance / d q): {grad or 'zero'}")
    if args.expr is not None:
        expr, _ = parse_expr(args.expr)
        label = args.expr
        ev = Evaluator(world.scene, world.model, state.q, frames, poses,
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
        report = world.collision(args.tolerance).check(state.q, poses=state.poses,
                                                       attached=state.held)
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
