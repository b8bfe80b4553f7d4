"""Inner bands: what projection aims for inside a two-sided tolerance band, so that a sampled
configuration lands in the band's middle rather than on the edge it entered by.

A condition like ``rests-on``'s gap, ``(and ... (>= g 0) (<= g 0.008))``, holds anywhere in
[0, 8 mm]; projection stops at the first configuration where it holds, which is the edge it
came from (a released object 8 mm up). :func:`inner_bands` rewrites, inside each ``and``, every
pair of constant bounds on the same expression (``lo <= x``, ``x <= hi``, ``hi > lo``) to the
middle quarter of the band, ``[lo + 3w/8, hi - 3w/8]``; and every alignment, ``(>= (dot u v)
(cos tol))`` with ``u`` and ``v`` unit vectors (the stdlib's ``aligned``, ``upright``), a band
[0, tol] on the angle, to its first quarter, ``(cos tol/4)`` (a released object upright, not
tilted by the whole tolerance). Only the projector's *distance* uses the
rewritten condition: its truth test, and every other kernel, keep the original, so what holds is
unchanged and a start that reaches the band but not its middle within the iterations still
counts.
"""

from __future__ import annotations

from dataclasses import replace

from tmpc.compiler import ir

#: the fraction of a band's width kept off each of its edges
MARGIN = 3 / 8


def inner_bands(node: ir.Node, positive: bool = True) -> ir.Node:
    """``node`` with the constant two-sided bands of its conjunctions narrowed (above); only
    where they must hold (``positive``): under a ``not`` a narrower band would let projection
    stop inside the real one, where the condition is false."""
    if isinstance(node, ir.Op):
        if node.op == "not":
            args = (inner_bands(node.args[0], not positive),)
        elif node.op == "implies":
            args = (inner_bands(node.args[0], not positive), inner_bands(node.args[1], positive))
        else:
            args = tuple(inner_bands(a, positive) for a in node.args)
        if node.op == "and" and positive:
            args = _narrowed(args)
        out = ir.Op(node.op, args, node.vtype) if args != node.args else node
        return (_alignment(out) or out) if positive else out
    if isinstance(node, ir.If):
        return ir.If(node.cond, inner_bands(node.then, positive),
                     inner_bands(node.orelse, positive))
    if isinstance(node, ir.Quant):
        body = inner_bands(node.body, positive)
        return node if body is node.body else replace(node, body=body)
    return node


def _bound(n: ir.Node):
    """(expression, constant, side) of a comparison with one constant side: side ``"lo"`` for
    ``c <= x`` / ``x >= c``, ``"hi"`` for ``x <= c`` / ``c >= x``; None otherwise."""
    if not isinstance(n, ir.Op) or n.op not in ("le", "lt", "ge", "gt"):
        return None
    a, b = n.args
    upper = n.op in ("le", "lt")            # a <= b
    if isinstance(b, ir.Const) and isinstance(b.value, float | int) and \
            not isinstance(a, ir.Const):
        return a, float(b.value), "hi" if upper else "lo"
    if isinstance(a, ir.Const) and isinstance(a.value, float | int) and \
            not isinstance(b, ir.Const):
        return b, float(a.value), "lo" if upper else "hi"
    return None


def _alignment(n: ir.Node) -> ir.Node | None:
    """``(>= (dot u v) (cos tol/4))`` for an alignment ``(>= (dot u v) (cos tol))`` of unit
    vectors (each divided by its norm) and a constant ``tol``; None for anything else."""
    if not (isinstance(n, ir.Op) and n.op == "ge" and isinstance(n.args[0], ir.Op)
            and n.args[0].op == "dot" and isinstance(n.args[1], ir.Op)
            and n.args[1].op == "cos" and isinstance(n.args[1].args[0], ir.Const)):
        return None
    if not all(isinstance(v, ir.Op) and v.op == "div" and isinstance(v.args[1], ir.Op)
               and v.args[1].op == "norm" for v in n.args[0].args):
        return None
    tol = n.args[1].args[0]
    if not isinstance(tol.value, float | int) or tol.value <= 0:
        return None
    cos = ir.Op("cos", (ir.Const(float(tol.value) / 4, tol.vtype),), n.args[1].vtype)
    return ir.Op("ge", (n.args[0], cos), n.vtype)


def _narrowed(parts: tuple[ir.Node, ...]) -> tuple[ir.Node, ...]:
    bounds = [_bound(p) for p in parts]
    out = list(parts)
    for i, bi in enumerate(bounds):
        if bi is None or bi[2] != "lo":
            continue
        for j, bj in enumerate(bounds):
            if bj is None or bj[2] != "hi" or bj[0] != bi[0] or not bj[1] > bi[1]:
                continue
            w = bj[1] - bi[1]
            out[i] = _with_constant(parts[i], bi[1] + MARGIN * w)
            out[j] = _with_constant(parts[j], bj[1] - MARGIN * w)
    return tuple(out)


def _with_constant(cmp: ir.Op, value: float) -> ir.Op:
    a, b = cmp.args
    if isinstance(b, ir.Const):
        return ir.Op(cmp.op, (a, ir.Const(value, b.vtype)), cmp.vtype)
    return ir.Op(cmp.op, (ir.Const(value, a.vtype), b), cmp.vtype)
