"""`tmpc bench` as tasks (docs/bench.md, "Distributed sweeps"): the local process pool's plans
equal the same runs in this process, parameter sweeps, results files (torn lines, resume), the
no-Ray error, and the report's plots. Kept light (the 1-stick clutter, short limits, few
seeds); the Ray cluster's tests are under the `cluster` marker (tests/cluster)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.support import CLUTTER
from tmpc.compiler.artifact import digest
from tmpc.runtime.bench import backends, dispatch, worker
from tmpc.runtime.bench.params import ParamError, param_points, parse_params
from tmpc.runtime.bench.results import ResultsFile, read_results, run_key
from tmpc.runtime.cli.main import main

FIELDS = {"problem", "planner", "seed", "params", "status", "valid", "actions",
          "planning_seconds", "setup_seconds", "cost", "worker"}


class InlineBackend:
    """Runs each task in this process (the coordinator's logic without processes)."""

    name = "inline"
    workers = 1
    ran: list = []

    def __init__(self, workers, address=None, memory_mib=None):
        self.flight = {}

    @staticmethod
    def check_installed():
        pass

    def put(self, path, data):
        return str(path)

    def submit(self, handle, task):
        self.flight[len(self.flight)] = (handle, task)

    def wait(self, timeout):
        out = []
        for handle, task in self.flight.values():
            InlineBackend.ran.append(run_key(task))
            out.append((task, worker.run_task(handle, task)))
        self.flight.clear()
        return out

    def cancel(self):
        self.flight.clear()

    def close(self):
        pass


@pytest.fixture
def inline(monkeypatch):
    monkeypatch.setitem(backends.BACKENDS, "local", InlineBackend)
    monkeypatch.setattr(dispatch, "BACKENDS", backends.BACKENDS)
    InlineBackend.ran = []
    return InlineBackend


def _bench(out, *extra):
    return main(["bench", str(CLUTTER), "--seeds", "2", "--time-limit", "20", "-o", str(out),
                 *extra])


def test_params_cross_product_and_unknown_names():
    grid = parse_params(["heuristic_bias=0.2,0.4"], ["unified"])
    assert grid == {"heuristic_bias": [0.2, 0.4]}
    assert param_points({"a": [1, 2], "b": [True]}) == [{"a": 1, "b": True}, {"a": 2, "b": True}]
    assert param_points({}) == [{}]
    assert parse_params(["rewire=1.5", "first_solution=true"], ["optimal"]) == \
        {"rewire": [1.5], "first_solution": [True]}
    with pytest.raises(ParamError, match="not a parameter of planner unified"):
        parse_params(["rewire=1.5"], ["unified", "optimal"])
    with pytest.raises(ParamError, match="NAME=V1"):
        parse_params(["heuristic_bias"], ["unified"])


def test_unknown_param_is_a_usage_error_before_anything_runs(tmp_path, capsys, inline):
    out = tmp_path / "r.jsonl"
    assert _bench(out, "--param", "nonsense=1") == 2
    assert "not a parameter of planner unified" in capsys.readouterr().err
    assert not out.exists() and inline.ran == []


def test_ray_missing_is_e831_naming_the_extra(tmp_path, capsys, monkeypatch):
    import importlib.util
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "ray" else real(name, *a))
    assert _bench(tmp_path / "r.jsonl", "--backend", "ray") == 1
    err = capsys.readouterr().err
    assert "E831" in err and "tmpc[cluster]" in err and "Traceback" not in err


def test_results_file_ignores_a_torn_line_and_cuts_it_before_appending(tmp_path):
    path = tmp_path / "r.jsonl"
    good = {"problem": "p", "planner": "unified", "seed": 0, "params": {}, "status": "solved"}
    path.write_text(json.dumps(good) + "\n" + '{"problem": "p", "planner": "uni')
    assert read_results(path) == [good]
    f = ResultsFile(path, resume=True)
    assert f.done == {run_key(good)}
    f.append({**good, "seed": 1})
    f.close()
    assert [r["seed"] for r in read_results(path)] == [0, 1]
    assert path.read_text().count("\n") == 2


def test_sweep_resume_and_params_inline(tmp_path, inline, capsys):
    """A parameter sweep writes one line per (seed, point); resuming with more seeds runs only
    the missing cells, and an existing file without --resume is refused."""
    out = tmp_path / "r.jsonl"
    assert _bench(out, "--param", "heuristic_bias=0.3,0.6") == 0
    recs = read_results(out)
    assert sorted((r["seed"], r["params"]["heuristic_bias"]) for r in recs) == \
        [(0, 0.3), (0, 0.6), (1, 0.3), (1, 0.6)]
    for r in recs:
        assert FIELDS <= set(r) and r["status"] == "solved" and r["valid"] is None
        assert r["actions"] and r["planning_seconds"] > 0 and r["cost"] > 0
    table = capsys.readouterr().out
    assert "unified[heuristic_bias=0.3]" in table and "unified[heuristic_bias=0.6]" in table
    assert _bench(out, "--param", "heuristic_bias=0.3,0.6") == 2      # no --resume
    inline.ran = []
    assert main(["bench", str(CLUTTER), "--seeds", "3", "--time-limit", "20", "-o", str(out),
                 "--param", "heuristic_bias=0.3,0.6", "--resume"]) == 0
    assert sorted(k[2] for k in inline.ran) == [2, 2]
    assert len(read_results(out)) == 6


def test_local_pool_plans_equal_this_process(tmp_path, inline):
    """Two runs through a real 1-worker spawn pool give the plans the same runs give here."""
    here = tmp_path / "here.jsonl"
    assert _bench(here) == 0
    inline_recs = {run_key(r): r for r in read_results(here)}
    pool = backends.LocalBackend(1)
    try:
        tasks = []
        for r in inline_recs.values():
            task = {"problem": r["problem"], "input": str(CLUTTER), "planner": r["planner"],
                    "seed": r["seed"], "params": {}, "time_limit": 20.0, "validate": True,
                    "config_params": None}
            tasks.append(task)
        art = _artifact(tmp_path)
        for task in tasks:
            task["digest"] = digest(Path(art).read_bytes())
            pool.submit(pool.put(art, b""), task)
        got = []
        while pool.flight:
            got += pool.wait(1.0)
    finally:
        pool.close()
    assert len(got) == 2
    workers = set()
    for task, rec in got:
        assert rec["actions"] == inline_recs[run_key(task)]["actions"]
        assert rec["valid"] is True
        workers.add(rec["worker"])
    assert len(workers) == 1 and [r["setup_cached"] for _, r in
                                  sorted(got, key=lambda x: x[0]["seed"])] == [False, True]


def _artifact(tmp_path) -> str:
    return str(dispatch.open_compiled(CLUTTER).artifact[0])


def test_report_draws_plots_and_a_page(tmp_path):
    path = tmp_path / "r.jsonl"
    lines = []
    for seed in range(4):
        for planner, size in (("unified", 10), ("unified", 40)):
            lines.append({"problem": f"c{size}", "planner": planner, "seed": seed, "params": {},
                          "status": "solved" if seed < 3 else "partial", "solved": seed < 3,
                          "planning_seconds": 0.5 + seed + size / 10, "ground_actions": size,
                          "time_limit": 10.0, "valid": None, "actions": [], "cost": 3.0})
        lines.append({"problem": "c10", "planner": "optimal", "seed": seed, "params": {},
                      "status": "solved", "solved": True, "planning_seconds": 10.0,
                      "first_solution_seconds": 1.0 + seed, "ground_actions": 10,
                      "time_limit": 10.0, "cost_trace": [[1.0 + seed, 9.0], [5.0, 6.0 - seed]]})
    path.write_text("".join(json.dumps(r) + "\n" for r in lines))
    assert main(["bench", "report", str(path), "-o", str(tmp_path / "rep")]) == 0
    for name in ("success.png", "time_vs_size.png", "cost.png"):
        png = (tmp_path / "rep" / name).read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    page = (tmp_path / "rep" / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 3 and "unified" in page
    # the README's table, from the file alone: c10 before c40, the median over 3 solved and 1
    # unsolved of 1.5, 2.5, 3.5 is 3.0; the anytime cell's time is its first solution's
    table = (tmp_path / "rep" / "table.md").read_text().splitlines()
    rows = [ln for ln in table if ln.startswith("| c")]
    assert [r.split(" | ")[:4] for r in rows] == [
        ["| c10", "optimal", "4/4", "2.50 (1.75–3.25)"], ["| c10", "unified", "3/4",
                                                          "3.00 (2.25–unsolved)"],
        ["| c40", "unified", "3/4", "6.00 (5.25–unsolved)"]]
    assert "<td>2.50 (1.75–3.25)</td>" in page


def test_report_draws_error_over_edits_of_repair_reports(tmp_path):
    """A repair experiment's report.json among the inputs: its error-over-edits panels and its
    row of the repair table, from the file alone, beside the runs of a results file."""
    rep = {"experiment": 2, "truth": "(dist ?c ?g 0.1)", "trials": [
        {"seed": s, "final_formula": "(dist ?c ?g 0.1)", "structurally_correct": s != 2,
         "param_error": None if s == 2 else 0.001 * s, "edits": 3, "unexpected": 10,
         "loop_seconds": [0.5, 1.5], "loop_cpu_seconds": [0.25, 1.0 + s],
         "observations": 90 + s, "status": "stopped",
         "repairs": [{"observation": 4, "error": 0.0, "edits": 2, "trace": [0.3, 0.01, 0.0],
                      "param_error": 0.02},
                     {"observation": 9, "error": 0.0, "edits": 1, "trace": [0.1, 0.0],
                      "param_error": None if s == 2 else 0.001 * s}]} for s in range(3)]}
    (tmp_path / "report.json").write_text(json.dumps(rep, indent=1) + "\n")
    runs = tmp_path / "r.jsonl"
    runs.write_text(json.dumps({"problem": "c1", "planner": "unified", "seed": 0, "params": {},
                                "status": "solved", "solved": True, "planning_seconds": 1.0,
                                "ground_actions": 4, "time_limit": 10.0}) + "\n")
    assert main(["bench", "report", str(tmp_path / "report.json"), str(runs), "-o",
                 str(tmp_path / "out")]) == 0
    png = (tmp_path / "out" / "error_over_edits.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    table = (tmp_path / "out" / "table.md").read_text()
    assert "| c1 | unified | 1/1 | 1.00 (1.00–1.00) |" in table
    assert "| 2 | 3 | 2/3 | 0.0010 / 0.0005 | 10 | 91 | 3 | 1.50 / 1.000 | 3.00 / 0.625 |" in table
    page = (tmp_path / "out" / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 3      # success, size, error over edits


def test_ctrl_c_cancels_and_keeps_the_finished_runs(tmp_path, inline, monkeypatch, capsys):
    """Ctrl-C after the first finished run: the rest is cancelled, the finished run is in the
    file (and the table), exit 130; --resume then runs only the cancelled one."""
    out = tmp_path / "r.jsonl"
    real, cancelled = dispatch.Dispatch.finished, []

    def finished(self, task, rec, progress):
        real(self, task, rec, progress)
        raise KeyboardInterrupt

    monkeypatch.setattr(dispatch.Dispatch, "finished", finished)
    monkeypatch.setattr(InlineBackend, "cancel", lambda self: cancelled.append(len(self.flight)))
    assert _bench(out) == 130
    assert [r["seed"] for r in read_results(out)] == [0] and cancelled
    assert "every finished run is kept" in capsys.readouterr().err
    monkeypatch.setattr(dispatch.Dispatch, "finished", real)
    inline.ran = []
    assert _bench(out, "--resume") == 0
    assert [k[2] for k in inline.ran] == [1]
