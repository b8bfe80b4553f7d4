"""A compiled condition as text a person reads: the truth test and the unsatisfaction distance.

The language server's hover shows what a geometric predicate *means once compiled*: its IR after
helpers are inlined (and legacy Lua traced), as infix text over the predicate's parameters, and
the distance the kernels minimise, written by the same rules as
:meth:`tmpc.compiler.kernels.emit._Emitter.dist` (docs/math.md §A): a comparison is a hinge, ``=``
an absolute value, ``and`` the l2 norm of its parts (or their max), ``or`` a min, ``not`` pushed to
the leaves. Pure Python over :mod:`tmpc.compiler.ir`: no JAX.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import lru_cache

from tmpc.compiler import ir
from tmpc.compiler.lower import Lowerer
from tmpc.compiler.lua_trace import trace_module
from tmpc.lang import ast as A
from tmpc.lang.diagnostics import TmpcError
from tmpc.lang.lua import load_lua_predicates
from tmpc.lang.scope import Scope

_INFIX = {"add": "+", "sub": "-", "mul": "*", "div": "/"}
_CMP_TEXT = {"le": "<=", "lt": "<", "ge": ">=", "gt": ">", "eq": "="}
_AXIS = "xyz"
_RPY = ("roll", "pitch", "yaw")


@dataclass(frozen=True)
class Explanation:
    """``truth``: the condition as infix text; ``distance``: its unsatisfaction distance."""

    truth: str
    distance: str
    #: what the named functions in ``distance`` mean (e.g. ``box-distance``)
    legend: tuple[str, ...] = ()


def explain(node: ir.Node, params: tuple[str, ...], and_mode: str = "l2") -> Explanation:
    """Text for a condition whose :class:`~tmpc.compiler.ir.Arg` slots are named ``params``."""
    t = _Text(params, and_mode)
    truth, distance = t.cond(node), t.dist(node, False)
    return Explanation(truth, distance, tuple(t.legend.values()))


_BOX_LEGEND = {
    "box-distance": "box-distance(p, B): the Euclidean distance from p to the box B, "
                    "0 inside (the l2 norm of the six face hinges)",
    "box-excess": "box-excess(p, B): the largest face hinge max(lower - p, p - upper, 0)",
    "box-depth": "box-depth(p, B): how far p is inside B: its distance to the nearest face, "
                 "0 outside",
}


def explain_predicate(scope: Scope, decl: A.PredicateDecl, lua_path: str | None = None,
                      and_mode: str = "l2") -> Explanation | str:
    """A geometric predicate's compiled meaning; a sentence saying why when there is none (no
    Lua file for a legacy predicate, tracing fell back to direct evaluation, ...).

    Native bodies are lowered with helpers inlined (pure Python). A legacy predicate is traced
    from ``lua_path`` in tmpc's Lua sandbox (tmpc.lang.lua imports lupa on first use, never when the
    language server starts)."""
    names = tuple(p.name.text for p in decl.params)
    if decl.semantics is not None:
        try:
            return explain(Lowerer(scope).predicate(decl).body, names, and_mode)
        except ValueError as exc:          # a recursive helper: the checker reports it
            return f"cannot lower: {exc}"
    if lua_path is None:
        return "implemented in Lua; no run configuration names a Lua file for this domain"
    try:
        result = _trace_lua(lua_path, decl)
    except TmpcError as exc:
        return "the Lua file does not load: " + "; ".join(d.message for d in exc.diagnostics)
    node = result.traced.get(decl.name.text)
    if node is None:
        why = "; ".join(d.message for d in result.diagnostics) or \
            "tracing could not capture it, so it is evaluated directly (W700)"
        return why
    return explain(node, names, and_mode)


def _trace_lua(path: str, decl: A.PredicateDecl):
    """The predicate traced from the Lua file, reused while the file is unchanged (a hover
    would otherwise build a sandbox and trace the file each time)."""
    try:
        st = os.stat(path)
    except OSError:                       # the loader says what is wrong with the path
        return _traced.__wrapped__(path, 0, 0, decl)
    return _traced(path, st.st_mtime_ns, st.st_size, decl)


@lru_cache(maxsize=64)
def _traced(path: str, mtime_ns: int, size: int, decl: A.PredicateDecl):
    return trace_module(load_lua_predicates(path), {decl.name.text: decl}, strict=False)


class _Text:
    def __init__(self, params: tuple[str, ...], and_mode: str):
        self.params, self.and_mode = params, and_mode
        self.legend: dict[str, str] = {}

    # ---- values -----------------------------------------------------------------------------
    def val(self, n: ir.Node) -> str:
        if isinstance(n, ir.Const):
            return _num(n.value)
        if isinstance(n, ir.Arg):
            return self.params[n.index] if n.index < len(self.params) else f"$arg{n.index}"
        if isinstance(n, ir.Var):
            return f"?v{n.slot}"
        if isinstance(n, ir.Entity):
            return n.name
        if isinstance(n, ir.Joint):
            return f"joint({n.name})"
        if isinstance(n, ir.If):
            return f"(if {self.cond(n.cond)} then {self.val(n.then)} else {self.val(n.orelse)})"
        if isinstance(n, ir.Op):
            return self.op(n)
        return ir.show(n)

    def op(self, n: ir.Op) -> str:
        o, a = n.op, n.args
        if o in _INFIX:
            return f"({self.val(a[0])} {_INFIX[o]} {self.val(a[1])})"
        if o == "neg":
            return f"-{self.val(a[0])}"
        if o == "pose":
            return self.val(a[0])
        if o == "component" and isinstance(a[1], ir.Const):
            i = int(a[1].value)
            inner = a[0]
            if isinstance(inner, ir.Op) and inner.op == "rpy" and i < 3:
                return f"{_RPY[i]}({self.val(inner.args[0])})"
            if isinstance(inner, ir.Op) and inner.op == "position" and i < 3:
                return f"{_AXIS[i]}({self.val(inner.args[0])})"
            return f"{self.val(inner)}[{i}]"
        if o == "rotation_axis" and isinstance(a[1], ir.Const):
            return f"{_AXIS[int(a[1].value)]}-axis({self.val(a[0])})"
        if o == "support":
            return f"support-region({self.val(a[0])})"
        if o == "support_local":
            return f"local-support({self.val(a[0])})"
        if o in ("grasp_point", "grasp_axis", "grasp_hand_axis", "stable_up"):
            return f"{o.replace('_', '-')}({self.val(a[0])})"
        if o == "lua":
            return f"lua {self.val(a[0])}({', '.join(self.val(x) for x in a[1:])})"
        if n.type == ir.BOOL:
            return self.cond(n)
        return f"{o}({', '.join(self.val(x) for x in a)})"

    # ---- truth ------------------------------------------------------------------------------
    def cond(self, n: ir.Node) -> str:
        if isinstance(n, ir.Const):
            return "true" if n.value else "false"
        if isinstance(n, ir.Quant):
            return f"({n.kind} ?v{n.slot} - {'|'.join(n.domain)}: {self.cond(n.body)})"
        if isinstance(n, ir.If):
            return (f"(if {self.cond(n.cond)} then {self.cond(n.then)} "
                    f"else {self.cond(n.orelse)})")
        if not isinstance(n, ir.Op):
            return self.val(n)
        o, a = n.op, n.args
        if o in _CMP_TEXT:
            return f"{self.val(a[0])} {_CMP_TEXT[o]} {self.val(a[1])}"
        if o in ("and", "or"):
            return "(" + f" {o} ".join(self.cond(x) for x in a) + ")"
        if o == "not":
            return f"not {self.cond(a[0])}"
        if o == "implies":
            return f"({self.cond(a[0])} implies {self.cond(a[1])})"
        if o == "same":
            return f"{self.val(a[0])} is {self.val(a[1])}"
        if o == "holds":
            return f"{self.val(a[0])} <= tol"
        if o == "inside":
            return f"inside({self.val(a[0])}, {self.val(a[1])})"
        if o == "lua":
            return self.val(n) + " <= tol"
        return self.val(n)

    # ---- distance (mirrors emit._Emitter.dist) ----------------------------------------------
    def dist(self, n: ir.Node, neg: bool) -> str:
        if isinstance(n, ir.Const):
            return "0" if bool(n.value) != neg else "inf"
        if isinstance(n, ir.If):
            return (f"(if {self.cond(n.cond)} then {self.dist(n.then, neg)} "
                    f"else {self.dist(n.orelse, neg)})")
        if isinstance(n, ir.Quant):
            conj = (n.kind == "forall") != neg
            over = f"?v{n.slot} - {'|'.join(n.domain)}"
            body = self.dist(n.body, neg)
            if conj:
                return (f"max over {over} of {body}" if self.and_mode == "max"
                        else f"sqrt(sum over {over} of ({body})^2)")
            return f"min over {over} of {body}"
        if not isinstance(n, ir.Op):
            return self.val(n)
        o, a = n.op, n.args
        if o in ("le", "lt", "ge", "gt"):
            x, y = (a[1], a[0]) if o in ("ge", "gt") else (a[0], a[1])   # x <= y wanted
            if neg:
                x, y = y, x
            return _hinge(self.val(x), y, self.val(y))
        if o == "eq":
            d = f"|{self.val(a[0])} - {self.val(a[1])}|"
            return f"max(tol - {d}, 0)" if neg else d
        if o == "same":
            return f"(0 if {self.val(a[0])} {'is not' if neg else 'is'} {self.val(a[1])} else inf)"
        if o in ("holds", "lua"):
            d = self.val(a[0]) if o == "holds" else self.val(n)
            return f"max(tol - {d}, 0)" if neg else f"max({d}, 0)"
        if o == "inside":
            name = "box-depth" if neg else ("box-excess" if self.and_mode == "max"
                                            else "box-distance")
            self.legend[name] = _BOX_LEGEND[name]
            return f"{name}({self.val(a[0])}, {self.val(a[1])})"
        if o in ("and", "or"):
            parts = [self.dist(x, neg) for x in a]
            return self.conj(parts) if (o == "and") != neg else _call("min", parts)
        if o == "not":
            return self.dist(a[0], not neg)
        if o == "implies":
            parts = [self.dist(a[0], not neg), self.dist(a[1], neg)]
            return self.conj(parts) if neg else _call("min", parts)
        return self.val(n)

    def conj(self, parts: list[str]) -> str:
        if len(parts) == 1:
            return parts[0]
        if self.and_mode == "max":
            return _call("max", parts)
        return "sqrt(" + " + ".join(f"{p}^2" for p in parts) + ")"


def _hinge(x: str, y: ir.Node, y_text: str) -> str:
    """``max(x - y, 0)``, without the ``- 0``."""
    if isinstance(y, ir.Const) and y.value == 0:
        return f"max({x}, 0)"
    return f"max({x} - {y_text}, 0)"


def _call(name: str, parts: list[str]) -> str:
    return parts[0] if len(parts) == 1 else f"{name}({', '.join(parts)})"


def _num(v) -> str:
    if isinstance(v, tuple):
        return "(" + ", ".join(_num(x) for x in v) + ")"
    if v == float("inf"):
        return "inf"
    return f"{float(v):g}"
