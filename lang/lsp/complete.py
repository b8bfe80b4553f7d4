"""Completion: what may be typed at the cursor, from the enclosing lists (found by a forward scan
of the text before the cursor that skips comments and strings) and the program's index.

Contexts: after ``(:`` a section or action key; in ``:requirements`` a requirement; after ``- `` in
a typed list a type; after ``?`` a parameter in scope; the head of a list in a formula (a
predicate or connective) or in a ``:semantics``/``:define`` body (a built-in, a helper, a
geometric predicate); an argument (an object or constant).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lsprotocol import types as T

from tmpc.lang import symbols as K
from tmpc.lang.lsp.hover import signature, typed
from tmpc.lang.lsp.index import Index


@dataclass
class _Frame:
    head: str | None = None
    #: the last `:keyword` seen directly in this list
    key: str | None = None
    count: int = 0
    start: int = 0


@dataclass
class Context:
    frames: list[_Frame] = field(default_factory=list)
    prefix: str = ""
    #: the cursor is right after `(` (plus the prefix): a head position
    head: bool = False
    #: the previous token was `-` (a type follows)
    after_dash: bool = False


def context(text: str, offset: int) -> Context:
    frames = [_Frame()]
    i, prev = 0, ""
    n = min(offset, len(text))
    while i < n:
        c = text[i]
        if c == ";":
            j = text.find("\n", i)
            i = n if j < 0 or j >= n else j
            continue
        if c == '"':
            j = text.find('"', i + 1)
            i = n if j < 0 or j >= n else j + 1
            prev = "string"
            continue
        if c == "(":
            frames.append(_Frame(start=i))
            prev = "("
            i += 1
            continue
        if c == ")":
            if len(frames) > 1:
                frames.pop()
            frames[-1].count += 1
            prev = ")"
            i += 1
            continue
        if c.isspace():
            i += 1
            continue
        j = i
        while j < n and not text[j].isspace() and text[j] not in '();"':
            j += 1
        tok = text[i:j]
        if j >= n:                                  # the word being typed
            ctx = Context(frames, tok, prev == "(", prev == "-")
            return ctx
        f = frames[-1]
        if f.count == 0:
            f.head = tok.lower()
        elif tok.startswith(":"):
            f.key = tok.lower()
        f.count += 1
        prev = tok
        i = j
    return Context(frames, "", prev == "(", prev == "-")


def _item(label: str, kind: T.CompletionItemKind, detail: str | None = None) -> T.CompletionItem:
    return T.CompletionItem(label=label, kind=kind, detail=detail)


def complete(text: str, offset: int, idx: Index | None, is_problem: bool,
             path: str) -> list[T.CompletionItem]:
    ctx = context(text, offset)
    heads = [f.head for f in ctx.frames]
    keys = [f.key for f in ctx.frames]
    inner = ctx.frames[-1]
    if ":requirements" in heads:
        return [_item(r, T.CompletionItemKind.Keyword) for r in K.REQUIREMENTS]
    if ctx.prefix.startswith(":") and (ctx.head or inner.head in (":action", ":derived")
                                      or len(ctx.frames) <= 3):
        return _keywords(heads, is_problem)
    if idx is None:
        return []
    if ctx.after_dash:
        return [_item(o.key, T.CompletionItemKind.Class) for o in _unique(idx, "type")]
    if ctx.prefix.startswith("?"):
        return _parameters(idx, offset, ctx, path)
    in_expr = ":semantics" in keys or ":define" in heads
    if ctx.head:
        return _expr_heads(idx) if in_expr else _formula_heads(idx, keys)
    return _objects(idx)


def _keywords(heads, is_problem: bool) -> list[T.CompletionItem]:
    if ":action" in heads or ":derived" in heads:
        words = K.ACTION_KEYS
    elif ":predicates" in heads:
        words = K.PREDICATE_ANNOTATIONS
    else:
        words = K.PROBLEM_SECTIONS if is_problem else K.DOMAIN_SECTIONS
    return [_item(w, T.CompletionItemKind.Keyword) for w in words]


def _unique(idx: Index, kind: str):
    seen, out = set(), []
    for o in idx.occurrences:
        if o.kind == kind and o.definition and o.key not in seen:
            seen.add(o.key)
            out.append(o)
    return out


def _formula_heads(idx: Index, keys) -> list[T.CompletionItem]:
    effect = ":effect" in keys
    words = K.EFFECT_CONNECTIVES if effect else K.FORMULA_CONNECTIVES
    out = [_item(w, T.CompletionItemKind.Keyword) for w in words]
    for key, decl in idx.predicates.items():
        if effect and decl.kind.value == "geometric":
            continue                      # geometric predicates never appear in effects
        out.append(_item(decl.name.text, T.CompletionItemKind.Function,
                         f"{decl.kind.value} {signature(decl)}"))
    return out


def _expr_heads(idx: Index) -> list[T.CompletionItem]:
    out = []
    for name, sigs in K.BUILTINS.items():
        detail = " | ".join(f"({' '.join(s.args)}) -> {s.result}" for s in sigs)
        out.append(_item(name, T.CompletionItemKind.Operator, detail))
    out += [_item(w, T.CompletionItemKind.Keyword) for w in K.EXPR_SPECIAL_FORMS]
    for o in _unique(idx, "helper"):
        node = o.node
        out.append(_item(node.name.text, T.CompletionItemKind.Function,
                         f"helper ({node.name.text} {typed(node.params)})"))
    for decl in idx.predicates.values():
        if decl.kind.value == "geometric":
            out.append(_item(decl.name.text, T.CompletionItemKind.Function,
                             f"geometric {signature(decl)}"))
    return out


def _objects(idx: Index) -> list[T.CompletionItem]:
    out = []
    for o in _unique(idx, "object"):
        t = o.node.type
        detail = " ".join(n.text for n in t.names) if t is not None else "object"
        out.append(_item(o.node.name.text, T.CompletionItemKind.Constant, detail))
    return out


def _parameters(idx: Index, offset: int, ctx: Context, path: str) -> list[T.CompletionItem]:
    """Parameters bound by a declaration enclosing the cursor (the outermost list at depth 2:
    the action/predicate/helper), deduplicated."""
    if len(ctx.frames) < 3:
        return []
    start = ctx.frames[2].start
    seen, out = set(), []
    for o in idx.occurrences:
        if o.kind == "parameter" and o.definition and o.span.path == path \
                and o.span.start >= start \
                and o.span.start < offset and o.key not in seen:
            seen.add(o.key)
            t = getattr(o.node, "type", None)
            detail = " ".join(n.text for n in t.names) if t is not None else None
            out.append(_item(o.node.name.text, T.CompletionItemKind.Variable, detail))
    return out
