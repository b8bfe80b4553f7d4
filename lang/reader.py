"""Level 2 of the parser: s-expression tree -> AST (domains, problems, modules).

Structural mistakes get their own codes and hints (docs/diagnostics.md). The reader never raises
on bad input: it records a diagnostic, skips the offending form and goes on, so one file yields
all its errors and a partial AST.
"""

from __future__ import annotations

import gc
import re
from contextlib import contextmanager
from dataclasses import dataclass, field

from tmpc.lang import ast as A
from tmpc.lang import symbols as K
from tmpc.lang.diagnostics import Diagnostic, DiagnosticSink, Related, warning
from tmpc.lang.columns import InitFacts
from tmpc.lang.reader_common import (
    describe,
    head,
    is_keyword,
    is_sym,
    packed_facts,
    plain_init_pred,
    suggest,
    sym,
)
from tmpc.lang.reader_formulas import FormulaReader
from tmpc.lang.sexpr import Packed, SAtom, SExpr, SexprDoc, SList, depth_error, parse_sexpr
from tmpc.lang.source import SourceFile, Span

#: what `(define (KIND NAME) ...)` may define
DEFINITION_KINDS = ("domain", "problem", "module", "semantics")
PROBLEM_ONLY = frozenset({":domain", ":objects", ":init", ":goal", ":metric"})
DOMAIN_ONLY = frozenset({":types", ":constants", ":predicates", ":functions", ":action",
                         ":derived", ":include", ":define"})


@dataclass
class ParsedFile:
    """One source file: its definitions (domains, problems, modules) and diagnostics."""

    source: SourceFile
    definitions: list[A.Domain | A.Problem] = field(default_factory=list)
    diagnostics: list[Diagnostic] = field(default_factory=list)
    sexpr: SexprDoc | None = None

    @property
    def ok(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)


def parse_source(source: SourceFile) -> ParsedFile:
    """Parse one file fully (both levels). Never raises for bad input; a file nested deeper
    than :data:`~tmpc.lang.sexpr.MAX_DEPTH` is one E004 and nothing else."""
    deep = depth_error(source)
    if deep is not None:
        return ParsedFile(source, [], [deep], SexprDoc(source, [], [], [deep]))
    with _gc_paused():
        doc = parse_sexpr(source)
        sink = DiagnosticSink(list(doc.diagnostics))
        reader = Reader(sink)
        defs = reader.read(doc)
    diags = sink.items
    if any(d.code == "E001" for d in diags):
        closed = _closed_at_end(source)
        if closed is not None:
            return closed
    if any(getattr(d, "dialect", None) in LEGACY_DIALECTS for d in defs):
        diags = [_legacy_tolerated(d) for d in diags]
    return ParsedFile(source, defs, diags, doc)


_BRACKETS = re.compile(r'(;[^\n]*)|("(?:\\.|[^"\\\n])*")|(\()|(\))')


def _closed_at_end(source: SourceFile) -> ParsedFile | None:
    """A problem file that ends before the `)`s closing its `(define`: the suite of Lagriffoul
    et al. 2018 ships its problems so. When adding them at the end of the file makes it read
    without error as problems only, that reading is kept with warning W510 (a tab-indented line
    would otherwise mislead the indentation-guided repair). None otherwise: the E001 errors
    stand (a domain missing its last `)` is still an error)."""
    text = source.text
    depth, last, start = 0, 0, 0
    for m in _BRACKETS.finditer(text):
        if m.lastindex == 3:
            start = m.start() if depth == 0 else start
            depth += 1
        elif m.lastindex == 4:
            depth -= 1
            if depth < 0:
                return None
        if m.lastindex != 1:
            last = m.end()
    if depth <= 0:
        return None
    tail = text[last:]
    keep = len(tail) - len(tail.lstrip()) >= depth and not tail.strip()
    closed = text[:last] + ")" * depth + (tail[depth:] if keep else tail)
    parsed = parse_source(SourceFile(source.path, closed))
    if not parsed.ok or not parsed.definitions or \
            not all(isinstance(d, A.Problem) for d in parsed.definitions):
        return None
    line, col = source.line_col(start)
    at = Span(source.path, max(0, last - 1), last)
    what = " ".join(text[start + 1:start + 20].split()[:1]) or "("
    w = warning("W510", f"the file ends before the `)` closing `({what}` opened at {line}:{col}"
                f"; {'it is' if depth == 1 else f'{depth} `)` are'} added at the end of the file",
                at, "add the missing `)` at the end of the file",
                related=[Related(Span(source.path, start, start + 1), "unclosed list opens here")])
    return ParsedFile(source, parsed.definitions, [w, *parsed.diagnostics], parsed.sexpr)


@contextmanager
def _gc_paused():
    """The s-expression tree and the AST hold no reference cycles, so while a file is read the
    cyclic collector only costs time: it walks the growing tree again and again. Paused while
    reading; on again after, as it was."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


LEGACY_DIALECTS = (A.Dialect.PLANET, A.Dialect.TMIT_STAR)


def _legacy_tolerated(d: Diagnostic) -> Diagnostic:
    """planet/tmit-star read files with surplus `)`; legacy files must run unchanged, so in a
    legacy-dialect file an extra `)` is a warning (the repaired tree is what they meant)."""
    if d.code != "E002":
        return d
    return warning("W017", d.message + " (tolerated in a legacy planet/tmit-star file)", d.span,
                   d.hint, d.related)


def parse_text(text: str, path: str = "<string>") -> ParsedFile:
    return parse_source(SourceFile(path, text))


class Reader(FormulaReader):
    def __init__(self, sink: DiagnosticSink):
        super().__init__(sink)
        self.glued_candidates: list[SAtom] = []

    # ---- top level -------------------------------------------------------------------------
    def read(self, doc: SexprDoc) -> list[A.Domain | A.Problem]:
        out = []
        for item in doc.items:
            if head(item) == "in-package":
                continue  # PDDL 1.2 files start with a Lisp `(in-package ...)`: nothing to read
            if head(item) == "define":
                d = self.define(item)
                if d is not None:
                    out.append(d)
            else:
                self.err("E101", f"expected `(define ...)` at the top level, found {describe(item)}",
                         item.span, _top_level_hint(item))
        if not doc.items and not doc.diagnostics:
            self.err("E100", "the file contains no `(define ...)`",
                     Span(doc.source.path, 0, 0), "a PDDL file is `(define (domain NAME) ...)` "
                     "or `(define (problem NAME) ...)`")
        return out

    def define(self, x: SList):
        if len(x.items) < 2 or not isinstance(x.items[1], SList) or len(x.items[1].items) != 2:
            self.err("E101", "expected `(define (domain NAME) ...)` or `(define (problem NAME) ...)`",
                     x.span)
            return None
        what, nm = x.items[1].items
        kind = sym(what)
        name = self.name(nm, f"a {kind or 'definition'} name")
        if kind not in DEFINITION_KINDS or name is None:
            if kind not in DEFINITION_KINDS:
                self.err("E101", "expected `domain`, `problem`, `module` or `semantics`, found "
                         f"{describe(what)}", what.span,
                         suggest(what.text if is_sym(what) else "", DEFINITION_KINDS))
            return None
        if kind == "problem":
            return self.problem(name, x)
        return self.domain(name, x, kind)

    def _sections(self, x: SList, allowed: tuple[str, ...], other: frozenset, what: str):
        """Yield (keyword, section list) for each well-formed section; report the rest."""
        seen: dict[str, Span] = {}
        repeatable = {":action", ":derived", ":define", ":include", ":predicates", ":constants",
                      ":types", ":functions", ":requirements"}
        for sec in x.items[2:]:
            if isinstance(sec, SAtom):
                self._stray_in_definition(sec, what)
                continue
            kw = head(sec)
            if kw is None or not kw.startswith(":"):
                self.err("E104", f"expected a section like `(:{allowed[1][1:]} ...)` in the {what}, "
                         f"found {describe(sec)}", sec.span,
                         "a `)` may be missing earlier, or this form belongs inside a section")
                continue
            if kw in other:
                other_what = "problem" if what == "domain" else "domain"
                self.err("E120", f"`{kw}` is a {other_what} section; this is a {what}",
                         sec.items[0].span, f"move it into the {other_what} file")
                continue
            if kw not in allowed:
                self.err("E102", f"unknown section `{sec.items[0].text}` in the {what}",
                         sec.items[0].span, suggest(kw, allowed) or
                         f"sections are {', '.join(allowed)}")
                continue
            if kw in seen and kw not in repeatable:
                self.err("E105", f"duplicate section `{kw}`", sec.items[0].span,
                         related=[Related(seen[kw], "first given here")])
                continue
            seen[kw] = sec.items[0].span
            yield kw, sec

    def _stray_in_definition(self, sec: SAtom, what: str) -> None:
        kw = sym(sec) or ""
        if kw in K.ACTION_ONLY_KEYS:
            self.err("E103", f"`{sec.text}` outside an action: it appears directly in the {what}",
                     sec.span, "a `)` earlier closes the `(:action ...)` too soon; remove it so "
                     f"`{sec.text}` stays inside the action")
        else:
            self.err("E104", f"unexpected {describe(sec)} in the {what}; expected a section "
                     "`(:keyword ...)`", sec.span)

    # ---- domain ----------------------------------------------------------------------------
    def domain(self, name: A.Name, x: SList, form: str) -> A.Domain:
        allowed = ("", ":requirements", ":types", ":constants", ":predicates", ":functions",
                   ":include", ":define", ":action", ":derived")
        target, hands = None, ()
        if form == "semantics":
            allowed += (":domain", ":hand")
        parts: dict[str, list] = {k: [] for k in ("requirements", "types", "constants",
                                                   "predicates", "functions", "includes",
                                                   "defines", "actions", "derived")}
        raw_preds: list[tuple[A.PredicateDecl, set[str]]] = []
        other = PROBLEM_ONLY - {":domain"} if form == "semantics" else PROBLEM_ONLY
        for kw, sec in self._sections(x, allowed, other, form):
            body = sec.items[1:]
            if kw == ":domain":
                target = self._one_name(sec, kw)
            elif kw == ":hand":
                hands += tuple(n for n in (self.name(it, "a frame name") for it in body) if n)
            elif kw == ":requirements":
                parts["requirements"] += self.requirements(body)
            elif kw == ":types":
                parts["types"] += self.types(body)
            elif kw == ":constants":
                parts["constants"] += self.typed_list(body, False, "`:constants`")
            elif kw == ":predicates":
                raw_preds += [p for p in (self.predicate(b) for b in body) if p]
            elif kw == ":functions":
                parts["functions"] += self.functions(body)
            elif kw == ":include":
                parts["includes"] += self.includes(body)
            elif kw == ":define":
                d = self.define_helper(sec)
                if d:
                    parts["defines"].append(d)
            elif kw == ":action":
                a = self.action(sec, form == "semantics")
                if a:
                    parts["actions"].append(a)
            elif kw == ":derived":
                d = self.derived(sec)
                if d:
                    parts["derived"].append(d)
        dialect = _dialect(parts["requirements"], raw_preds, parts)
        preds = tuple(_resolve_kind(p, marks, dialect) for p, marks in raw_preds)
        return A.Domain(name, tuple(parts["requirements"]), tuple(parts["types"]),
                        tuple(parts["constants"]), preds, tuple(parts["functions"]),
                        tuple(parts["includes"]), tuple(parts["defines"]), tuple(parts["actions"]),
                        tuple(parts["derived"]), dialect, form, span=x.span, target=target,
                        hands=hands)

    def _one_name(self, sec: SList, kw: str) -> A.Name | None:
        if len(sec.items) != 2:
            self.err("E117", f"`({kw} NAME)` takes one name", sec.span)
            return None
        return self.name(sec.items[1], "a domain name" if kw == ":domain" else "a frame name")

    def requirements(self, items) -> list[A.Requirement]:
        out = []
        for r in items:
            if not is_keyword(r):
                self.err("E115", f"expected a requirement like `:strips`, found {describe(r)}",
                         r.span, f"write `:{r.text}`" if is_sym(r) and ":" + r.text.lower()
                         in K.REQUIREMENTS else None)
                continue
            key = r.text.lower()
            if key not in K.REQUIREMENTS:
                self.err("E115", f"unknown requirement `{r.text}`", r.span,
                         suggest(key, K.REQUIREMENTS) or "see docs/language.md for the list")
                continue
            # Stored lower-case: keyword case carries no meaning (and `fmt` normalizes it).
            out.append(A.Requirement(A.Name(key, span=r.span), span=r.span))
        return out

    def types(self, items) -> list[A.TypeDecl]:
        return [A.TypeDecl(t.name, t.type, span=t.span)
                for t in self.typed_list(items, False, "`:types`")]

    def functions(self, items) -> list[A.FunctionDecl]:
        out: list[A.FunctionDecl] = []
        pending: list[A.FunctionDecl] = []
        i = 0
        while i < len(items):
            x = items[i]
            if isinstance(x, SList):
                nm = self.name(x.items[0], "a function name") if x.items else None
                if nm is not None:
                    params = self.typed_list(x.items[1:], True, f"`{nm.text}`'s parameters")
                    pending.append(A.FunctionDecl(nm, params, None, span=x.span))
                i += 1
                continue
            if is_sym(x) and x.text.startswith("-"):
                tname = x.text[1:] or (items[i + 1].text if i + 1 < len(items)
                                       and is_sym(items[i + 1]) else "")
                step = 1 if x.text[1:] else 2
                if not tname:
                    self.err("E110", "`-` in `:functions` must be followed by a type", x.span)
                tn = A.Name(tname, span=x.span)
                out += [A.FunctionDecl(f.name, f.params, tn, span=f.span) for f in pending]
                pending = []
                i += step
                continue
            self.err("E117", f"expected a function like `(name ?x - type)`, found {describe(x)}",
                     x.span)
            i += 1
        return out + pending

    def includes(self, items) -> list[A.Include]:
        out = []
        for it in items:
            if isinstance(it, SAtom) and it.kind == "string":
                out.append(A.Include(it.text[1:-1], span=it.span))
            else:
                self.err("E117", f"`:include` takes module names in quotes, found {describe(it)}",
                         it.span, 'write `(:include "tmpc/geometry")`')
        return out

    # ---- predicates ------------------------------------------------------------------------
    def predicate(self, x: SExpr) -> tuple[A.PredicateDecl, set[str]] | None:
        if not isinstance(x, SList) or not x.items:
            self.err("E117", f"expected a predicate like `(name ?x - type)`, found {describe(x)}",
                     x.span)
            return None
        nm = self.name(x.items[0], "a predicate name")
        if nm is None:
            return None
        items = x.items[1:]
        cut = next((i for i, it in enumerate(items) if _is_annotation_start(it)), len(items))
        params = self.typed_list(items[:cut], True, f"`{nm.text}`'s parameters")
        marks: set[str] = set()
        semantics, kin = None, None
        rest = list(items[cut:])
        i = 0
        while i < len(rest):
            it = rest[i]
            if isinstance(it, SList) and head(it) == "kinematic":
                kin = self.kinematic(it, it.items[1:], "tmit-star")
                marks.add("kinematic-list")
                i += 1
                continue
            kw = sym(it) if is_keyword(it) else None
            if kw in (":discrete", ":geometric"):
                marks.add(kw)
                i += 1
            elif kw == ":kinematic":
                marks.add(kw)
                nxt = rest[i + 1] if i + 1 < len(rest) else None
                if isinstance(nxt, SList):
                    planet = bool(nxt.items) and isinstance(nxt.items[0], SList)
                    kin = self.kinematic(nxt, nxt.items if planet else [nxt],
                                         "planet" if planet else "native")
                    i += 2
                else:
                    self.err("E116", "`:kinematic` needs `(link ?parent ?child)`", it.span,
                             "write `:kinematic (link ?m ?x)`")
                    i += 1
            elif kw == ":semantics":
                marks.add(kw)
                if i + 1 >= len(rest):
                    self.err("E116", "`:semantics` needs an expression after it", it.span)
                    break
                semantics = self.expr(rest[i + 1])
                i += 2
            else:
                self.err("E116", f"unexpected {describe(it)} in the declaration of `{nm.text}`",
                         it.span, suggest(it.text, K.PREDICATE_ANNOTATIONS)
                         if isinstance(it, SAtom) else "annotations are :discrete, :kinematic, "
                         ":geometric and :semantics")
                i += 1
        decl = A.PredicateDecl(nm, params, A.Kind.DISCRETE, semantics, kin, span=x.span)
        return decl, marks

    def kinematic(self, where: SList, entries, style: str) -> A.KinematicSpec | None:
        link = None
        for e in entries:
            h = head(e)
            if h not in ("link", "unlink") or len(e.items) != 3:
                self.err("E116", f"expected `(link ?parent ?child)` or `(unlink ?parent ?child)`, "
                         f"found {describe(e)}", e.span)
                return None
            a, b = self.var(e.items[1]), self.var(e.items[2])
            if a is None or b is None:
                return None
            if h == "link":
                link = (a, b)
            elif link is not None and (a.key, b.key) != (link[0].key, link[1].key):
                self.err("E116", "`unlink` must name the same objects as `link`", e.span)
        if link is None:
            self.err("E116", "a kinematic annotation needs a `(link ?parent ?child)`", where.span)
            return None
        return A.KinematicSpec(link[0], link[1], style, span=where.span)

    # ---- helpers, actions, derived ---------------------------------------------------------
    def _signature(self, sec: SList, what: str):
        if len(sec.items) < 2 or not isinstance(sec.items[1], SList) or not sec.items[1].items:
            self.err("E117", f"`{sec.items[0].text}` is written `({sec.items[0].text} (name ?x ...) "
                     f"{what})`", sec.span)
            return None
        sig = sec.items[1]
        nm = self.name(sig.items[0], "a name")
        params = self.typed_list(sig.items[1:], True, "the parameters")
        return (nm, params) if nm else None

    def define_helper(self, sec: SList) -> A.DefineDecl | None:
        sig = self._signature(sec, "body")
        if sig is None:
            return None
        if len(sec.items) != 3:
            self.err("E113", "a `:define` has exactly one body expression", sec.span)
            return None
        body = self.expr(sec.items[2])
        return A.DefineDecl(sig[0], sig[1], body, span=sec.span) if body else None

    def derived(self, sec: SList) -> A.Derived | None:
        sig = self._signature(sec, "formula")
        if sig is None:
            return None
        if len(sec.items) != 3:
            self.err("E111", "a `:derived` rule has exactly one formula", sec.span)
            return None
        body = self.formula(sec.items[2])
        return A.Derived(sig[0], sig[1], body, span=sec.span) if body else None

    def action(self, sec: SList, semantics: bool = False) -> A.Action | None:
        if len(sec.items) < 2:
            self.err("E117", "`:action` needs a name", sec.span)
            return None
        nm = self.name(sec.items[1], "an action name")
        if nm is None:
            return None
        values: dict[str, tuple[SAtom, SExpr]] = {}
        items = sec.items[2:]
        i = 0
        while i < len(items):
            key = items[i]
            if isinstance(key, SList) and head(key) in (":action", ":derived"):
                self.err("E109", f"`({key.items[0].text}` inside the action `{nm.text}`", key.span,
                         f"a `)` is missing at the end of `{nm.text}`")
                i += 1
                continue
            k = sym(key) if is_keyword(key) else None
            if k not in K.ACTION_KEYS and not (semantics and k == ":carries"):
                if k is not None:
                    self.err("E106", f"unknown key `{key.text}` in action `{nm.text}`", key.span,
                             suggest(k, K.ACTION_KEYS) or "keys are :parameters, :precondition, "
                             ":effect")
                    if i + 1 < len(items) and not is_keyword(items[i + 1]):
                        i += 1   # skip its value too: one mistake, one diagnostic
                else:
                    self.err("E109", f"expected a key like `:precondition` in action `{nm.text}`, "
                             f"found {describe(key)}", key.span)
                i += 1
                continue
            if i + 1 >= len(items) or is_keyword(items[i + 1]):
                self.err("E107", f"`{key.text}` has no value", key.span,
                         "write `()` for an empty one")
                i += 1
                continue
            if k in values:
                self.err("E108", f"`{key.text}` given twice in action `{nm.text}`", key.span,
                         related=[Related(values[k][0].span, "first given here")])
            else:
                values[k] = (key, items[i + 1])
            i += 2
        act = self._build_action(nm, values, sec)
        if ":carries" in values:
            v = self.var(values[":carries"][1], "the ?parameter the action carries")
            act = A.Action(act.name, act.params, act.precondition, act.effect, span=act.span,
                           carries=A.Var(v, span=v.span) if v is not None else None)
        return act

    def _build_action(self, nm: A.Name, values, sec: SList) -> A.Action:
        params: tuple[A.Typed, ...] = ()
        for key in (":parameters", ":vars"):
            if key in values:
                v = values[key][1]
                if isinstance(v, SList):
                    params += self.typed_list(v.items, True, f"`{nm.text}`'s parameters")
                else:
                    self.err("E104", f"`{key}` takes a list `(?x - type ...)`", v.span)
        pre = self.formula(values[":precondition"][1]) if ":precondition" in values else None
        eff = self.effect(values[":effect"][1]) if ":effect" in values else None
        if ":precondition" in values and ":effect" in values:
            pk, ek = values[":precondition"][0], values[":effect"][0]
            if ek.span.start < pk.span.start:
                self.add(warning("W005", "`:effect` comes before `:precondition`", ek.span,
                                 "PDDL orders the keys :parameters, :precondition, :effect"))
        return A.Action(nm, params, pre, eff, span=sec.span)

    # ---- problem ---------------------------------------------------------------------------
    def problem(self, name: A.Name, x: SList) -> A.Problem:
        allowed = ("", ":domain", ":requirements", ":objects", ":init", ":goal", ":metric")
        dom, reqs, objs, init, goal, metric = None, [], [], [], None, None
        objs_parts: list = []
        init_parts: list = []
        for kw, sec in self._sections(x, allowed, DOMAIN_ONLY, "problem"):
            body = sec.items[1:]
            if kw == ":domain":
                if len(body) == 1:
                    dom = self.name(body[0], "the domain name")
                else:
                    self.err("E117", "`:domain` takes one name", sec.span)
            elif kw == ":requirements":
                reqs += self.requirements(body)
            elif kw == ":objects":
                objs_parts.append(self.typed_list(body, False, "`:objects`"))
            elif kw == ":init":
                init_parts.append(self.init_facts(body) if isinstance(body, Packed) else
                                  tuple(i for i in (self.init_item(b) for b in body) if i))
            elif kw == ":goal":
                if len(body) != 1:
                    self.err("E111", "`:goal` takes one formula (wrap several in `(and ...)`)",
                             sec.span)
                else:
                    goal = self.formula(body[0])
            elif kw == ":metric":
                metric = self.metric(sec)
        # one section (the usual case) stays as the reader made it, maybe as columns
        objs = objs_parts[0] if len(objs_parts) == 1 else tuple(o for p in objs_parts for o in p)
        init = init_parts[0] if len(init_parts) == 1 else tuple(i for p in init_parts for i in p)
        return A.Problem(name, dom, tuple(reqs), objs, init, goal, metric, span=x.span)

    def init_facts(self, body: Packed) -> InitFacts:
        """`:init` of a large problem: each fact `(p a b)` or `(= (f a b) 3)` of plain names
        stays an index into the s-expression columns (:mod:`tmpc.lang.columns`); anything else
        is read by :meth:`init_item`."""
        return packed_facts(body, plain_init_pred, True, self.init_item)

    def init_item(self, x: SExpr) -> A.InitItem | None:
        if not isinstance(x, SList) or not x.items:
            self.err("E117", f"expected a fact like `(p a b)` in `:init`, found {describe(x)}",
                     x.span)
            return None
        h = head(x)
        if h == "=" and len(x.items) == 3 and isinstance(x.items[1], SList):
            target = self.func_term(x.items[1])
            val = self.number(x.items[2])
            return A.NumericInit(target, val, span=x.span) if target and val else None
        if h == "not":
            self.add(warning("W006", "negative facts in `:init` are redundant (closed world)",
                             x.span, "remove it; everything not listed is false"))
            return None
        if h == "at" and len(x.items) == 3 and isinstance(x.items[2], SList):
            self.err("E121", "timed initial literals are not supported", x.span)
            return None
        if h == "=":
            return self.formula(x)  # object equality facts
        return self.atom(x)

    def metric(self, sec: SList) -> A.Metric | None:
        body = sec.items[1:]
        if len(body) != 2 or sym(body[0]) not in K.METRIC_DIRECTIONS:
            self.err("E117", "`:metric` is written `(:metric minimize (total-cost))`", sec.span)
            return None
        expr = self.num_expr(body[1])
        return A.Metric(sym(body[0]), expr, span=sec.span) if expr else None


# ---------------------------------------------------------------------------------------------


def _is_annotation_start(it: SExpr) -> bool:
    if isinstance(it, SList):
        return head(it) == "kinematic"
    return is_keyword(it)


def _dialect(reqs, raw_preds, parts) -> A.Dialect:
    keys = {r.name.key for r in reqs}
    marks = set().union(*(m for _, m in raw_preds)) if raw_preds else set()
    if ":tmpc" in keys or marks & {":semantics", ":geometric"} or parts["includes"] or \
            parts["defines"]:
        return A.Dialect.TMPC
    if "kinematic-list" in marks:
        return A.Dialect.TMIT_STAR
    if marks & {":discrete", ":kinematic"}:
        return A.Dialect.PLANET
    return A.Dialect.PDDL


def _resolve_kind(p: A.PredicateDecl, marks: set[str], dialect: A.Dialect) -> A.PredicateDecl:
    """Apply the dialect's rule for predicates (docs/language.md, "Predicate kinds")."""
    from dataclasses import replace
    if p.kinematic is not None:
        return replace(p, kind=A.Kind.KINEMATIC)
    if p.semantics is not None:
        return replace(p, kind=A.Kind.GEOMETRIC)
    if ":geometric" in marks:
        return replace(p, kind=A.Kind.GEOMETRIC, external=True)
    if ":discrete" in marks or dialect in (A.Dialect.PDDL, A.Dialect.TMPC):
        return p
    return replace(p, kind=A.Kind.GEOMETRIC, external=True)


def _top_level_hint(item: SExpr) -> str | None:
    if isinstance(item, SList) and (head(item) or "").startswith(":"):
        return "this section is outside `(define ...)`: an earlier `)` closes the definition too soon"
    return None
