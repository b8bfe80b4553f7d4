"""Legacy Lua predicates -> IR, by tracing; direct evaluation when tracing cannot capture one.

:func:`trace_module` calls each predicate function of a :class:`~tmpc.lang.lua.LuaModule` once
with proxy arguments whose fields are IR nodes over :class:`~tmpc.compiler.ir.Arg` slots; the
proxies' metatables and tmpc's ``math``/combinators record every operation, so the result is the
predicate's IR, compiled like native ``:semantics`` afterwards:

* planet (conditions from ``Eq Le Lt Ge Gt And Or Not True False``): the IR condition itself;
* tmit-star (a distance, 0 = satisfied): ``holds(d)``.

Field mappings (argument ``i`` is ``Arg(i)``; ``p = position(pose(Arg i))``,
``q = orientation(pose(Arg i))``, quaternions xyzw)::

    px py pz           component(p, 0|1|2)
    rx ry rz rw        component(q, 0|1|2|3)
    planet  name       the argument's identity: Eq(a.name, b.name) -> same(Arg a, Arg b)
    planet  sssp.region.{x,y,z}.{low,high}
                       component(lower|upper(support_local(Arg i)), axis)   (object frame)
    tmit-star pose.{px..rw}   as px..rw
    tmit-star {x,y,z}_{low,high}
                       component(lower|upper(support(Arg i)), axis) - component(p, axis)

When the function branches on a traced value (``if x.px > 0``), calls a library function with no
IR operator (``math.floor``) or otherwise fails under tracing but runs on numbers, the predicate
gets a :class:`LuaFallback` instead: it evaluates the Lua function at concrete poses with dual
numbers (value + gradient), and a W700 warning names the function and the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from tmpc.compiler import ir
from tmpc.lang import ast as A
from tmpc.lang.diagnostics import Diagnostic, LuaError, Related, error, warning
from tmpc.lang.lua import LuaModule, arity_diagnostic
from tmpc.lang.source import SourceFile

POSE_FIELDS = ("px", "py", "pz", "rx", "ry", "rz", "rw")


@dataclass(eq=False)
class LuaFallback:
    """Direct evaluation of a Lua predicate at concrete argument values.

    ``fb(poses, supports=None, names=None) -> (distance, gradient)``: ``poses`` (k, 7) rows
    ``px py pz rx ry rz rw`` (world frame, quaternion xyzw) of the k arguments; ``supports`` per
    argument ``None`` or ``(lower, upper)`` of its support box in its own frame (the scene's
    support region; required for ``surface`` arguments); ``names`` per argument (needed only if
    the function reads ``name``). ``distance`` >= 0 is 0 where the predicate holds (planet: the
    condition's distance, ``and`` as the l2 norm; tmit-star: ``max(d, 0)``); ``gradient`` (k, 7)
    is d distance / d poses. Not thread-safe (one Lua state per module).
    """

    module: LuaModule
    function: str
    arg_kinds: tuple[str, ...]
    reason: str = ""

    @property
    def nargs(self) -> int:
        return len(self.arg_kinds)

    def __call__(self, poses, supports=None, names=None, *, gradient: bool = True):
        k = self.nargs
        P = np.asarray(poses, dtype=np.float64).reshape(k, 7)
        boxes = [None if s is None else [float(v) for v in np.ravel(s)]
                 for s in (supports if supports is not None else [None] * k)]
        if len(boxes) != k or any(b is not None and len(b) != 6 for b in boxes):
            raise ValueError(f"supports: expected {k} entries of (lower[3], upper[3]) or None")
        out = self.module.evaluate(self.function, [float(v) for v in P.ravel()], boxes,
                                   list(names) if names is not None else [None] * k, gradient)
        if not out.ok:
            raise LuaError(self.module.diagnostic(out, True, self.function,
                                                  self.module.functions[self.function].line),
                           self.module.files)
        value, lua_grad = float(out.values[0]), out.values[1]
        g = np.array([float(lua_grad[i + 1] or 0.0) for i in range(7 * k)]) if gradient \
            else np.zeros(7 * k)
        if self.module.dialect == "tmit-star" and value <= 0:      # holds(d): max(d, 0)
            value, g = 0.0, np.zeros(7 * k)
        return value, g.reshape(k, 7)

    def truth(self, poses, supports=None, names=None, tol: float = 1e-3) -> bool:
        """Holds iff the distance is within ``tol`` (as the compiled kernels decide)."""
        return self(poses, supports, names, gradient=False)[0] <= tol


@dataclass
class TraceResult:
    """Per PDDL predicate name: traced IR (``bool``, over ``Arg`` slots) or a fallback, and
    which arguments were read as surfaces (``"surface"``) or plain objects (``"object"``)."""

    traced: dict[str, ir.Node] = field(default_factory=dict)
    fallbacks: dict[str, LuaFallback] = field(default_factory=dict)
    diagnostics: list[Diagnostic] = field(default_factory=list)
    arg_kinds: dict[str, tuple[str, ...]] = field(default_factory=dict)

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self.diagnostics)


def parse_nodes(text: str) -> list[ir.Node]:
    """The core's serialized nodes (one per line, children first) -> IR nodes by id - 1."""
    nodes: list[ir.Node] = []
    for line in text.split("\n"):
        head, _, rest = line.partition(" ")
        if head == "const":
            nodes.append(ir.Const(float(rest)))
        elif head == "bool":
            nodes.append(ir.Const(float(rest), ir.BOOL))
        elif head == "arg":
            nodes.append(ir.Arg(int(rest)))
        elif head == "entity":
            nodes.append(ir.Entity(rest))
        else:
            vtype, *ids = rest.split(" ")
            nodes.append(ir.op(head, [nodes[int(i) - 1] for i in ids], vtype))
    return nodes


def _sample(nargs: int):
    """A generic point for probing a function on numbers (distinct positions, a small tilt)."""
    poses = []
    for i in range(nargs):
        s, c = math.sin(0.1 + 0.05 * i), math.cos(0.1 + 0.05 * i)
        poses += [0.31 + 0.17 * i, -0.23 + 0.11 * i, 0.52 + 0.07 * i, 0.0, 0.0, s, c]
    box = [-0.4, -0.3, 0.0, 0.4, 0.3, 0.05]
    return poses, [box] * nargs, [f"arg{i + 1}" for i in range(nargs)]


def _wanted(predicates) -> dict[str, tuple[int, object]]:
    """name -> (arity, declaration or None) for the predicates to trace."""
    out = {}
    for name, decl in predicates.items():
        if isinstance(decl, int):
            out[name] = (decl, None)
        elif isinstance(decl, A.PredicateDecl):
            if decl.semantics is not None or decl.kind is not A.Kind.GEOMETRIC:
                continue            # native semantics, or not geometric: nothing to find in Lua
            out[name] = (len(decl.params), decl)
        else:
            raise TypeError(f"predicate {name!r}: expected a PredicateDecl or an arity")
    return out


def trace_module(module: LuaModule, predicates: Mapping[str, A.PredicateDecl | int] | None = None,
                 *, strict: bool = True) -> TraceResult:
    """Trace the Lua functions implementing ``predicates`` (PDDL name -> declaration, or an
    arity; default: every function of the module with its Lua parameter count).

    Declarations with inline semantics or of a non-geometric kind are skipped. With ``strict``
    (default) any error raises :class:`LuaError` carrying every diagnostic; otherwise errors are
    returned in ``diagnostics`` and the failing predicates are left out.
    """
    if predicates is None:
        predicates = {n: f.nparams for n, f in module.functions.items()}
    result = TraceResult()
    for name, (nargs, decl) in _wanted(predicates).items():
        _trace_one(module, name, nargs, decl, result)
    if strict and result.has_errors:
        raise LuaError(result.diagnostics, _files(module, result.diagnostics))
    return result



def _files(module: LuaModule, diags: list[Diagnostic]) -> dict:
    """The Lua file and the PDDL files the diagnostics point into (a declaration's span), so the
    CLI shows the predicate's line and column, not only the domain's path."""
    files = dict(module.files)
    for d in diags:
        for span in (d.span, *(r.span for r in d.related)):
            if span is not None and span.path not in files:
                try:
                    files[span.path] = SourceFile.read(span.path)
                except (OSError, UnicodeDecodeError):
                    pass
    return files

def _trace_one(module: LuaModule, name: str, nargs: int, decl, result: TraceResult) -> None:
    diags = result.diagnostics
    span = getattr(decl, "span", None)
    fname = module.lookup(name)
    if fname is None:
        known = ", ".join(module.names) or "none"
        diags.append(error("E707", f"no Lua function for geometric predicate `{name}` in "
                           f"{module.path}", span, f"the file defines: {known}",
                           [Related(module.line_span(1), "the Lua file")]
                           if module.line_span(1) else []))
        return
    fn = module.functions[fname]
    if not fn.vararg and fn.nparams != nargs:
        diags.append(arity_diagnostic(module, fn, name, nargs, span))
        return
    out = module.trace(fname, nargs)
    if out.ok:
        text, rid, kinds = out.values
        node = parse_nodes(str(text))[int(rid) - 1]
        if module.dialect == "tmit-star":
            node = ir.op("holds", (node,), ir.BOOL)
        result.traced[name] = node
        result.arg_kinds[name] = tuple(str(kinds).split())
        return
    if out.kind not in ("untraceable", "error"):
        diags.append(module.diagnostic(out, True, fname, fn.line))
        return
    poses, boxes, names = _sample(nargs)
    probe = module.evaluate(fname, poses, boxes, names, False)
    if not probe.ok:
        diags.append(module.diagnostic(probe, True, fname, fn.line))
        return
    kinds = tuple(str(probe.values[2]).split())
    reason = out.message if out.kind == "untraceable" else f"tracing failed: {out.message}"
    result.fallbacks[name] = LuaFallback(module, fname, kinds, reason)
    result.arg_kinds[name] = kinds
    diags.append(warning("W700", f"Lua predicate `{fname}` cannot be traced ({reason}); it is "
                         "evaluated directly per state (slower, gradients by dual numbers)",
                         module.line_span(out.line) or module.line_span(fn.line),
                         "branch on static data only, or use math.max/min instead of "
                         "comparisons on the state, to let tmpc compile it"))
