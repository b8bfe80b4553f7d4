"""`tmpc lsp` with its worker process, end to end over stdio (pytest-lsp): the witness command
returns a state `tmpc eval` confirms, code lenses evaluate at the start state, the static checks
arrive as diagnostics, and a worker that dies is reported while the server lives on.

The tabletop example is copied into a temporary workspace (the static checks test edits it).
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import signal
import sys
from pathlib import Path

import pytest
import pytest_lsp
from lsprotocol import types as T
from pytest_lsp import ClientServerConfig, LanguageClient

from tests.lspclient import open_document
from tests.support import EXAMPLES

pytestmark = pytest.mark.asyncio(loop_scope="module")


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    ws = tmp_path_factory.mktemp("ws")
    shutil.copytree(EXAMPLES / "tabletop", ws / "tabletop")
    return ws


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(
    server_command=[sys.executable, "-m", "tmpc.runtime.cli", "lsp"]))
async def client(lsp_client: LanguageClient, workspace):
    # window/showMessageRequest as an editor answers it: the user's choice (None: dismissed)
    lsp_client.asked, lsp_client.choose = [], None

    def ask(params: T.ShowMessageRequestParams):
        lsp_client.asked.append(params)
        return lsp_client.choose(params) if lsp_client.choose else None
    lsp_client.feature(T.WINDOW_SHOW_MESSAGE_REQUEST)(ask)
    await lsp_client.initialize_session(T.InitializeParams(
        capabilities=T.ClientCapabilities(), root_uri=workspace.as_uri(),
        workspace_folders=[T.WorkspaceFolder(uri=workspace.as_uri(), name="ws")]))
    yield
    await lsp_client.shutdown_session()



def _cli(capsys, *argv) -> tuple[int, str]:
    from tmpc.runtime.cli.main import main
    capsys.readouterr()
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().out


async def _command(client: LanguageClient, name: str, *arguments):
    return await client.workspace_execute_command_async(
        T.ExecuteCommandParams(command=name, arguments=list(arguments)))


async def test_the_witness_command_returns_a_state_tmpc_eval_confirms(client, workspace, capsys):
    config = workspace / "tabletop" / "tabletop.toml"
    uri = await open_document(client, workspace / "tabletop" / "domain.pddl")
    text = (workspace / "tabletop" / "domain.pddl").read_text()
    at = text.index("(reach ?g ?c))") + 1
    line = text.count("\n", 0, at)
    ch = at - text.rindex("\n", 0, at) - 1
    actions = await client.text_document_code_action_async(T.CodeActionParams(
        text_document=T.TextDocumentIdentifier(uri=uri),
        range=T.Range(start=T.Position(line=line, character=ch),
                      end=T.Position(line=line, character=ch)),
        context=T.CodeActionContext(diagnostics=[])))
    offered = [a for a in actions if isinstance(a, T.Command) and a.command == "tmpc.witness"]
    assert [a.title for a in offered] == ["Sample a witness of `reach`"]
    got = await _command(client, "tmpc.witness", uri, "reach", ["panda_hand_tcp", "red_cube"], 0)
    assert got["found"] and got["holds"] and got["distance"] < 1e-3
    assert set(got["joints"]) == {f"panda_joint{i}" for i in range(1, 8)}
    state = Path(got["state_path"])
    assert json.loads(state.read_text()) == got["state"]
    code, out = _cli(capsys, "eval", config, "--state", state, "--predicate", "reach",
                     "panda_hand_tcp", "red_cube", "--json")
    assert code == 0 and json.loads(out)["value"] is True
    # the action's own arguments when none are given (the first grounding that fits)
    first = await _command(client, "tmpc.witness", uri, "reach", None, 0)
    assert first["args"] == ["panda_hand_tcp", "red_cube"] and first["found"]
    for _ in range(100):
        if client.asked:
            break
        await asyncio.sleep(0.05)
    assert any("witness of (reach panda_hand_tcp red_cube)" in m.message for m in client.asked)


async def test_the_witness_offers_tmpc_view_and_the_page_opens(client, workspace):
    uri = await open_document(client, workspace / "tabletop" / "domain.pddl")
    client.asked.clear()
    client.choose = lambda params: params.actions[0]
    shown = len(client.shown_documents)
    got = await _command(client, "tmpc.witness", uri, "reach", ["panda_hand_tcp", "blue_cube"],
                         2)
    assert got["found"]
    for _ in range(600):                     # the page is drawn after the command answered
        if len(client.shown_documents) > shown:
            break
        await asyncio.sleep(0.05)
    client.choose = None
    asked = client.asked
    assert [a.title for a in asked[0].actions] == ["Open in tmpc view"]
    assert "witness of (reach panda_hand_tcp blue_cube)" in asked[0].message
    page = client.shown_documents[-1]
    assert page.external and page.uri.endswith("witness-reach.html")
    html = Path(got["state_path"]).with_suffix(".html").read_text()
    assert html.startswith("<!doctype html>") and "(1 states, 0 actions)" in html
    # the command alone, on the state file
    direct = await _command(client, "tmpc.view", uri, got["state_path"])
    assert direct["shown"] and direct["bytes"] == len(html.encode())


async def test_code_lenses_evaluate_actions_and_the_goal_at_the_start(client, workspace,
                                                                         capsys):
    folder = workspace / "tabletop"
    domain, problem = folder / "domain.pddl", folder / "problem.pddl"
    lenses = []
    for path in (domain, problem):
        uri = await open_document(client, path)
        lenses += await client.text_document_code_lens_async(
            T.CodeLensParams(text_document=T.TextDocumentIdentifier(uri=uri)))
    assert [(lens.data.get("action"), lens.data.get("goal")) for lens in lenses] == \
        [("pick", None), ("place", None), (None, True)]
    titles = [(await client.code_lens_resolve_async(lens)).command.title for lens in lenses]
    # pick: no gripper reaches a cube at the start; place: nothing is held
    assert titles[0].startswith("at the start state: 0 of 4 groundings hold; nearest "), titles
    assert titles[2] == "at the start state: false, distance 0"
    code, out = _cli(capsys, "eval", workspace / "tabletop" / "tabletop.toml", "--predicate",
                     "reach", "panda_hand_tcp", "red_cube", "--json")
    assert code == 0 and json.loads(out)["value"] is False


async def test_the_static_checks_arrive_as_diagnostics(client, workspace):
    domain = workspace / "tabletop" / "domain.pddl"
    domain.write_text(domain.read_text().replace(
        "(near ?g ?c 0.02)", "(near ?g ?c 0.02) (> (z (position ?c)) 5.0)"))
    uri = await open_document(client, domain)
    got = await _command(client, "tmpc.checkStatic", uri)
    assert got["diagnostics"] >= 1, got
    # published before the command's answer, on the same stream
    unsat = [d for d in client.diagnostics[uri] if d.code == "W614"]
    assert unsat and all(d.source == "tmpc --static" for d in unsat)
    assert any("`reach`" in d.message for d in unsat)


async def test_a_dead_worker_is_reported_and_the_server_lives_on(client, workspace):
    problem = workspace / "tabletop" / "problem.pddl"
    uri = await open_document(client, problem)
    stats = await client.protocol.send_request_async("tmpc/stats", {})
    assert stats.worker
    os.kill(stats.worker, signal.SIGKILL)
    title = await _command(client, "tmpc.evaluate", {"goal": True, "path": str(problem)})
    assert "worker process exited" in title and "restarts on the next request" in title
    again = await _command(client, "tmpc.evaluate", {"goal": True, "path": str(problem)})
    assert again.startswith("at the start state: false")
    stats = await client.protocol.send_request_async("tmpc/stats", {})
    assert stats.worker and stats.worker != os.getpid()
    hover = await client.text_document_hover_async(T.HoverParams(
        text_document=T.TextDocumentIdentifier(uri=uri), position=T.Position(line=0, character=2)))
    assert hover is None or hover.contents


async def test_a_cancelled_request_stops_the_worker_and_the_next_one_runs(client, workspace):
    domain = workspace / "tabletop" / "domain.pddl"
    domain.write_text(domain.read_text() + "\n; edited: the static checks run again\n")
    uri = await open_document(client, domain)
    before = (await client.protocol.send_request_async("tmpc/stats", {})).worker
    rid = "static-to-cancel"
    pending = client.protocol.send_request(
        T.WORKSPACE_EXECUTE_COMMAND, T.ExecuteCommandParams(command="tmpc.checkStatic",
                                                            arguments=[uri]), msg_id=rid)
    await asyncio.sleep(0.5)                  # the worker is loading and checking (~2 s)
    client.protocol.notify(T.CANCEL_REQUEST, T.CancelParams(id=rid))
    with pytest.raises(Exception, match="(?i)cancel"):
        await asyncio.wrap_future(pending)
    for _ in range(100):                      # the server killed the worker
        if (await client.protocol.send_request_async("tmpc/stats", {})).worker is None:
            break
        await asyncio.sleep(0.05)
    assert (await client.protocol.send_request_async("tmpc/stats", {})).worker is None
    title = await _command(client, "tmpc.evaluate", {"goal": True,
                                                      "path": str(workspace / "tabletop" /
                                                                  "problem.pddl")})
    assert title.startswith("at the start state: false")
    after = (await client.protocol.send_request_async("tmpc/stats", {})).worker
    assert after and after != before
