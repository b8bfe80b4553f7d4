"""Hover text: what a name is, its typed signature, the comments above its declaration, and for a
geometric predicate what it means once compiled (through the injected ``explain`` hook, which
lowers native bodies and traces legacy Lua)."""

from __future__ import annotations

from typing import Callable

from tmpc.lang import ast as A
from tmpc.lang.lsp.index import Index, Occurrence
from tmpc.lang.source import SourceFile
from tmpc.lang.symbols import BUILTINS, REQUIREMENTS

#: explain(scope, PredicateDecl, lua_path) -> an object with .truth/.distance/.legend, or a str
Explain = Callable[[object, A.PredicateDecl, str | None], object]


def typed(params: tuple[A.Typed, ...]) -> str:
    out = []
    for p in params:
        t = " - " + _typeref(p.type) if p.type is not None else ""
        out.append(p.name.text + t)
    return " ".join(out)


def _typeref(t: A.TypeRef | None) -> str:
    if t is None:
        return "object"
    if len(t.names) == 1:
        return t.names[0].text
    return "(either " + " ".join(n.text for n in t.names) + ")"


def doc_comment(src: SourceFile | None, start: int) -> str:
    """The ``;`` comment lines directly above offset ``start`` (the declaration's docs)."""
    if src is None:
        return ""
    line, _ = src.line_col(start)
    lines = []
    for ln in range(line - 1, 0, -1):
        text = src.line_text(ln).strip()
        if not text.startswith(";"):
            break
        lines.append(text.lstrip(";").strip())
    return "\n".join(reversed(lines))


def signature(decl: A.PredicateDecl) -> str:
    return f"({decl.name.text}{' ' if decl.params else ''}{typed(decl.params)})"


def predicate_hover(decl: A.PredicateDecl, explain: Explain | None, scope,
                    lua_path: str | None) -> list[str]:
    parts = [f"**{decl.kind.value} predicate**", f"```pddl\n{signature(decl)}\n```"]
    if decl.kinematic is not None:
        k = decl.kinematic
        parts.append(f"while it holds, `{k.child.text}` is rigidly attached to "
                     f"`{k.parent.text}` (link/unlink on its effects)")
    if decl.kind is A.Kind.GEOMETRIC and explain is not None and scope is not None:
        got = explain(scope, decl, lua_path)
        if isinstance(got, str):
            parts.append(f"compiled: {got}")
        else:
            parts.append("holds when (tolerance 1e-3):\n```\n" + got.truth + "\n```")
            parts.append("unsatisfaction distance (what projection minimises):\n```\n"
                         + got.distance + "\n```")
            parts += [f"- {line}" for line in got.legend]
    elif decl.kind is A.Kind.GEOMETRIC and decl.external:
        parts.append("implemented by a same-named Lua function")
    return parts


def hover_text(occ: Occurrence, idx: Index, files: dict[str, SourceFile], norm,
               explain: Explain | None = None, scope=None, lua_path: str | None = None) -> str:
    defs = idx.definitions(occ)
    d = defs[0] if defs else None
    node = d.node if d is not None else None
    parts: list[str] = []
    if occ.kind == "predicate" and occ.key in idx.predicates:
        parts = predicate_hover(idx.predicates[occ.key], explain, scope, lua_path)
    elif occ.kind == "action" and isinstance(node, A.Action):
        parts = ["**action**", f"```pddl\n({node.name.text} {typed(node.params)})\n```"]
    elif occ.kind == "helper" and isinstance(node, A.DefineDecl):
        parts = ["**helper** (inlined where used)",
                 f"```pddl\n({node.name.text} {typed(node.params)})\n```"]
        body = _text_of(files, norm, node.body.span)
        if body:
            parts.append(f"```pddl\n{body}\n```")
    elif occ.kind == "type":
        parent = _typeref(node.parent) if isinstance(node, A.TypeDecl) and node.parent else None
        parts = [f"**type** `{occ.key}`" + (f" - `{parent}`" if parent else "")]
    elif occ.kind == "object" and isinstance(node, A.Typed):
        where = "problem object" if d is not None and _is_problem(idx, d) else "constant"
        parts = [f"**{where}** `{node.name.text} - {_typeref(node.type)}`"]
    elif occ.kind == "parameter" and isinstance(node, A.Typed):
        parts = [f"**parameter** `{node.name.text} - {_typeref(node.type)}`"]
    elif occ.kind == "domain":
        parts = [f"**domain** `{occ.key}`"]
    elif occ.kind == "function" and isinstance(node, A.FunctionDecl):
        parts = [f"**function** `({node.name.text} {typed(node.params)})`"]
    if not parts:
        parts = [f"**{occ.kind}** `{occ.key}`" + ("" if defs else " (not declared)")]
    if d is not None:
        docs = doc_comment(files.get(norm(d.span.path)), _decl_start(d))
        if docs:
            parts.append(docs)
    return "\n\n".join(parts)


def builtin_hover(word: str) -> str | None:
    """Overloads of a built-in operator, or a requirement's meaning."""
    if word in BUILTINS:
        sigs = [f"({word} {' '.join(s.args)}{' ...' if s.variadic else ''}) -> {s.result}"
                for s in BUILTINS[word]]
        return "**built-in**\n```\n" + "\n".join(sigs) + "\n```"
    if word in REQUIREMENTS:
        implied = REQUIREMENTS[word]
        return f"**requirement** `{word}`" + (
            "\n\nimplies " + ", ".join(f"`{r}`" for r in implied) if implied else "")
    return None


def _decl_start(d: Occurrence) -> int:
    span = getattr(d.node, "span", None)
    return span.start if span is not None else d.span.start


def _is_problem(idx: Index, d: Occurrence) -> bool:
    return any(p.problem is not None and p.problem.span is not None
               and p.problem.span.path == d.span.path
               and p.problem.span.start <= d.span.start <= p.problem.span.end
               for p in idx.programs)


def _text_of(files, norm, span) -> str | None:
    if span is None:
        return None
    src = files.get(norm(span.path))
    return src.text[span.start:span.end] if src is not None else None
