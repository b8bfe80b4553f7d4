"""`tmpc lsp` end to end: a real LSP client (pytest-lsp) speaks to the server over stdio.

The examples are copied into a temporary workspace, so edits and renames never touch the repo.
The server runs without its worker here (``--no-worker``); the worker features are tested in
tests/runtime/test_lsp_worker.py, the process itself (start, --tcp) in test_lsp_process.py.
"""

from __future__ import annotations

import hashlib
import shutil
import sys
from pathlib import Path

import pytest
import pytest_lsp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lsprotocol import types as T
from pytest_lsp import ClientServerConfig, LanguageClient

from tests.lspclient import mark, open_document, published
from tmpc.lang.formatter import format_doc
from tmpc.lang.sexpr import parse_sexpr
from tmpc.lang.source import SourceFile

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.asyncio(loop_scope="module")
_VERSION = 1000      # document versions the random-edit test sends


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    ws = tmp_path_factory.mktemp("ws")
    for name in ("clutter", "tmit-star-sort"):
        shutil.copytree(ROOT / "examples" / name, ws / name)
    return ws


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(
    server_command=[sys.executable, "-m", "tmpc.runtime.cli", "lsp", "--no-worker"]))
async def client(lsp_client: LanguageClient, workspace):
    await lsp_client.initialize_session(T.InitializeParams(
        capabilities=T.ClientCapabilities(), root_uri=workspace.as_uri(),
        workspace_folders=[T.WorkspaceFolder(uri=workspace.as_uri(), name="ws")]))
    yield
    await lsp_client.shutdown_session()



def _pos(text: str, needle: str, skip: int = 0, into: int = 1) -> T.Position:
    """The position ``into`` characters into the ``skip``-th occurrence of ``needle``."""
    at = -1
    for _ in range(skip + 1):
        at = text.index(needle, at + 1)
    src = SourceFile("t", text)
    line, ch = src.lsp_position(at + into)
    return T.Position(line=line, character=ch)


def _change(client, uri, version, start: T.Position, end: T.Position, new: str) -> None:
    client.text_document_did_change(T.DidChangeTextDocumentParams(
        text_document=T.VersionedTextDocumentIdentifier(uri=uri, version=version),
        content_changes=[T.TextDocumentContentChangePartial(range=T.Range(start=start, end=end),
                                                            text=new)]))


def _codes(client, uri) -> list[str]:
    return [d.code for d in client.diagnostics.get(uri, [])]


async def test_diagnostics_after_open_and_after_an_incremental_edit(client, workspace):
    path = workspace / "clutter" / "domain.pddl"
    text = path.read_text()
    uri = await open_document(client, path)
    assert not [d for d in client.diagnostics[uri] if d.severity == T.DiagnosticSeverity.Error]
    # two mistakes at once (a misspelled predicate, a bad number of arguments): both reported
    at = _pos(text, "(arm-empty ?m) (at ?m ?x))", into=1)
    before = mark(client, uri)
    _change(client, uri, 2, at, T.Position(line=at.line, character=at.character + 9), "arm-emty")
    await published(client, uri, before)
    codes = _codes(client, uri)
    assert "E200" in codes
    bad = next(d for d in client.diagnostics[uri] if d.code == "E200")
    assert bad.range.start == at and "arm-empty" in bad.message + "".join(
        str(bad.data.get("hint")) for _ in [0])
    # undo: clean again
    before = mark(client, uri)
    _change(client, uri, 3, at, T.Position(line=at.line, character=at.character + 8), "arm-empty")
    await published(client, uri, before)
    assert "E200" not in _codes(client, uri)


async def test_a_problem_is_checked_against_its_domain_elsewhere_in_the_workspace(client,
                                                                               workspace):
    path = workspace / "clutter" / "problem.pddl"
    text = path.read_text().replace("(arm-empty l_gripper_tool_frame)\n    (arm",
                                    "(arm-empty l_gripper_tool_frame blue_stick_1)\n    (arm", 1)
    uri = await open_document(client, path, text)
    assert "E202" in _codes(client, uri)      # arity: known only from the domain file


async def test_non_ascii_comments_keep_positions_in_utf16(client, workspace):
    path = workspace / "clutter" / "emoji.pddl"
    text = ("; 🤖 robot — ünïcode\n(define (domain emo) (:requirements :strips)\n"
            "  (:predicates (p)) ; 🤖🤖 x\n  (:action a :parameters () :precondition (q) "
            ":effect (p)))\n")
    path.write_text(text)
    uri = await open_document(client, path, text)
    bad = next(d for d in client.diagnostics[uri] if d.code == "E200")
    # line 3 (0-based), the `q` after "(:action a :parameters () :precondition ("
    assert bad.range.start == T.Position(line=3, character=text.splitlines()[3].index("(q)") + 1)
    hover = await client.text_document_hover_async(T.HoverParams(
        text_document=T.TextDocumentIdentifier(uri=uri),
        position=T.Position(line=2, character=text.splitlines()[2].index("(p)") + 1)))
    assert hover is not None and "discrete predicate" in hover.contents.value
    path.unlink()


async def test_hover_on_a_native_geometric_predicate_shows_its_compiled_distance(client,
                                                                              workspace):
    path = workspace / "clutter" / "domain.pddl"
    text = path.read_text()
    uri = await open_document(client, path)
    hover = await client.text_document_hover_async(T.HoverParams(
        text_document=T.TextDocumentIdentifier(uri=uri), position=_pos(text, "(at ?m ?x))")))
    value = hover.contents.value
    assert "geometric predicate" in value and "(at ?m - manipulator ?x - stick)" in value
    # `near` (a tmpc/geometry helper) inlined: the distance is the hinge of the 5 cm threshold
    assert "max(distance(position(?m), position(?x)) - 0.05, 0)" in value
    assert "the gripper's tool frame is close enough" in value      # the comment above it
    hover = await client.text_document_hover_async(T.HoverParams(
        text_document=T.TextDocumentIdentifier(uri=uri), position=_pos(text, "(holding ?m ?x)")))
    assert "kinematic predicate" in hover.contents.value and "attached" in hover.contents.value


async def test_hover_on_a_tmit_star_lua_predicate_shows_the_traced_distance(client, workspace):
    path = workspace / "tmit-star-sort" / "domain.pddl"
    text = path.read_text()
    uri = await open_document(client, path)
    hover = await client.text_document_hover_async(T.HoverParams(
        text_document=T.TextDocumentIdentifier(uri=uri), position=_pos(text, "(at ?m ?x))")))
    value = hover.contents.value
    assert "geometric predicate" in value
    assert "unsatisfaction distance" in value and "x(?x) - x(?m)" in value   # traced from Lua


async def test_completion_in_three_contexts(client, workspace):
    path = workspace / "clutter" / "domain.pddl"
    text = path.read_text()
    uri = await open_document(client, path)

    async def labels(position) -> set[str]:
        got = await client.text_document_completion_async(T.CompletionParams(
            text_document=T.TextDocumentIdentifier(uri=uri), position=position))
        return {i.label for i in got.items}

    # a formula head inside a precondition: predicates and connectives
    heads = await labels(_pos(text, "(on-surface ?x ?s) (arm-empty", into=1))
    assert {"on-surface", "at", "placed", "and", "not"} <= heads
    # a `?` in an action: that action's parameters
    params = await labels(_pos(text, "?s) (arm-empty ?m) (at", into=1))
    assert params == {"?x", "?s", "?m"}
    # a `:semantics` body head: built-ins with signatures and the included helpers
    expr = await labels(_pos(text, "(near ?m ?x 0.05)", into=1))
    assert {"distance", "position", "near", "upright"} <= expr
    # a section keyword
    keys = await labels(_pos(text, "(:action pickup", into=2))
    assert ":predicates" in keys and ":action" in keys


async def test_definition_references_and_rename_across_domain_and_problem(client, workspace):
    dom, prob = workspace / "clutter" / "domain.pddl", workspace / "clutter" / "problem.pddl"
    dtext, ptext = dom.read_text(), prob.read_text()
    duri = await open_document(client, dom)
    puri = await open_document(client, prob, ptext)
    ident = T.TextDocumentIdentifier(uri=puri)
    got = await client.text_document_definition_async(T.DefinitionParams(
        text_document=ident, position=_pos(ptext, "(on-surface blue_stick_1 table1)")))
    assert got[0].uri == duri and got[0].range.start == _pos(dtext, "(on-surface ?x - stick")
    refs = await client.text_document_references_async(T.ReferenceParams(
        text_document=ident, position=_pos(ptext, "(arm-empty l_gripper"),
        context=T.ReferenceContext(include_declaration=True)))
    where = sorted((r.uri == duri, r.range.start.line) for r in refs)
    assert sum(1 for d, _ in where if d) == dtext.count("arm-empty")
    assert sum(1 for d, _ in where if not d) == ptext.count("arm-empty")
    edit = await client.text_document_rename_async(T.RenameParams(
        text_document=ident, position=_pos(ptext, "(arm-empty l_gripper"), new_name="hand-free"))
    assert {u: len(e) for u, e in edit.changes.items()} == {duri: dtext.count("arm-empty"),
                                                           puri: ptext.count("arm-empty")}
    # a parameter renames within its action only
    edit = await client.text_document_rename_async(T.RenameParams(
        text_document=T.TextDocumentIdentifier(uri=duri), position=_pos(dtext, "?s - surface ?m"),
        new_name="?table"))
    lines = {e.range.start.line for e in edit.changes[duri]}
    first = _pos(dtext, "(:action pickup").line
    second = _pos(dtext, "(:action putdown").line
    assert lines and all(first <= ln < second for ln in lines)


async def test_definition_of_a_lua_predicate_goes_into_the_lua_file(client, workspace):
    path = workspace / "tmit-star-sort" / "domain.pddl"
    text = path.read_text()
    uri = await open_document(client, path)
    got = await client.text_document_definition_async(T.DefinitionParams(
        text_document=T.TextDocumentIdentifier(uri=uri), position=_pos(text, "(above ?m ?s))")))
    lua = [g for g in got if g.uri.endswith("predicates.lua")]
    assert lua, got
    line = (workspace / "tmit-star-sort" / "predicates.lua").read_text().splitlines()[
        lua[0].range.start.line]
    assert "above" in line and "function" in line


async def test_formatting_equals_tmpc_fmt_and_symbols_and_folding(client, workspace):
    path = workspace / "clutter" / "domain.pddl"
    messy = path.read_text().replace("\n  (:action", "\n(:action").replace("  ", " ")
    uri = await open_document(client, path, messy)
    edits = await client.text_document_formatting_async(T.DocumentFormattingParams(
        text_document=T.TextDocumentIdentifier(uri=uri),
        options=T.FormattingOptions(tab_size=2, insert_spaces=True)))
    assert len(edits) == 1
    assert edits[0].new_text == format_doc(parse_sexpr(SourceFile(str(path), messy)))
    assert edits[0].new_text != messy
    symbols = await client.text_document_document_symbol_async(T.DocumentSymbolParams(
        text_document=T.TextDocumentIdentifier(uri=uri)))
    names = {c.name for c in symbols[0].children}
    assert symbols[0].name == "clutter" and {"pickup", "putdown", "at", "stick"} <= names
    folds = await client.text_document_folding_range_async(T.FoldingRangeParams(
        text_document=T.TextDocumentIdentifier(uri=uri)))
    assert any(f.start_line == 0 and f.kind == T.FoldingRangeKind.Comment for f in folds)
    assert len([f for f in folds if f.kind is None]) >= 4


async def test_quick_fixes_did_you_mean_requirement_and_declare(client, workspace):
    path = workspace / "clutter" / "fix.pddl"
    text = ("(define (domain fix) (:requirements :strips)\n  (:types thing)\n"
            "  (:predicates (ready ?t - thing))\n"
            "  (:action go :parameters (?t - thing) :precondition (and (redy ?t) (not (ready ?t)))"
            "\n    :effect (and (ready ?t) (gone ?t))))\n")
    path.write_text(text)
    uri = await open_document(client, path, text)
    diags = client.diagnostics[uri]
    assert {"E200", "W001"} <= {d.code for d in diags}
    actions = await client.text_document_code_action_async(T.CodeActionParams(
        text_document=T.TextDocumentIdentifier(uri=uri), range=diags[0].range,
        context=T.CodeActionContext(diagnostics=list(diags))))
    titles = {a.title for a in actions}
    assert "Change to `ready`" in titles
    assert "Add `:negative-preconditions` to :requirements" in titles
    assert "Declare predicate `gone`" in titles
    declare = next(a for a in actions if a.title == "Declare predicate `gone`")
    edit = declare.edit.changes[uri][0]
    assert edit.new_text.strip() == "(gone ?x1)"
    path.unlink()


async def test_semantic_tokens_colour_predicates_by_kind(client, workspace):
    path = workspace / "clutter" / "domain.pddl"
    text = path.read_text()
    uri = await open_document(client, path)
    got = await client.text_document_semantic_tokens_full_async(T.SemanticTokensParams(
        text_document=T.TextDocumentIdentifier(uri=uri)))
    from tmpc.lang.lsp.navigate import TOKEN_MODIFIERS, TOKEN_TYPES
    line = ch = 0
    kinds = {}
    for i in range(0, len(got.data), 5):
        dl, dc, length, ttype, mods = got.data[i:i + 5]
        line, ch = line + dl, (ch + dc if dl == 0 else dc)
        word = text.splitlines()[line][ch:ch + length]
        if TOKEN_TYPES[ttype] == "function":
            kinds[word] = [m for j, m in enumerate(TOKEN_MODIFIERS) if mods >> j & 1]
    assert "geometric" in kinds["at"] and "kinematic" in kinds["holding"]
    assert "discrete" in kinds["on-surface"]


PIECES = ["(", ")", "?x", ":semantics", " (and", "🤖", "\n", "\"", ";", "-", "(:action q",
          "(:predicates", "(near ?g ?c", "é", ""]
EDIT = st.tuples(st.floats(0, 1), st.integers(0, 6), st.sampled_from(PIECES), st.floats(0, 1))


@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edits=st.lists(EDIT, min_size=1, max_size=12))
async def test_random_edits_never_crash_the_server(client, workspace, edits):
    """Random incremental edits (hypothesis; UTF-16 positions with emoji and accents), each
    followed by a hover and a completion at a random place: no error, and the server's text
    is the client's."""
    path = workspace / "clutter" / "domain.pddl"
    text = path.read_text()
    global _VERSION
    if _VERSION == 1000:
        await open_document(client, path)
    uri = path.as_uri()
    _VERSION += 1
    client.text_document_did_change(T.DidChangeTextDocumentParams(
        text_document=T.VersionedTextDocumentIdentifier(uri=uri, version=_VERSION),
        content_changes=[T.TextDocumentContentChangeWholeDocument(text=text)]))
    for where, length, new, look in edits:
        src = SourceFile("t", text)
        a = int(where * len(text))
        b = min(len(text), a + length)
        start, end = src.lsp_position(a), src.lsp_position(b)
        _VERSION += 1
        _change(client, uri, _VERSION, T.Position(line=start[0], character=start[1]),
                T.Position(line=end[0], character=end[1]), new)
        text = text[:a] + new + text[b:]
        pos = SourceFile("t", text).lsp_position(int(look * len(text)))
        position = T.Position(line=pos[0], character=pos[1])
        await client.text_document_hover_async(T.HoverParams(
            text_document=T.TextDocumentIdentifier(uri=uri), position=position))
        await client.text_document_completion_async(T.CompletionParams(
            text_document=T.TextDocumentIdentifier(uri=uri), position=position))
    got = await client.text_document_formatting_async(T.DocumentFormattingParams(
        text_document=T.TextDocumentIdentifier(uri=uri),
        options=T.FormattingOptions(tab_size=2, insert_spaces=True)))
    assert got is None or isinstance(got, (list, tuple))
    stats = await client.protocol.send_request_async("tmpc/stats", {})
    assert [uri, hashlib.sha256(text.encode()).hexdigest()] in [list(d) for d in stats.documents]
    assert not [m for m in client.messages if m.type == T.MessageType.Error]


async def test_the_random_edits_were_checked(client, workspace):
    """The edits above were checked and published (didChange to publish, server side)."""
    stats = await client.protocol.send_request_async("tmpc/stats", {})
    assert len(stats.latencies) >= 1
