"""Readers for PDDL formulas, effects, numeric expressions and tmpc expressions."""

from __future__ import annotations

from tmpc.lang import ast as A
from tmpc.lang import symbols as K
from tmpc.lang.diagnostics import DiagnosticSink, ParseError, error
from tmpc.lang.reader_common import (
    ReaderBase,
    describe,
    head,
    is_keyword,
    is_number,
    is_sym,
    is_var,
    packed_facts,
    plain_goal_pred,
    suggest,
    sym,
)
from tmpc.lang.sexpr import Packed, SAtom, SExpr, SList, depth_error, parse_sexpr
from tmpc.lang.source import SourceFile


class FormulaReader(ReaderBase):
    # ---- goal descriptions -----------------------------------------------------------------
    def formula(self, x: SExpr) -> A.Formula | None:
        if not isinstance(x, SList):
            hint = f"write `({x.text})` for a zero-argument atom" if is_sym(x) and \
                not is_keyword(x) else None
            self.err("E111", f"expected a formula in parentheses, found {describe(x)}", x.span, hint)
            return None
        if not x.items:
            return A.And((), span=x.span)
        h = head(x)
        if h is None:
            self.err("E111", f"a formula starts with a name, found {describe(x.items[0])}",
                     x.items[0].span)
            return None
        args = x.items[1:]
        if h == "and" and isinstance(args, Packed):
            # a large goal: its atoms stay in the columns, as a large `:init`'s facts do
            return A.And(packed_facts(args, plain_goal_pred, False, self.formula), span=x.span)
        if h in ("and", "or"):
            parts = tuple(p for p in (self.formula(a) for a in args) if p is not None)
            return (A.And if h == "and" else A.Or)(parts, span=x.span)
        if h == "not":
            if len(args) != 1:
                return self._arity(x, "`not` takes exactly one formula")
            part = self.formula(args[0])
            return A.Not(part, span=x.span) if part else None
        if h == "imply":
            if len(args) != 2:
                return self._arity(x, "`imply` takes two formulas")
            left, right = self.formula(args[0]), self.formula(args[1])
            return A.Imply(left, right, span=x.span) if left and right else None
        if h in ("exists", "forall"):
            return self._quantified(x, h, self.formula,
                                    lambda p, b: A.Quantified(h, p, b, span=x.span))
        if h in K.NUMERIC_COMPARISONS:
            return self._comparison(x, h)
        if is_keyword(x.items[0]):
            return self._misplaced_keyword(x.items[0])
        return self.atom(x)

    def _arity(self, x: SList, msg: str) -> None:
        self.err("E111", msg, x.span)
        return None

    def _misplaced_keyword(self, kw: SAtom) -> None:
        self.err("E111", f"`{kw.text}` cannot start a formula", kw.span,
                 "a section keyword here usually means a `)` is missing before it")
        return None

    def _quantified(self, x: SList, kind: str, body_reader, make):
        """``(kind (typed vars) body)``; ``make(params, body)`` builds the node."""
        if len(x.items) != 3 or not isinstance(x.items[1], SList):
            self.err("E111", f"`{kind}` is written `({kind} (?x - type ...) body)`", x.span)
            return None
        params = self.typed_list(x.items[1].items, True, f"the `{kind}` variables")
        body = body_reader(x.items[2])
        return make(params, body) if body is not None else None

    def _comparison(self, x: SList, op: str) -> A.Formula | None:
        if len(x.items) != 3:
            return self._arity(x, f"`{op}` compares exactly two things")
        left, right = x.items[1], x.items[2]
        if op == "=" and _is_term(left) and _is_term(right):
            lt, rt = self.term(left), self.term(right)
            return A.Equals(lt, rt, span=x.span) if lt and rt else None
        ln, rn = self.num_expr(left), self.num_expr(right)
        return A.Compare(op, ln, rn, span=x.span) if ln and rn else None

    def atom(self, x: SList) -> A.Atom | None:
        pred = x.items[0]
        if not is_sym(pred) or is_var(pred) or is_number(pred):
            self.err("E111", f"expected a predicate name, found {describe(pred)}", pred.span)
            return None
        args = []
        for a in x.items[1:]:
            t = self.term(a)
            if t is None:
                return None
            args.append(t)
        return A.Atom(A.Name(pred.text, span=pred.span), tuple(args), span=x.span)

    # ---- numeric expressions ---------------------------------------------------------------
    def num_expr(self, x: SExpr) -> A.NumExpr | None:
        if is_number(x):
            return self.number(x)
        if isinstance(x, SList) and x.items:
            h = head(x)
            if h in K.NUMERIC_OPS and len(x.items) >= 2:
                args = [self.num_expr(a) for a in x.items[1:]]
                if any(a is None for a in args):
                    return None
                return A.NumOp(h, tuple(args), span=x.span)
            return self.func_term(x)
        if is_sym(x) and not is_var(x) and not is_keyword(x):
            # PDDL allows a zero-ary function written without parentheses in some tools.
            return A.FuncTerm(A.Name(x.text, span=x.span), (), span=x.span)
        self.err("E113", f"expected a number or a numeric fluent, found {describe(x)}", x.span)
        return None

    def func_term(self, x: SList) -> A.FuncTerm | None:
        at = self.atom(x)
        return A.FuncTerm(at.pred, at.args, span=x.span) if at else None

    # ---- effects ---------------------------------------------------------------------------
    def effect(self, x: SExpr) -> A.Effect | None:
        if not isinstance(x, SList):
            self.err("E112", f"expected an effect in parentheses, found {describe(x)}", x.span)
            return None
        if not x.items:
            return A.AndEffect((), span=x.span)
        h = head(x)
        args = x.items[1:]
        if h == "and":
            parts = tuple(p for p in (self.effect(a) for a in args) if p is not None)
            return A.AndEffect(parts, span=x.span)
        if h == "not":
            if len(args) != 1 or not isinstance(args[0], SList):
                self.err("E112", "`not` in an effect takes one atom: `(not (p ?x))`", x.span)
                return None
            at = self.atom(args[0]) if args[0].items else None
            return A.DelEffect(at, span=x.span) if at else None
        if h == "forall":
            return self._quantified(x, "forall", self.effect,
                                    lambda p, b: A.ForallEffect(p, b, span=x.span))
        if h == "when":
            if len(args) != 2:
                self.err("E112", "`when` is written `(when condition effect)`", x.span)
                return None
            cond, body = self.formula(args[0]), self.effect(args[1])
            return A.WhenEffect(cond, body, span=x.span) if cond and body else None
        if h in K.NUMERIC_EFFECTS:
            return self._numeric_effect(x, h)
        if h in ("or", "exists", "imply") or h in K.NUMERIC_COMPARISONS:
            self.err("E112", f"`{h}` is not allowed in an effect", x.items[0].span,
                     "effects are atoms, `(not atom)`, `and`, `forall`, `when` and "
                     "`increase`/`decrease`")
            return None
        if h is not None and is_keyword(x.items[0]):
            return self._misplaced_keyword(x.items[0])
        at = self.atom(x)
        return A.AddEffect(at, span=x.span) if at else None

    def _numeric_effect(self, x: SList, op: str) -> A.NumericEffect | None:
        if len(x.items) != 3 or not isinstance(x.items[1], SList) or not x.items[1].items:
            self.err("E112", f"`{op}` is written `({op} (fluent ...) value)`", x.span)
            return None
        target = self.func_term(x.items[1])
        value = self.num_expr(x.items[2])
        return A.NumericEffect(op, target, value, span=x.span) if target and value else None

    # ---- tmpc expressions ------------------------------------------------------------------
    def expr(self, x: SExpr) -> A.Expr | None:
        if isinstance(x, SAtom):
            if x.kind != "symbol":
                self.err("E113", f"expected an expression, found {describe(x)}", x.span)
                return None
            if is_number(x):
                return self.number(x)
            if is_var(x):
                return A.ExprVar(A.Name(x.text, span=x.span), span=x.span)
            if is_keyword(x):
                self.err("E113", f"`{x.text}` cannot appear in an expression", x.span,
                         "a section keyword here usually means a `)` is missing before it")
                return None
            return A.ExprName(A.Name(x.text, span=x.span), span=x.span)
        if not x.items:
            self.err("E113", "empty `()` is not an expression", x.span)
            return None
        h = head(x)
        if h is None or is_var(x.items[0]) or is_number(x.items[0]):
            self.err("E113", f"an expression list starts with an operator, found "
                     f"{describe(x.items[0])}", x.items[0].span)
            return None
        if h == "let":
            return self._let(x)
        if h == "if":
            if len(x.items) != 4:
                self.err("E113", "`if` is written `(if condition then else)`", x.span)
                return None
            parts = [self.expr(a) for a in x.items[1:]]
            return A.If(*parts, span=x.span) if all(parts) else None
        if h in ("forall", "exists"):
            return self._quantified(x, h, self.expr,
                                    lambda p, b: A.ExprQuant(h, p, b, span=x.span))
        if is_keyword(x.items[0]):
            self.err("E113", f"`{x.items[0].text}` cannot start an expression", x.items[0].span,
                     suggest(x.items[0].text, K.PREDICATE_ANNOTATIONS) or
                     "a section keyword here usually means a `)` is missing before it")
            return None
        args = [self.expr(a) for a in x.items[1:]]
        if any(a is None for a in args):
            return None
        op = x.items[0]
        return A.Call(A.Name(op.text, span=op.span), tuple(args), span=x.span)

    def _let(self, x: SList) -> A.Let | None:
        if len(x.items) != 3 or not isinstance(x.items[1], SList):
            self.err("E113", "`let` is written `(let ((?v value) ...) body)`", x.span)
            return None
        bindings = []
        for b in x.items[1].items:
            if not (isinstance(b, SList) and len(b.items) == 2):
                self.err("E113", "a `let` binding is written `(?v value)`", b.span)
                return None
            nm = self.var(b.items[0], "a ?variable to bind")
            val = self.expr(b.items[1])
            if nm is None or val is None:
                return None
            bindings.append(A.Binding(nm, val, span=b.span))
        body = self.expr(x.items[2])
        return A.Let(tuple(bindings), body, span=x.span) if body else None


def _is_term(x: SExpr) -> bool:
    return is_sym(x) and not is_number(x) and not is_keyword(x) and sym(x) not in K.NUMERIC_OPS


def parse_expr(text: str) -> tuple[A.Expr, SourceFile]:
    """One expression from a command line (``tmpc eval --expr``), read as in a ``:semantics``
    body; its source is ``<expr>``."""
    src = SourceFile("<expr>", text)
    deep = depth_error(src)
    if deep is not None:
        raise ParseError([deep], {src.path: src})
    doc = parse_sexpr(src)
    sink = DiagnosticSink(list(doc.diagnostics))
    if len(doc.items) != 1 and not sink.has_errors:
        sink.add(error("E113", "expected exactly one expression", src.span(0, len(text))))
    reader = FormulaReader(sink)
    value = reader.expr(doc.items[0]) if doc.items else None
    if sink.has_errors or value is None:
        raise ParseError(sink.items or [error("E113", "empty expression", None)], {src.path: src})
    return value, src
