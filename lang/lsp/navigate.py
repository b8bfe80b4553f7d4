"""Definition, references, rename, document symbols, folding, formatting and semantic tokens."""

from __future__ import annotations

import re

from lsprotocol import types as T

from tmpc.lang import ast as A
from tmpc.lang.formatter import format_doc
from tmpc.lang.lsp.convert import span_range, to_range, uri
from tmpc.lang.lsp.index import Index, Occurrence
from tmpc.lang.sexpr import SList, parse_sexpr
from tmpc.lang.source import SourceFile

#: semantic token types and modifiers (standard types; tmpc's predicate kinds are modifiers, so
#: a theme colours `function.geometric` apart from `function.discrete`)
TOKEN_TYPES = ["function", "type", "parameter", "variable", "method", "macro", "namespace"]
TOKEN_MODIFIERS = ["declaration", "discrete", "kinematic", "geometric"]
_KIND_TOKEN = {"predicate": "function", "type": "type", "parameter": "parameter",
               "object": "variable", "action": "method", "helper": "macro",
               "function": "function", "domain": "namespace"}


def location(occ: Occurrence, files: dict[str, SourceFile], norm) -> T.Location | None:
    src = files.get(norm(occ.span.path))
    if src is None:
        return None
    return T.Location(uri=uri(norm(occ.span.path)), range=span_range(src, occ.span))


def lua_definition(name: str, lua_path: str | None, text: str | None) -> T.Location | None:
    """Where a legacy predicate's Lua function is defined (``function NAME(`` / ``NAME =
    function(``), matched as the compiler looks it up (case, ``-`` as ``_``)."""
    if lua_path is None or text is None:
        return None
    want = name.lower().replace("-", "_")
    pattern = re.compile(r"^\s*(?:local\s+)?function\s+([A-Za-z_][\w.]*)\s*\(|"
                         r"^\s*([A-Za-z_]\w*)\s*=\s*function\s*\(", re.M)
    src = SourceFile(lua_path, text)
    for m in pattern.finditer(text):
        g = 1 if m.group(1) else 2
        if m.group(g).lower().replace("-", "_") == want:
            return T.Location(uri=uri(lua_path), range=to_range(src, m.start(g), m.end(g)))
    return None


def rename_edits(occ: Occurrence, idx: Index, new: str, files, norm) -> T.WorkspaceEdit:
    changes: dict[str, list[T.TextEdit]] = {}
    for o in idx.references(occ):
        loc = location(o, files, norm)
        if loc is not None:
            changes.setdefault(loc.uri, []).append(T.TextEdit(range=loc.range, new_text=new))
    return T.WorkspaceEdit(changes=changes)


def document_symbols(defs: list, src: SourceFile) -> list[T.DocumentSymbol]:
    out = []
    for d in defs:
        if d.span is None:
            continue
        if isinstance(d, A.Domain):
            children = [_sym(x.name.text, kind, x.span, x.name.span, src)
                        for kind, items in ((T.SymbolKind.Class, d.types),
                                            (T.SymbolKind.Constant, d.constants),
                                            (T.SymbolKind.Function, d.predicates),
                                            (T.SymbolKind.Function, d.defines),
                                            (T.SymbolKind.Method, d.actions))
                        for x in items if x.span is not None]
            out.append(_sym(d.name.text, T.SymbolKind.Module, d.span, d.name.span, src, children))
        elif isinstance(d, A.Problem):
            children = [_sym(o.name.text, T.SymbolKind.Object, o.span, o.name.span, src)
                        for o in d.objects if o.span is not None]
            if d.goal is not None and d.goal.span is not None:
                children.append(_sym("goal", T.SymbolKind.Event, d.goal.span, d.goal.span, src))
            out.append(_sym(d.name.text, T.SymbolKind.Namespace, d.span, d.name.span, src,
                            children))
    return out


def _sym(name, kind, span, sel, src, children=None) -> T.DocumentSymbol:
    return T.DocumentSymbol(name=name, kind=kind, range=span_range(src, span),
                            selection_range=span_range(src, sel or span), children=children)


def folding(src: SourceFile) -> list[T.FoldingRange]:
    doc = parse_sexpr(src)
    out: list[T.FoldingRange] = []
    stack = list(doc.items)
    while stack:
        x = stack.pop()
        if isinstance(x, SList):
            a, b = src.lsp_position(x.span.start)[0], src.lsp_position(x.span.end)[0]
            if b > a:
                out.append(T.FoldingRange(start_line=a, end_line=b))
            stack.extend(x.items)
    lines = [src.lsp_position(c.span.start)[0] for c in doc.comments]
    run = []
    for ln in lines + [None]:
        if run and (ln is None or ln != run[-1] + 1):
            if len(run) > 1:
                out.append(T.FoldingRange(start_line=run[0], end_line=run[-1],
                                          kind=T.FoldingRangeKind.Comment))
            run = []
        if ln is not None:
            run.append(ln)
    return sorted(out, key=lambda r: (r.start_line, r.end_line))


def formatting(src: SourceFile) -> list[T.TextEdit] | None:
    """``tmpc fmt``'s output as one edit; None (no change offered) for a file with syntax
    errors, which ``tmpc fmt`` refuses too."""
    doc = parse_sexpr(src)
    if any(d.is_error for d in doc.diagnostics):
        return None
    text = format_doc(doc)
    if text == src.text:
        return []
    end = src.lsp_position(len(src.text))
    return [T.TextEdit(range=T.Range(start=T.Position(line=0, character=0),
                                     end=T.Position(line=end[0], character=end[1])),
                       new_text=text)]


def semantic_tokens(idx: Index, path: str, src: SourceFile) -> list[int]:
    """The LSP relative encoding of every indexed name in ``path``."""
    data: list[int] = []
    prev_line = prev_ch = 0
    last_end = -1
    for o in idx.in_file(path):
        if o.span.start < last_end or o.kind not in _KIND_TOKEN:
            continue
        line, ch = src.lsp_position(o.span.start)
        end_line, end_ch = src.lsp_position(o.span.end)
        if end_line != line:
            continue
        mods = 1 if o.definition else 0
        if o.kind == "predicate" and o.key in idx.predicates:
            mods |= 1 << TOKEN_MODIFIERS.index(idx.predicates[o.key].kind.value)
        delta_ch = ch - prev_ch if line == prev_line else ch
        data += [line - prev_line, delta_ch, end_ch - ch,
                 TOKEN_TYPES.index(_KIND_TOKEN[o.kind]), mods]
        prev_line, prev_ch, last_end = line, ch, o.span.end
    return data
