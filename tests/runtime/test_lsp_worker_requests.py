"""The language server's worker (tmpc.runtime.lsp_worker): its request functions agree with the
commands (`tmpc sample`, `tmpc eval`, `tmpc check --static`), its cache notices edits, and the
process speaks only protocol lines on stdout, survives bad requests and exits on end of input."""

from __future__ import annotations

import itertools
import json
import shutil
import subprocess
import sys

import pytest

from tests.support import EXAMPLES, TABLETOP
from tmpc.lang.diagnostics import Diagnostic, Related, Severity, TmpcError
from tmpc.lang.source import Span
from tmpc.runtime.lsp_worker import diagnostic_to_json, respond, work

REACH = ["reach", "panda_hand_tcp", "red_cube"]


def cli(capsys, *argv) -> tuple[int, str]:
    """`tmpc ARGV...` in this process: (exit code, stdout)."""
    from tmpc.runtime.cli.main import main
    capsys.readouterr()
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().out


def call(method: str, **params) -> dict:
    return respond(json.dumps({"id": 7, "method": method, "params": params}))


@pytest.fixture
def tabletop_copy(tmp_path):
    """A writable copy of examples/tabletop."""
    shutil.copytree(EXAMPLES / "tabletop", tmp_path / "tabletop")
    return tmp_path / "tabletop"


# ---- witness -------------------------------------------------------------------------------
def test_witness_is_the_state_tmpc_sample_finds_and_tmpc_eval_confirms(tmp_path, capsys):
    got = work.witness(TABLETOP, predicate=REACH[0], args=REACH[1:], seed=0)
    assert got["found"] and got["holds"] and got["args"] == REACH[1:]
    assert got["tried"] >= 1 and set(got["rejected"]) == {"unconverged", "colliding"}
    assert set(got["joints"]) == {f"panda_joint{i}" for i in range(1, 8)}
    code, out = cli(capsys, "sample", TABLETOP, "--predicate", *REACH, "-n", "1", "--seed", "0")
    assert code == 0 and json.loads(out) == got["state"]
    state = tmp_path / "s.json"
    state.write_text(json.dumps(got["state"]))
    code, out = cli(capsys, "eval", TABLETOP, "--state", state, "--predicate", *REACH, "--json")
    shown = json.loads(out)
    assert code == 0 and shown["value"] is True
    assert shown["distance"] == pytest.approx(got["distance"], abs=1e-12)
    assert work.witness(TABLETOP, predicate="reach", args=REACH[1:], seed=0) == got
    other = work.witness(TABLETOP, predicate="reach", args=REACH[1:], seed=1)
    assert other["found"] and other["joints"] != got["joints"]


def test_witness_without_args_takes_the_first_grounding():
    got = work.witness(TABLETOP, predicate="reach", args=None, seed=0)
    assert got["args"] == ["panda_hand_tcp", "red_cube"] and got["found"]


# ---- evaluate ------------------------------------------------------------------------------
def test_evaluate_a_predicate_agrees_with_tmpc_eval(capsys):
    for args in (REACH[1:], ["panda_hand_tcp", "blue_cube"]):
        got = work.evaluate(TABLETOP, predicate="reach", args=args)
        code, out = cli(capsys, "eval", TABLETOP, "--predicate", "reach", *args, "--json")
        shown = json.loads(out)
        assert code == 0 and got == {"holds": shown["value"], "distance": shown["distance"]}
        assert got["distance"] > 0.01          # the start is far from the cubes


def test_evaluate_an_action_counts_every_type_fitting_grounding(tabletop_world):
    from tmpc.compiler.compile import compile_world
    compiled = compile_world(tabletop_world)
    formula = compiled.action("pick")
    names = [o.name.text for o in compiled.program.scope.objects.values()]
    fits = []
    for args in itertools.product(names, repeat=len(formula.params)):
        try:
            compiled.bind_args(formula, list(args))
        except TmpcError:
            continue
        fits.append(list(args))
    got = work.evaluate(TABLETOP, action="pick")
    assert got["groundings"] == got["evaluated"] == len(fits) == 4
    assert not got["truncated"] and got["skipped"] == 0
    each = [work.evaluate(TABLETOP, action="pick", args=a) for a in fits]
    assert got["holding"] == sum(e["holds"] for e in each)
    best = min(range(len(fits)), key=lambda i: each[i]["distance"])
    assert got["best"] == {"args": fits[best], **each[best]}


def test_evaluate_the_goal_at_the_start():
    got = work.evaluate(TABLETOP, goal=True)
    assert got == {"holds": False, "distance": 0.0,
                   "unmet": ["(on red_cube tray)", "(on blue_cube tray)"]}


def test_a_second_request_reuses_the_world_and_an_edit_reloads_it(tabletop_copy):
    config = tabletop_copy / "tabletop.toml"
    first = work.evaluate(config, goal=True)
    loads = work.WORLDS.loads
    assert work.evaluate(config, goal=True) == first and work.WORLDS.loads == loads
    problem = tabletop_copy / "problem.pddl"
    problem.write_text(problem.read_text().replace(
        "(:goal (and (on red_cube tray) (on blue_cube tray)))", "(:goal (on red_cube bench))"))
    assert work.evaluate(config, goal=True)["holds"] is True
    assert work.WORLDS.loads == loads + 1


# ---- static checks and diagnostics ---------------------------------------------------------
def test_static_checks_are_what_check_static_adds(tabletop_copy, capsys):
    domain = tabletop_copy / "domain.pddl"
    domain.write_text(domain.read_text().replace(
        ":precondition (and (holding ?g ?c) (over ?g ?s)",
        ":precondition (and (holding ?g ?c) (not (holding ?g ?c)) (over ?g ?s)").replace(
        "(near ?g ?c 0.02)", "(near ?g ?c 0.02) (> (z (position ?c)) 5.0)"))
    config = tabletop_copy / "tabletop.toml"
    got = work.static_checks(config, budget=30.0)
    # place can never be applied (W610), so the goal is out of reach (W61x); no cube is 5 m up,
    # so reach and pick's precondition are unsatisfiable (W614)
    codes = [d["code"] for d in got]
    assert codes[0] == "W610" and codes.count("W614") == 2, got
    text = domain.read_text()
    assert got[0]["path"].endswith("domain.pddl")
    assert text[got[0]["start"]:got[0]["end"]] == "place"
    unsat = [d["message"] for d in got if d["code"] == "W614"]
    assert "geometric predicate `reach`" in unsat[0] and "action `pick`" in unsat[1]
    code, out = cli(capsys, "check", "--static", "--format", "json", "--budget", "30", config)
    shown = [d for d in json.loads(out) if d["code"].startswith("W61")]
    # and what a run would stop at: the goal is out of reach (E824, issue S)
    assert code == 1 and "E824" in [d["code"] for d in json.loads(out)]
    assert [(d["code"], d["span"]["start"], d["span"]["end"], d["message"]) for d in shown] == \
        [(d["code"], d["start"], d["end"], d["message"]) for d in got]
    assert work.static_checks(config, budget=30.0) is got       # unchanged files: kept


def test_diagnostic_to_json_gives_offsets_and_related_spans():
    d = Diagnostic("E582", Severity.ERROR, "unknown predicate `x`", Span("d.pddl", 3, 9),
                   "did you mean `y`?", (Related(Span("m.tmpc", 0, 2), "defined here"),))
    assert diagnostic_to_json(d) == {
        "code": "E582", "severity": "error", "message": "unknown predicate `x`",
        "hint": "did you mean `y`?", "path": "d.pddl", "start": 3, "end": 9,
        "related": [{"path": "m.tmpc", "start": 0, "end": 2, "label": "defined here"}]}
    bare = diagnostic_to_json(Diagnostic("W614", Severity.WARNING, "m", None))
    assert (bare["path"], bare["start"], bare["end"], bare["related"]) == (None, None, None, [])


def test_a_check_error_crosses_with_its_spans(tabletop_copy):
    problem = tabletop_copy / "problem.pddl"
    problem.write_text(problem.read_text().replace("(on blue_cube bench)",
                                                   "(on green_cube bench)"))
    reply = call("evaluate", config=str(tabletop_copy / "tabletop.toml"), goal=True)
    assert reply["id"] == 7 and "result" not in reply
    diags = reply["error"]["diagnostics"]
    assert diags and diags[0]["severity"] == "error"
    src = problem.read_text()
    assert any(d["path"] and d["path"].endswith("problem.pddl")
               and src[d["start"]:d["end"]] == "green_cube" for d in diags), diags


# ---- the protocol --------------------------------------------------------------------------
@pytest.mark.parametrize("line, rid, words", [
    ("not json", None, "not a JSON request"),
    ('{"method": "ping"}', None, "a request is"),
    ('[1, 2]', None, "a request is"),
    ('{"id": 3, "method": "fly"}', 3, "unknown method 'fly'"),
    ('{"id": 4, "method": "witness", "params": [1]}', 4, "params must be an object"),
    ('{"id": 5, "method": "witness", "params": {"config": "x", "colour": 1}}', 5, "colour"),
    ('{"id": 6, "method": "ping", "params": {"x": 1}}', 6, "takes no params"),
])
def test_malformed_requests_are_answered_with_errors(line, rid, words):
    reply = respond(line)
    assert reply["id"] == rid and "result" not in reply
    assert words in reply["error"]["message"] and reply["error"]["diagnostics"] == []


def test_an_unexpected_exception_names_its_type(capsys):
    reply = call("evaluate", config=str(TABLETOP), predicate="reach", goal=True)
    assert reply["error"]["message"].startswith("ValueError: give exactly one of")
    assert "Traceback" in capsys.readouterr().err


def test_the_door_answers_ping_without_loading_the_compiler():
    code = ("import sys; from tmpc.runtime.lsp_worker import respond; "
            "r = respond('{\"id\": 1, \"method\": \"ping\"}'); assert r['result']['pid'] > 0; "
            "heavy = [m for m in ('numpy', 'jax', 'z3', 'lupa', 'tmpc.compiler.compile') "
            "if m in sys.modules]; assert not heavy, heavy")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr


def test_prints_go_to_stderr_once_the_protocol_has_stdout():
    code = ("import os; from tmpc.runtime.lsp_worker.protocol import _protocol_stream; "
            "s = _protocol_stream(); print('from python'); os.write(1, b'from C\\n'); "
            "s.write('protocol\\n'); s.flush()")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "protocol\n"
    assert "from python" in r.stderr and "from C" in r.stderr


def test_the_worker_process_answers_survives_and_exits_on_eof():
    requests = [
        {"id": 1, "method": "ping"},
        {"id": 2, "method": "witness",
         "params": {"config": str(TABLETOP), "predicate": "reach", "args": REACH[1:], "seed": 0}},
        "this is not a request",
        {"id": 3, "method": "ping"},
        {"id": 4, "method": "evaluate",
         "params": {"config": str(TABLETOP), "predicate": "levitating", "args": []}},
        {"id": 5, "method": "ping"},
    ]
    lines = "".join((r if isinstance(r, str) else json.dumps(r)) + "\n" for r in requests)
    proc = subprocess.run([sys.executable, "-m", "tmpc.runtime.lsp_worker"], input=lines,
                          capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr
    replies = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [r["id"] for r in replies] == [1, 2, None, 3, 4, 5]
    pid = replies[0]["result"]["pid"]
    assert replies[3]["result"] == {"pid": pid} == replies[5]["result"]
    found = replies[1]["result"]
    assert found["found"] and found["holds"] and found["state"]["joints"]
    assert found == work.witness(TABLETOP, predicate="reach", args=REACH[1:], seed=0)
    assert "error" in replies[2]
    assert [d["code"] for d in replies[4]["error"]["diagnostics"]] == ["E582"]


def test_view_draws_the_witness_state_as_tmpc_view_draws_a_plan(tmp_path, capsys):
    got = work.witness(TABLETOP, predicate="reach", args=REACH[1:], seed=0)
    page = work.view(TABLETOP, state=got["state"], out=str(tmp_path / "w.html"))
    html = (tmp_path / "w.html").read_text()
    assert page == {"path": str(tmp_path / "w.html"), "bytes": len(html.encode())}
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"format": "tmpc-plan/1", "status": "solved", "actions": [],
                                "states": [{**got["state"], "action": None}]}))
    code, _ = cli(capsys, "view", TABLETOP, plan, "--html", tmp_path / "cli.html")
    assert code == 0 and (tmp_path / "cli.html").read_text() == html
    reply = call("view", config=str(TABLETOP), state=[1, 2], out=str(tmp_path / "x.html"))
    assert "must be a state object" in reply["error"]["message"]
    assert not (tmp_path / "x.html").exists()
