"""`tmpc lsp`: the language server. Each handler is a few lines that call ``lang/`` (or the worker)
and convert; logs go to stderr only.

Diagnostics are debounced per document and published for every open file a check reads.
Heavy work (sampling a witness, evaluating at the start state, SMT/sampling static checks) goes
to the worker process (:mod:`tmpc.lang.lsp.worker`) with a time budget; the editor can cancel it.
"""

from __future__ import annotations

import asyncio
import hashlib
import inspect
import json
import logging
import os
import tempfile
import threading
import time
from dataclasses import dataclass, replace
from functools import cached_property

from lsprotocol import types as T
from pygls.exceptions import JsonRpcInvalidParams
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol, lsp_method
from pygls.uris import to_fs_path

from tmpc.lang import ast as A
from tmpc.lang.lsp import complete, fixes, hover, navigate
from tmpc.lang.lsp.convert import diagnostic, offset, span_range, uri
from tmpc.lang.lsp.index import Index, build_index
from tmpc.lang.lsp.project import Check, Overlay, Project, norm
from tmpc.lang.lsp.worker import Worker, WorkerError
from tmpc.lang.program import Program, check_parsed
from tmpc.lang.source import SourceFile, Span

log = logging.getLogger("tmpc.lsp")

#: seconds a document waits after an edit before it is checked (edits in between restart it).
#: Short: edits that arrive while a check runs queue behind it and restart the wait, so a burst
#: (typing, a paste as many changes) is checked once after it anyway
DEBOUNCE = 0.005
#: time budgets (s) of worker requests
BUDGETS = {"witness": 60.0, "evaluate": 60.0, "static": 120.0}


@dataclass
class Hooks:
    """What the composition root injects: ``explain`` (compiled meaning of a geometric
    predicate, see :func:`tmpc.compiler.explain.explain_predicate`), ``warm`` (loads what
    ``explain`` needs; called on a background thread once the first diagnostics are out, so the
    first hover does not pay for the imports) and the worker's command."""

    explain: object = None
    warm: object = None
    worker_command: list[str] | None = None


@dataclass
class Analysis:
    check: Check
    index: Index

    @cached_property
    def scope(self):
        """A checked program's scope (for lowering a predicate body), or None; computed once
        per check (hovers reuse it)."""
        progs = self.check.report.programs
        if progs:
            return progs[0].scope
        # the problem has errors: the domain alone; the actions have errors: the declarations
        # alone (a predicate's meaning never depends on an action)
        for src in self.check.report.sources:
            if src.domain is None:
                continue
            for domain in (src.domain, replace(src.domain, actions=(), derived=())):
                checked, _ = Program(domain, None, src.modules).check()
                if checked is not None:
                    return checked.scope
        return None


class TmpcProtocol(LanguageServerProtocol):
    """pygls's protocol, with ``workspace/executeCommand`` run as a coroutine: pygls 2 runs a
    command's handler as a separate task behind a generator, which ``$/cancelRequest`` never
    reaches; here the request's task awaits the handler, so cancelling the request cancels the
    command (and its worker call, which stops the worker)."""

    @lsp_method(T.WORKSPACE_EXECUTE_COMMAND)
    async def lsp_workspace__execute_command(self, params: T.ExecuteCommandParams):
        handler = self.fm.commands.get(params.command)
        if handler is None:
            raise JsonRpcInvalidParams.of(ValueError(f"no command {params.command!r}"))
        result = handler(*(params.arguments or []))
        return await result if inspect.isawaitable(result) else result


class TmpcServer(LanguageServer):
    def __init__(self, hooks: Hooks, version: str):
        super().__init__("tmpc", version, protocol_cls=TmpcProtocol)
        self.hooks = hooks
        self.project = Project()
        self.analyses: dict[str, Analysis] = {}
        self.static: dict[str, list[T.Diagnostic]] = {}
        self._pending: dict[str, asyncio.TimerHandle] = {}
        self._edited: dict[str, float] = {}
        #: seconds from didChange to publish, per published check (for `tmpc/stats`)
        self.latencies: list[float] = []
        self.worker = Worker(hooks.worker_command) if hooks.worker_command else None
        #: pending "open in tmpc view?" questions (kept so they are not garbage collected)
        self._offers: set[asyncio.Future] = set()
        self._warm_started = False

    # ---- checking --------------------------------------------------------------------------
    def schedule(self, path: str) -> None:
        old = self._pending.pop(path, None)
        if old is not None:
            old.cancel()
        loop = asyncio.get_event_loop()
        self._pending[path] = loop.call_later(DEBOUNCE, self.run_check, path)

    def run_check(self, path: str) -> None:
        self._pending.pop(path, None)
        if path not in self.project.documents:
            return
        try:
            check = self.project.check(path)
        except Exception:                       # a bug in tmpc: say so, keep serving
            log.exception("checking %s failed", path)
            self.window_show_message(T.ShowMessageParams(
                type=T.MessageType.Error, message=f"tmpc: checking {path} failed (a bug); "
                "see the server log"))
            return
        analysis = Analysis(check, build_index(check.report.sources))
        files = check.files
        for p, diags in check.by_file().items():
            if p not in self.project.documents and p != path:
                continue
            self.analyses[p] = analysis
            items = [diagnostic(d, files, norm) for d in diags] + self.static.get(p, [])
            doc = self.project.documents.get(p)
            self.text_document_publish_diagnostics(T.PublishDiagnosticsParams(
                uri=uri(p), diagnostics=items, version=doc.version if doc else None))
        t0 = self._edited.pop(path, None)
        if t0 is not None:
            self.latencies.append(time.perf_counter() - t0)
        if self.hooks.warm is not None and not self._warm_started:
            self._warm_started = True
            threading.Thread(target=self._warm, name="tmpc-warm", daemon=True).start()

    def _warm(self) -> None:
        try:
            self.hooks.warm()
        except Exception:                       # the first hover will say what is wrong
            log.exception("warming the explain hook failed")

    def analysis(self, path: str) -> Analysis | None:
        a = self.analyses.get(path)
        if a is None and path in self.project.documents:
            self.run_check(path)
            a = self.analyses.get(path)
        return a

    def source(self, path: str) -> SourceFile | None:
        doc = self.project.documents.get(path)
        return doc.source if doc is not None else None

    def lua_path(self, a: Analysis) -> str | None:
        return a.check.config.semantics if a.check.config is not None else None

    async def work(self, method: str, params: dict) -> dict:
        if self.worker is None:
            raise WorkerError("this server was started without a worker (heavy features off)")
        return await self.worker.call(method, params, BUDGETS.get(method, 60.0))


def create_server(hooks: Hooks | None = None, version: str = "0") -> TmpcServer:
    server = TmpcServer(hooks or Hooks(), version)
    _register(server)
    return server


def _path(u: str) -> str:
    return norm(to_fs_path(u) or u)


def _register(ls: TmpcServer) -> None:  # noqa: C901 - one small handler per LSP method
    @ls.feature(T.INITIALIZE)
    def initialize(ls: TmpcServer, params: T.InitializeParams):
        roots = [_path(f.uri) for f in params.workspace_folders or []]
        if not roots and params.root_uri:
            roots = [_path(params.root_uri)]
        ls.project.roots = roots

    @ls.feature(T.INITIALIZED)
    async def initialized(ls: TmpcServer, params):
        if ls.worker is not None:
            try:
                await ls.worker.start()
            except OSError as exc:
                log.warning("cannot start the tmpc worker: %s", exc)

    @ls.feature(T.SHUTDOWN)
    async def shutdown(ls: TmpcServer, params):
        if ls.worker is not None:
            await ls.worker.stop()

    @ls.feature(T.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: TmpcServer, params: T.DidOpenTextDocumentParams):
        path = _path(params.text_document.uri)
        ls.project.open(path, params.text_document.text, params.text_document.version)
        ls.project.rescan()
        ls.run_check(path)

    @ls.feature(T.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: TmpcServer, params: T.DidChangeTextDocumentParams):
        path = _path(params.text_document.uri)
        doc = ls.project.documents.get(path)
        if doc is None:
            return
        text = doc.source.text
        for change in params.content_changes:
            if isinstance(change, T.TextDocumentContentChangePartial):
                src = SourceFile(path, text)
                a, b = offset(src, change.range.start), offset(src, change.range.end)
                text = text[:a] + change.text + text[b:]
            else:
                text = change.text
        ls.project.open(path, text, params.text_document.version)
        ls._edited.setdefault(path, time.perf_counter())
        ls.schedule(path)

    @ls.feature(T.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: TmpcServer, params: T.DidSaveTextDocumentParams):
        ls.project.rescan()
        ls.run_check(_path(params.text_document.uri))

    @ls.feature(T.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: TmpcServer, params: T.DidCloseTextDocumentParams):
        path = _path(params.text_document.uri)
        ls.project.close(path)
        ls.analyses.pop(path, None)
        ls.text_document_publish_diagnostics(T.PublishDiagnosticsParams(uri=uri(path),
                                                                        diagnostics=[]))

    @ls.feature(T.TEXT_DOCUMENT_HOVER)
    def on_hover(ls: TmpcServer, params: T.HoverParams):
        path, src, a = _at(ls, params)
        if src is None:
            return None
        off = offset(src, params.position)
        occ = a.index.at(path, off) if a is not None else None
        if occ is None:
            word = _word_at(src.text, off)
            text = hover.builtin_hover(word) if word else None
            return T.Hover(contents=T.MarkupContent(kind=T.MarkupKind.Markdown, value=text)) \
                if text else None
        text = hover.hover_text(occ, a.index, a.check.files, norm, ls.hooks.explain,
                                a.scope, ls.lua_path(a))
        return T.Hover(contents=T.MarkupContent(kind=T.MarkupKind.Markdown, value=text),
                       range=span_range(src, occ.span))

    @ls.feature(T.TEXT_DOCUMENT_COMPLETION,
                T.CompletionOptions(trigger_characters=["(", ":", "?", "-"]))
    def on_completion(ls: TmpcServer, params: T.CompletionParams):
        path, src, a = _at(ls, params)
        if src is None:
            return []
        is_problem = (ls.project.kind(path) or ("",))[0] == "problem"
        items = complete.complete(src.text, offset(src, params.position),
                                  a.index if a else None, is_problem, path)
        return T.CompletionList(is_incomplete=False, items=items)

    @ls.feature(T.TEXT_DOCUMENT_DEFINITION)
    def on_definition(ls: TmpcServer, params: T.DefinitionParams):
        path, src, a = _at(ls, params)
        occ = _occ(a, path, src, params.position)
        if occ is None:
            return None
        locs = [navigate.location(d, a.check.files, norm) for d in a.index.definitions(occ)]
        decl = a.index.predicates.get(occ.key) if occ.kind == "predicate" else None
        if decl is not None and decl.external:
            lua = ls.lua_path(a)
            text = ls.project.text(lua) if lua else None
            locs.append(navigate.lua_definition(decl.name.text, lua, text))
        return [x for x in locs if x is not None] or None

    @ls.feature(T.TEXT_DOCUMENT_REFERENCES)
    def on_references(ls: TmpcServer, params: T.ReferenceParams):
        path, src, a = _at(ls, params)
        idx, files = _wide(ls, path, a)
        occ = _occ(a, path, src, params.position)
        if occ is None:
            return None
        return [loc for o in idx.references(occ)
                if (loc := navigate.location(o, files, norm)) is not None
                and (params.context.include_declaration or not o.definition)]

    @ls.feature(T.TEXT_DOCUMENT_PREPARE_RENAME)
    def on_prepare_rename(ls: TmpcServer, params: T.PrepareRenameParams):
        path, src, a = _at(ls, params)
        occ = _occ(a, path, src, params.position)
        return span_range(src, occ.span) if occ is not None else None

    @ls.feature(T.TEXT_DOCUMENT_RENAME)
    def on_rename(ls: TmpcServer, params: T.RenameParams):
        path, src, a = _at(ls, params)
        occ = _occ(a, path, src, params.position)
        if occ is None:
            return None
        idx, files = _wide(ls, path, a)
        new = params.new_name
        if occ.kind == "parameter" and not new.startswith("?"):
            new = "?" + new
        return navigate.rename_edits(occ, idx, new, files, norm)

    @ls.feature(T.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def on_symbols(ls: TmpcServer, params: T.DocumentSymbolParams):
        path = _path(params.text_document.uri)
        doc = ls.project.documents.get(path)
        if doc is None:
            return []
        return navigate.document_symbols(doc.parse().definitions, doc.source)

    @ls.feature(T.TEXT_DOCUMENT_FOLDING_RANGE)
    def on_folding(ls: TmpcServer, params: T.FoldingRangeParams):
        src = ls.source(_path(params.text_document.uri))
        return navigate.folding(src) if src is not None else []

    @ls.feature(T.TEXT_DOCUMENT_FORMATTING)
    def on_formatting(ls: TmpcServer, params: T.DocumentFormattingParams):
        src = ls.source(_path(params.text_document.uri))
        return navigate.formatting(src) if src is not None else None

    @ls.feature(T.TEXT_DOCUMENT_SEMANTIC_TOKENS_FULL,
                T.SemanticTokensLegend(token_types=navigate.TOKEN_TYPES,
                                       token_modifiers=navigate.TOKEN_MODIFIERS))
    def on_tokens(ls: TmpcServer, params: T.SemanticTokensParams):
        path, src, a = _at(ls, params)
        if src is None or a is None:
            return T.SemanticTokens(data=[])
        return T.SemanticTokens(data=navigate.semantic_tokens(a.index, path, src))

    @ls.feature(T.TEXT_DOCUMENT_CODE_ACTION,
                T.CodeActionOptions(code_action_kinds=[T.CodeActionKind.QuickFix,
                                                       T.CodeActionKind.Empty]))
    def on_code_action(ls: TmpcServer, params: T.CodeActionParams):
        path, src, a = _at(ls, params)
        if src is None:
            return []
        domain = _domain_file(ls, path, a)
        out = [fix for d in params.context.diagnostics
               for fix in fixes.quick_fixes(d, path, src, domain)]
        occ = _occ(a, path, src, params.range.start)
        if occ is not None and occ.kind == "predicate" and ls.worker is not None:
            decl = a.index.predicates.get(occ.key)
            if decl is not None and decl.kind is A.Kind.GEOMETRIC:
                args = _atom_args(a, occ)
                # a bare Command (LSP allows it here): clients tell it from a CodeAction by
                # shape, a CodeAction holding only a command is ambiguous to some
                out.append(T.Command(title=f"Sample a witness of `{decl.name.text}`",
                                     command="tmpc.witness",
                                     arguments=[uri(path), decl.name.text, args]))
        return out

    @ls.feature(T.TEXT_DOCUMENT_CODE_LENS)
    def on_code_lens(ls: TmpcServer, params: T.CodeLensParams):
        path, src, a = _at(ls, params)
        if src is None or a is None or a.check.config is None or ls.worker is None:
            return []
        out = []
        for defn in _defs(ls, path):
            if isinstance(defn, A.Domain):
                for act in defn.actions:
                    out.append(_lens(src, act.name.span, {"action": act.name.text}, path))
            elif isinstance(defn, A.Problem) and defn.goal is not None:
                out.append(_lens(src, defn.goal.span, {"goal": True}, path))
        return out

    @ls.feature(T.CODE_LENS_RESOLVE)
    async def on_lens_resolve(ls: TmpcServer, lens: T.CodeLens):
        data = lens.data or {}
        lens.command = await _evaluate_lens(ls, data)
        return lens

    @ls.command("tmpc.evaluate")
    # a command's arguments are its positional parameters (TmpcProtocol)
    async def cmd_evaluate(ls: TmpcServer, data: dict | None = None):
        data = data or {}
        cmd = await _evaluate_lens(ls, data)
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Info, message=cmd.title))
        return cmd.title

    @ls.command("tmpc.witness")
    async def cmd_witness(ls: TmpcServer, *args):
        return await _witness(ls, *args)

    @ls.command("tmpc.view")
    async def cmd_view(ls: TmpcServer, doc_uri: str, state_path: str):
        return await _view(ls, _path(doc_uri), state_path)

    @ls.command("tmpc.checkStatic")
    async def cmd_static(ls: TmpcServer, doc_uri: str):
        return await _static(ls, _path(doc_uri))

    @ls.feature("tmpc/stats")
    def stats(ls: TmpcServer, params):
        docs = [[uri(p), hashlib.sha256(d.source.text.encode()).hexdigest()]
                for p, d in ls.project.documents.items()]
        return {"latencies": list(ls.latencies), "documents": docs,
                "worker": ls.worker.pid if ls.worker is not None else None}


# ---- handler helpers -------------------------------------------------------------------------
def _at(ls: TmpcServer, params):
    path = _path(params.text_document.uri)
    src = ls.source(path)
    return path, src, ls.analysis(path) if src is not None else None


def _occ(a: Analysis | None, path: str, src, pos: T.Position):
    if a is None or src is None:
        return None
    return a.index.at(path, offset(src, pos))


def _word_at(text: str, off: int) -> str | None:
    stop = set('() \t\r\n;"')
    i = off
    while i > 0 and text[i - 1] not in stop:
        i -= 1
    j = off
    while j < len(text) and text[j] not in stop:
        j += 1
    return text[i:j].lower() or None


def _wide(ls: TmpcServer, path: str, a: Analysis | None):
    """An index over the domain and every problem in the workspace that names it."""
    kind = ls.project.kind(path)
    if kind is None:
        return (a.index, a.check.files) if a else (Index(), {})
    domains = [path] if kind[0] == "domain" else ls.project.domains_named(kind[1])[:1]
    paths = list(dict.fromkeys(domains + ls.project.problems_of(kind[1])))
    ws = Overlay(ls.project)
    report = check_parsed(ws, [ws.load(p) for p in paths])
    return build_index(report.sources), {norm(k): v for k, v in ws.files.items()}


def _domain_file(ls: TmpcServer, path: str, a: Analysis | None):
    kind = ls.project.kind(path)
    if kind is None or kind[0] != "problem":
        return None
    doms = ls.project.domains_named(kind[1])
    if not doms:
        return None
    text = ls.project.text(doms[0])
    return (doms[0], SourceFile(doms[0], text)) if text is not None else None


def _defs(ls: TmpcServer, path: str):
    doc = ls.project.documents.get(path)
    return doc.parse().definitions if doc is not None else []


def _atom_args(a: Analysis, occ) -> list[str] | None:
    """Ground arguments when the predicate at the cursor is an atom of the problem."""
    for prog in a.index.programs:
        p = prog.problem
        if p is None or p.span is None or p.span.path != occ.span.path:
            continue
        for f in _atoms(p.goal):
            if f.pred.span == occ.span and all(isinstance(t, A.Const) for t in f.args):
                return [t.name.text for t in f.args]
    return None


def _atoms(f):
    if isinstance(f, A.Atom):
        yield f
    for part in getattr(f, "parts", ()) or ():
        yield from _atoms(part)
    for attr in ("part", "body", "left", "right"):
        x = getattr(f, attr, None)
        if x is not None and not isinstance(x, (str, A.Name)):
            yield from _atoms(x)


def _lens(src: SourceFile, span: Span, data: dict, path: str) -> T.CodeLens:
    return T.CodeLens(range=span_range(src, span), data={**data, "path": path})


async def _evaluate_lens(ls: TmpcServer, data: dict) -> T.Command:
    path = data.get("path")
    config = ls.project.config_for(path) if path else None
    if config is None:
        return T.Command(title="no run configuration names this file", command="")
    params = {"config": config.path}
    what = "goal" if data.get("goal") else f"`{data.get('action')}`"
    if data.get("goal"):
        params["goal"] = True
    else:
        params["action"] = data.get("action")
    try:
        r = await ls.work("evaluate", params)
    except WorkerError as exc:
        return T.Command(title=f"evaluate {what}: {exc}", command="")
    if "groundings" in r:
        best = r.get("best") or {}
        title = (f"at the start state: {r['holding']} of {r['groundings']} groundings hold"
                 + (f"; nearest ({' '.join(best.get('args', []))}) distance "
                    f"{best.get('distance', float('nan')):.4g}" if best else ""))
    else:
        title = f"at the start state: {str(r['holds']).lower()}, distance {r['distance']:.4g}"
    return T.Command(title=title, command="tmpc.evaluate", arguments=[data])


async def _witness(ls: TmpcServer, doc_uri: str, predicate: str, args=None, seed: int = 0):
    path = _path(doc_uri)
    config = ls.project.config_for(path)
    if config is None:
        msg = "no run configuration in the workspace names this file: a witness needs a scene"
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Warning, message=msg))
        return {"found": False, "message": msg}
    params = {"config": config.path, "predicate": predicate, "args": args, "seed": seed}
    try:
        r = await ls.work("witness", params)
    except WorkerError as exc:
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Error,
                                                   message=f"tmpc witness: {exc}"))
        return {"found": False, "message": str(exc), "diagnostics": exc.diagnostics}
    if not r.get("found"):
        msg = f"no state where `{predicate}` holds within the sampling budget"
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Warning, message=msg))
        return {**r, "message": msg}
    r["state_path"] = _write_state(r["state"], predicate)
    joints = ", ".join(f"{k} {v:.3f}" for k, v in list(r.get("joints", {}).items())[:12])
    message = (f"witness of ({predicate} {' '.join(r.get('args') or args or [])}): distance "
               f"{r['distance']:.2g}; joints {joints}; state in {r['state_path']} "
               f"(tmpc eval {config.path} --state {r['state_path']})")
    # offered, not awaited: the command answers now, the page is drawn if the user asks
    offer = asyncio.ensure_future(_offer_view(ls, message, path, r["state_path"]))
    ls._offers.add(offer)
    offer.add_done_callback(ls._offers.discard)
    return r


VIEW = "Open in tmpc view"


async def _offer_view(ls: TmpcServer, message: str, path: str, state_path: str) -> None:
    try:
        choice = await ls.window_show_message_request_async(T.ShowMessageRequestParams(
            type=T.MessageType.Info, message=message,
            actions=[T.MessageActionItem(title=VIEW)]))
    except Exception:          # a client without message requests: the plain message
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Info, message=message))
        return
    if choice is not None and choice.title == VIEW:
        await _view(ls, path, state_path)


async def _view(ls: TmpcServer, path: str, state_path: str) -> dict:
    """Draw a state (a witness's state file) as ``tmpc view`` draws a plan, and ask the client
    to open the page (``window/showDocument``, in the browser)."""
    config = ls.project.config_for(path)
    if config is None:
        return {"message": "no run configuration in the workspace names this file"}
    try:
        with open(state_path, encoding="utf-8") as f:
            state = json.load(f)
        out = os.path.splitext(state_path)[0] + ".html"
        r = await ls.work("view", {"config": config.path, "state": state, "out": out})
    except (OSError, ValueError, WorkerError) as exc:
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Error,
                                                   message=f"tmpc view: {exc}"))
        return {"message": str(exc)}
    try:
        shown = await ls.window_show_document_async(T.ShowDocumentParams(
            uri=uri(r["path"]), external=True))
        r["shown"] = bool(shown and shown.success)
    except Exception:           # a client without showDocument: say where the page is
        r["shown"] = False
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Info,
                                                   message=f"tmpc view: {r['path']}"))
    return r


def _write_state(state: dict, name: str) -> str:
    """The witness state as a file `tmpc eval --state` and the viewer read (atomic write)."""
    folder = os.path.join(tempfile.gettempdir(), "tmpc-lsp")
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, f"witness-{name}.json")
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(state, f)
    os.replace(tmp, path)
    return path


async def _static(ls: TmpcServer, path: str):
    """W610-W614 for the file's run configuration, published with its other diagnostics."""
    config = ls.project.config_for(path)
    if config is None:
        return {"diagnostics": 0, "message": "no run configuration names this file"}
    try:
        found = await ls.work("static", {"config": config.path})
    except WorkerError as exc:
        ls.window_show_message(T.ShowMessageParams(type=T.MessageType.Error,
                                                   message=f"tmpc static checks: {exc}"))
        return {"diagnostics": 0, "message": str(exc)}
    ls.static = {}
    for d in found:
        p = norm(d["path"]) if d.get("path") else path
        text = ls.project.text(p)
        if text is None:
            continue
        src = SourceFile(p, text)
        ls.static.setdefault(p, []).append(_json_diagnostic(d, src))
    for p in list(ls.project.documents):
        ls.run_check(p)
    return {"diagnostics": len(found)}


def _json_diagnostic(d: dict, src: SourceFile) -> T.Diagnostic:
    rng = span_range(src, Span(src.path, d["start"], d["end"]) if d.get("start") is not None
                     else None)
    sev = T.DiagnosticSeverity.Error if d.get("severity") == "error" else \
        T.DiagnosticSeverity.Warning
    msg = d["message"] + (f"\nhint: {d['hint']}" if d.get("hint") else "")
    return T.Diagnostic(range=rng, message=msg, severity=sev, code=d.get("code"),
                        source="tmpc --static", data={"code": d.get("code"),
                                                      "hint": d.get("hint")})
