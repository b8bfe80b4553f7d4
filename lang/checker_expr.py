"""Type checking of tmpc expressions (`:semantics` bodies and `:define` helpers).

Value types: ``scalar``, ``vec3``, ``quat``, ``box``, ``transform``, ``bool``, and objects
(``object:TYPE``). Operator overloads come from :data:`tmpc.lang.symbols.BUILTINS`. Helpers are
inlined, so a helper without parameter annotations is checked at each call with the argument
types of that call (results are memoized per argument-type tuple).
"""

from __future__ import annotations

from tmpc.lang import ast as A
from tmpc.lang import symbols as K
from tmpc.lang.diagnostics import DiagnosticSink, Related, error, warning
from tmpc.lang.reader_common import suggest
from tmpc.lang.scope import Scope, type_keys

ANY_OBJECT = "object"


def is_object(t: str | None) -> bool:
    return t is not None and (t == ANY_OBJECT or t.startswith("object:"))


def show(t: str) -> str:
    return f"object of type `{t[7:]}`" if t.startswith("object:") else f"`{t}`"


class _Env:
    """Variable -> value type; ``static`` vars are bound to static values (objects, numbers)."""

    def __init__(self, types: dict[str, str], static: set[str]):
        self.types, self.static = types, static

    def child(self, extra: dict[str, str], static: set[str]) -> "_Env":
        return _Env({**self.types, **extra}, self.static | static)


class ExprChecker:
    def __init__(self, scope: Scope, sink: DiagnosticSink):
        self.scope, self.sink = scope, sink
        self._helper_results: dict[tuple, str | None] = {}
        self._active: list[str] = []

    def err(self, code, msg, span, hint=None, related=()):
        self.sink.add(error(code, msg, span, hint, related))

    # ---- entry points --------------------------------------------------------------------
    def check_semantics(self, p: A.PredicateDecl) -> None:
        env = _Env({q.name.key: _param_type(q) for q in p.params},
                   {q.name.key for q in p.params})
        t = self.expr(p.semantics, env)
        if t is not None and t != K.BOOL:
            self.err("E303", f"the `:semantics` of `{p.name.text}` must be a condition (bool), "
                     f"but it is {show(t)}", p.semantics.span,
                     "compare it, e.g. `(<= (distance ...) 0.1)`")

    def check_helper_definition(self, h: A.DefineDecl) -> None:
        """Check a helper on its own when all its parameters are annotated."""
        for q in h.params:
            if q.type is not None and len(q.type.names) == 1 and \
                    q.type.names[0].key not in K.VALUE_TYPES and \
                    q.type.names[0].key not in self.scope.types:
                self.err("E203", f"unknown type `{q.type.names[0].text}`", q.type.span,
                         "helper parameters take a PDDL type or one of " + ", ".join(K.VALUE_TYPES))
        if all(q.type is not None for q in h.params):
            self.helper_result(h, tuple(_param_type(q) for q in h.params), None)

    # ---- expressions ---------------------------------------------------------------------
    def expr(self, e: A.Expr, env: _Env) -> str | None:
        if isinstance(e, A.Num):
            return K.S
        if isinstance(e, A.ExprVar):
            t = env.types.get(e.name.key)
            if t is None:
                self.err("E205", f"unknown variable `{e.name.text}`", e.span,
                         suggest(e.name.key, env.types))
            return t
        if isinstance(e, A.ExprName):
            return self.name(e)
        if isinstance(e, A.Let):
            extra, static = {}, set()
            for b in e.bindings:
                t = self.expr(b.value, env)
                extra[b.name.key] = t
                if self.is_static(b.value, env):
                    static.add(b.name.key)
            return self.expr(e.body, env.child(extra, static))
        if isinstance(e, A.If):
            return self.if_expr(e, env)
        if isinstance(e, A.ExprQuant):
            extra = {}
            for q in e.params:
                for n in (q.type.names if q.type else ()):
                    if n.key not in self.scope.types:
                        self.err("E203", f"unknown type `{n.text}`", n.span)
                extra[q.name.key] = _param_type(q)
            t = self.expr(e.body, env.child(extra, set(extra)))
            if t is not None and t != K.BOOL:
                self.err("E300", f"the body of `{e.kind}` must be a condition, found {show(t)}",
                         e.body.span)
            return K.BOOL
        return self.call(e, env)

    def name(self, e: A.ExprName) -> str | None:
        info = self.scope.objects.get(e.name.key)
        if info is not None:
            return "object:" + info.types[0]
        if e.name.key in K.NUMBER_CONSTANTS:
            return K.S
        self.err("E206", f"unknown name `{e.name.text}` in an expression", e.span,
                 suggest(e.name.key, list(self.scope.objects) + list(K.NUMBER_CONSTANTS)) or
                 "objects used in semantics must be domain constants; parameters start with `?`")
        return None

    def if_expr(self, e: A.If, env: _Env) -> str | None:
        ct = self.expr(e.cond, env)
        if ct is not None and ct != K.BOOL:
            self.err("E300", f"the condition of `if` must be a condition, found {show(ct)}",
                     e.cond.span)
        elif not self.is_static(e.cond, env):
            self.err("E302", "the condition of `if` must be static (objects, numbers, scene "
                     "data), not the robot or object state", e.cond.span,
                     "use `or`/`and` for state-dependent choices; they have distances")
        a, b = self.expr(e.then, env), self.expr(e.orelse, env)
        if a is not None and b is not None and a != b and not (is_object(a) and is_object(b)):
            self.err("E300", f"the branches of `if` differ: {show(a)} and {show(b)}", e.span)
        return a if a is not None else b

    def is_static(self, e: A.Expr, env: _Env) -> bool:
        if isinstance(e, A.Num):
            return True
        if isinstance(e, A.ExprVar):
            return e.name.key in env.static
        if isinstance(e, A.ExprName):
            return True
        if isinstance(e, A.Call):
            if e.op.key in K.COMPONENTS and len(e.args) == 1:
                # `(z v)` of a static vector is static; `(z ?obj)` reads the object's position
                return self.is_static(e.args[0], env) and not self._is_object_ref(e.args[0], env)
            if e.op.key in K.STATE_ACCESSORS:
                return False
            if self.scope.helper(e.op.key) is not None:
                return False   # conservative: helpers may read state
            if e.op.key in self.scope.predicates:
                return False
            return all(self.is_static(a, env) for a in e.args)
        if isinstance(e, A.Let):
            return all(self.is_static(b.value, env) for b in e.bindings) and \
                self.is_static(e.body, env.child({}, {b.name.key for b in e.bindings}))
        if isinstance(e, A.If):
            return all(self.is_static(x, env) for x in (e.cond, e.then, e.orelse))
        return False

    def _is_object_ref(self, e: A.Expr, env: _Env) -> bool:
        if isinstance(e, A.ExprVar):
            return is_object(env.types.get(e.name.key))
        if isinstance(e, A.ExprName):
            return e.name.key in self.scope.objects
        if isinstance(e, (A.If, A.Let)):
            return True   # conservative
        return False

    # ---- calls -----------------------------------------------------------------------------
    def call(self, e: A.Call, env: _Env) -> str | None:
        op = e.op.key
        if op == "joint":
            return self.joint_call(e)
        if op in K.BUILTINS:
            args = [self.expr(a, env) for a in e.args]
            if any(a is None for a in args):
                return None
            if op == "/":
                for d in e.args[1:]:
                    if isinstance(d, A.Num) and d.value == 0:
                        self.sink.add(warning(
                            "W301", "division by a constant zero: the value is always +inf, "
                            "-inf or nan (0/0), in the planner and the validator alike", d.span,
                            "see docs/language.md (division); a comparison with nan is false"))
            return self.overload(e, K.BUILTINS[op], args)
        helper = self.scope.helper(op)
        if helper is not None:
            args = [self.expr(a, env) for a in e.args]
            if len(args) != len(helper.params):
                self.err("E202", f"helper `{helper.name.text}` takes {len(helper.params)} "
                         f"arguments, given {len(args)}", e.span,
                         related=[Related(helper.span, "defined here")])
                return None
            if any(a is None for a in args):
                return None
            return self.helper_result(helper, tuple(args), e)
        pred = self.scope.predicates.get(op)
        if pred is not None:
            return self.predicate_call(e, pred, env)
        self.err("E301", f"unknown operator `{e.op.text}`", e.op.span,
                 suggest(op, [*K.BUILTINS, *self.scope.helpers, *self.scope.module_helpers]) or
                 "see docs/language.md for the built-in operators; helpers come from `:define`")
        return None

    def joint_call(self, e: A.Call) -> str | None:
        if len(e.args) != 1 or not isinstance(e.args[0], A.ExprName):
            self.err("E300", "`joint` takes the name of a robot joint: `(joint torso_lift_joint)`",
                     e.span)
            return None
        return K.S

    def overload(self, e: A.Call, sigs: tuple[K.Signature, ...], args: list[str]) -> str | None:
        for sig in sigs:
            if _matches(sig, args):
                return sig.result
        shown = ", ".join(show(a) for a in args) or "no arguments"
        expected = " or ".join("(" + " ".join(s.args) + (" ..." if s.variadic else "") + ")"
                               for s in sigs)
        self.err("E300", f"`{e.op.text}` cannot take {shown}", e.span,
                 f"`{e.op.text}` takes {expected}")
        return None

    def predicate_call(self, e: A.Call, pred: A.PredicateDecl, env: _Env) -> str | None:
        if pred.kind is not A.Kind.GEOMETRIC:
            self.err("E401", f"`{pred.name.text}` is a {pred.kind.value} predicate; a `:semantics` "
                     "body may use only geometry", e.op.span,
                     "discrete facts belong in the action's precondition",
                     related=[Related(pred.span, "declared here")])
            return K.BOOL
        if len(e.args) != len(pred.params):
            self.err("E202", f"`{pred.name.text}` takes {len(pred.params)} arguments, given "
                     f"{len(e.args)}", e.span, related=[Related(pred.span, "declared here")])
            return K.BOOL
        for a, q in zip(e.args, pred.params):
            t = self.expr(a, env)
            if t is None:
                continue
            if not is_object(t):
                self.err("E300", f"`{pred.name.text}` takes objects, found {show(t)}", a.span)
            elif t != ANY_OBJECT and not self.scope.compatible((t[7:],), type_keys(q.type)):
                self.err("E204", f"{show(t)} does not fit `{q.name.text}` of "
                         f"`{pred.name.text}`", a.span)
        return K.BOOL

    def helper_result(self, h: A.DefineDecl, args: tuple[str, ...], call: A.Call | None):
        key = (h.name.key, args)
        if key in self._helper_results:
            return self._helper_results[key]
        if h.name.key in self._active:
            self.err("E304", f"helper `{h.name.text}` calls itself; helpers are inlined and "
                     "cannot recurse", call.span if call else h.span)
            return None
        for a, q in zip(args, h.params):
            want = _param_type(q) if q.type is not None else None
            if want is not None and not _fits(a, want, self.scope):
                self.err("E300", f"helper `{h.name.text}` expects {show(want)} for "
                         f"`{q.name.text}`, given {show(a)}", call.span if call else q.span,
                         related=[Related(q.span, "parameter declared here")])
                return None   # the body is not to blame; don't cascade into it
        env = _Env({q.name.key: a for q, a in zip(h.params, args)},
                   {q.name.key for q, a in zip(h.params, args) if is_object(a)})
        self._active.append(h.name.key)
        before = len(self.sink.items)
        result = self.expr(h.body, env)
        self._active.pop()
        if call is not None and len(self.sink.items) > before:
            # Point at the call too: the helper body is correct for other argument types.
            self.sink.rewrite_from(before, lambda d: error(
                d.code, d.message, d.span, d.hint,
                d.related + (Related(call.span, "in this use of the helper"),)))
        self._helper_results[key] = result
        return result


def _param_type(q: A.Typed) -> str:
    if q.type is None or not q.type.names:
        return ANY_OBJECT
    key = q.type.names[0].key
    return key if key in K.VALUE_TYPES else "object:" + key


def _fits(actual: str, want: str, scope: Scope) -> bool:
    if is_object(want):
        return is_object(actual) and (want == ANY_OBJECT or actual == ANY_OBJECT or
                                      scope.compatible((actual[7:],), (want[7:],)))
    return actual == want


def _matches(sig: K.Signature, args: list[str]) -> bool:
    want = list(sig.args)
    if sig.variadic:
        if len(args) < len(want):
            return False
        want = want + [want[-1]] * (len(args) - len(want))
    if len(want) != len(args):
        return False
    return all((w == ANY_OBJECT and is_object(a)) or w == a for w, a in zip(want, args))
