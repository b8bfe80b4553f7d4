"""`tmpc bench`: the JSON of every run, the table, OMPL's benchmark log (read by an independent
reader following OMPL's documented grammar, and by OMPL's own ompl_benchmark_statistics when the
installed `ompl` ships it), Ctrl-C keeping what was collected, and bad input."""

from __future__ import annotations

import json
import math
import sqlite3
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from tests.support import CLUTTER
from tmpc.lang.diagnostics import TmpcError

SEEDS = 2
TYPES = {"REAL", "INTEGER", "BOOLEAN", "ENUM"}


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """One real sweep through the CLI: clutter, 2 seeds, validated."""
    from tmpc.runtime.cli.main import main
    d = tmp_path_factory.mktemp("bench")
    out, log = d / "results.json", d / "results.log"
    code = main(["bench", str(CLUTTER), "--seeds", str(SEEDS), "--time-limit", "30",
                 "-o", str(out), "--ompl-log", str(log), "--validate"])
    return SimpleNamespace(code=code, doc=json.loads(out.read_text()), log=log, dir=d)


def test_json_records_every_run(swept):
    assert swept.code == 0
    doc = swept.doc
    assert doc["format"] == "tmpc-bench/1" and doc["status"] == "complete"
    assert doc["settings"] == {"planners": ["unified"], "seeds": SEEDS, "time_limit": 30.0,
                               "validate": True}
    assert doc["command"] == ["tmpc", "bench", str(CLUTTER), "--planners", "unified", "--seeds",
                              str(SEEDS), "--time-limit", "30", "--validate"]
    assert len(doc["load"]["start"]) == 3 and doc["host"]["cpus"] >= 1
    (prob,) = doc["problems"]
    assert prob["name"] == "clutter" and prob["error"] is None
    assert prob["setup_seconds"] >= prob["compile_seconds"] > 0
    assert prob["dof"] > 0 and prob["ground_actions"] > 0
    runs = doc["runs"]
    assert [(r["planner"], r["seed"]) for r in runs] == [("unified", s) for s in range(SEEDS)]
    for r in runs:
        assert r["status"] == "solved" and r["solved"] and r["valid"] is True
        assert r["violations"] == [] == r["warnings"] and r["validate_seconds"] > 0
        assert r["n_actions"] == len(r["actions"]) == 2 and r["states"] >= 3
        assert r["path_length"] > 0 and r["nodes"] >= r["states"]
        assert r["modes"] >= 3 and r["transitions"] >= 2
        assert set(r["time"]) == {"sampling", "projection", "collision", "heuristic",
                                  "compile", "other"}
        assert all(v >= 0 for v in r["time"].values())
        # "other" is what the timers do not cover, so the split adds up to the solve time at
        # least (more when timed activities overlap the wall clock's rounding)
        assert sum(r["time"].values()) >= r["solve_seconds"] - 1e-3
        assert r["solve_seconds"] >= r["search_seconds"]
        assert r["peak_rss_mib"] > 0 and r["rss_before_mib"] > 0 and r["rss_after_mib"] > 0
        assert len(r["load_before"]) == len(r["load_after"]) == 3


def test_summary_counts_match_the_runs(swept):
    doc = swept.doc
    (row,) = doc["summary"]
    solved = sum(r["solved"] for r in doc["runs"])
    assert (row["runs"], row["solved"], row["success_rate"]) == (SEEDS, solved, solved / SEEDS)
    assert row["invalid"] == 0 and row["validated"] == SEEDS and row["crashed"] == 0
    times = sorted(r["solve_seconds"] for r in doc["runs"])
    assert row["median_seconds"] == pytest.approx(sum(times) / 2, abs=1e-3)
    assert row["q1_seconds"] <= row["median_seconds"] <= row["q3_seconds"]
    assert row["median_actions"] == 2
    assert sum(row["time_shares"].values()) == pytest.approx(1.0, abs=0.05)


def read_ompl_log(path: Path) -> dict:
    """An independent reader of OMPL's benchmark log, from the EBNF in OMPL's documentation
    (doc/markdown/benchmark.md, "The benchmark logfile format"); strict where it says so."""
    lines = path.read_text().split("\n")
    assert lines[-1] == "", "the log ends with a newline"
    it = iter(lines[:-1])
    nxt = lambda: next(it)                                            # noqa: E731
    out: dict = {}

    def suffixed(line, suffix, conv=float):
        assert line.endswith(suffix), (line, suffix)
        return conv(line[: -len(suffix)])

    def multiline():
        assert nxt() == "<<<|"
        body = []
        while (ln := nxt()) != "|>>>":
            body.append(ln)
        return body

    line = nxt()
    if " version " in line:                                           # [version]
        out["library"], out["version"] = line.split(" version ")
        line = nxt()
    assert line.startswith("Experiment ")
    out["experiment"] = line[len("Experiment "):]
    line = nxt()
    out["experiment_properties"] = {}
    if line.endswith(" experiment properties"):
        for _ in range(suffixed(line, " experiment properties", int)):
            name_type, value = nxt().split(" = ")
            name, typ = name_type.rsplit(" ", 1)
            assert typ in TYPES
            out["experiment_properties"][name] = float(value)
        line = nxt()
    assert line.startswith("Running on ")
    assert nxt().startswith("Starting at ")
    out["setup"] = multiline()
    out["cpuinfo"] = multiline()                                      # optional; we write it
    out["seed"] = suffixed(nxt(), " is the random seed", int)
    out["time_limit"] = suffixed(nxt(), " seconds per run")
    out["memory_limit"] = suffixed(nxt(), " MB per run")
    out["runs_per_planner"] = suffixed(nxt(), " runs per planner", int)
    out["total_time"] = suffixed(nxt(), " seconds spent to collect the data")
    out["enums"] = {}
    for _ in range(suffixed(nxt(), " enum type", int)):
        name, *values = nxt().split("|")
        out["enums"][name] = values
    out["planners"] = {}
    for _ in range(suffixed(nxt(), " planners", int)):
        name = nxt()
        common = dict(nxt().split(" = ") for _ in range(suffixed(nxt(), " common properties",
                                                                   int)))
        props = []
        for _ in range(suffixed(nxt(), " properties for each run", int)):
            pname, ptype = nxt().rsplit(" ", 1)
            assert ptype in TYPES, ptype
            props.append((pname, ptype))
        runs = []
        for _ in range(suffixed(nxt(), " runs", int)):
            line = nxt()
            assert line.endswith("; ")
            fields = line[:-2].split("; ")
            assert len(fields) == len(props), (len(fields), len(props))
            run = {}
            for (pname, ptype), v in zip(props, fields):
                if v in ("", "nan", "inf"):
                    run[pname] = None
                elif ptype == "BOOLEAN":
                    assert v in ("0", "1")
                    run[pname] = v == "1"
                elif ptype in ("INTEGER", "ENUM"):
                    run[pname] = int(v)
                else:
                    run[pname] = float(v)
            runs.append(run)
        assert nxt() == "."                        # no progress properties
        out["planners"][name] = {"common": common, "properties": props, "runs": runs}
    assert next(it, None) is None
    return out


def test_ompl_log_follows_the_grammar(swept):
    log = read_ompl_log(swept.log)
    assert log["library"] == "tmpc" and log["experiment"] == "clutter"
    assert log["time_limit"] == 30 and log["runs_per_planner"] == SEEDS
    assert log["experiment_properties"]["dof"] == swept.doc["problems"][0]["dof"]
    status = log["enums"]["status"]
    (planner,) = log["planners"]
    assert planner == "unified"
    p = log["planners"]["unified"]
    assert float(p["common"]["heuristic_bias"]) == 0.4
    names = [n for n, _ in p["properties"]]
    assert names == sorted(names)
    for need in ("time", "memory", "status", "solved", "correct solution", "solution length",
                 "graph states", "seed", "collision time", "projection time", "peak rss"):
        assert need in names
    assert len(p["runs"]) == SEEDS
    for run, rec in zip(p["runs"], swept.doc["runs"]):
        assert run["seed"] == rec["seed"]
        assert run["solved"] is True and run["correct solution"] is True
        assert status[run["status"]] == "Exact solution"
        assert run["time"] + run["simplification time"] == pytest.approx(rec["solve_seconds"],
                                                                           abs=1e-3)
        assert run["solution length"] == pytest.approx(rec["path_length"])
        assert run["graph states"] == rec["nodes"]


def test_ompl_log_reads_into_planner_arena_database(swept, tmp_path):
    """OMPL's own ompl_benchmark_statistics.py (shipped by the `ompl` wheel) builds its SQLite
    database from our log."""
    pytest.importorskip("ompl.tools")
    db = tmp_path / "bench.db"
    proc = subprocess.run([sys.executable, "-m", "ompl.ompl_benchmark_statistics",
                           str(swept.log), "-d", str(db)], capture_output=True, text=True,
                          cwd=tmp_path, timeout=60)
    if proc.returncode and "No module named" in proc.stderr:
        pytest.skip("this ompl has no ompl_benchmark_statistics module")
    assert proc.returncode == 0, proc.stderr
    con = sqlite3.connect(db)
    (exp,) = con.execute("SELECT name, timelimit, runcount, version FROM experiments")
    assert exp == ("clutter", 30.0, SEEDS, "tmpc " + exp[3].split()[-1])
    assert [r[0] for r in con.execute("SELECT name FROM plannerConfigs")] == ["unified"]
    rows = con.execute("SELECT seed, solved, correct_solution, status, time, "
                       "simplification_time, graph_states FROM runs ORDER BY seed").fetchall()
    assert [r[0] for r in rows] == list(range(SEEDS))
    assert all(r[1] == 1 and r[2] == 1 and r[3] == 6 for r in rows)
    (desc,) = con.execute("SELECT description FROM enums WHERE name='status' AND value=6")
    assert desc == ("Exact solution",)
    # the view Planner Arena ranks planners by (script computes it from our columns)
    (best,) = con.execute("SELECT avg_solved FROM bestPlannerConfigs")
    assert best == (1.0,)


def test_table_has_one_row_per_problem_and_planner(swept, capsys):
    from tmpc.runtime.bench.sweep import markdown_table
    table = markdown_table(swept.doc["summary"], 30.0)
    lines = table.splitlines()
    assert len(lines) == 3 and lines[2].startswith("| clutter | unified | 2/2 |")
    assert "0/2" in lines[2]                      # invalid / validated


# ---- library-level: share one compiled problem (clutter_problem_1, tests/conftest.py) ----------


def _args(tmp_path, **kw):
    base = dict(inputs=[str(CLUTTER)], planners="unified", seeds=3, time_limit=30.0,
                output=str(tmp_path / "r.json"), ompl_log=str(tmp_path / "r.log"),
                validate=False, debug=False)
    base.update(kw)
    return SimpleNamespace(**base)


def test_ctrl_c_stops_the_sweep_and_keeps_the_runs(clutter_problem_1, tmp_path, monkeypatch):
    """A planner that returns `interrupted` (Ctrl-C inside its loop) ends the sweep; the runs so
    far are written, status `interrupted`."""
    from tmpc.runtime.bench import sweep as bc
    from tmpc.runtime.cli.bench import exit_code
    real = bc.make_planner

    def fake(name, problem, seed, args):
        algo = real(name, problem, seed, args)
        if seed == 1:
            solve = algo.solve
            algo.solve = lambda limit, progress=None: _interrupted(solve(limit))
        return algo

    monkeypatch.setattr(bc, "make_planner", fake)
    args = _args(tmp_path)
    bench = bc.Bench(args, ["unified"], ["clutter"])
    with pytest.raises(bc.Stop):
        bench.problem(CLUTTER, "clutter", problem=clutter_problem_1)
    bench.interrupted = True
    bench.finish()
    doc = json.loads(Path(args.output).read_text())
    assert doc["status"] == "interrupted"
    assert [(r["seed"], r["status"]) for r in doc["runs"]] == [(0, "solved"), (1, "interrupted")]
    assert exit_code(bench) == 130
    (row,) = doc["summary"]                      # the interrupted run is not a failure
    assert (row["runs"], row["solved"]) == (1, 1)
    log = read_ompl_log(Path(args.ompl_log))
    runs = log["planners"]["unified"]["runs"]
    assert len(runs) == 2 and log["enums"]["status"][runs[1]["status"]] == "Abort"
    assert runs[1]["solved"] is False and runs[1]["solution length"] is None


def _interrupted(result):
    result.status = "interrupted"
    return result


def test_keyboard_interrupt_outside_the_planner(clutter_problem_1, tmp_path, monkeypatch):
    """Ctrl-C outside the planner's loop (e.g. setting up the next run) also keeps the runs."""
    from tmpc.runtime.bench import sweep as bc
    from tmpc.runtime.cli.bench import run_bench
    real, calls = bc.make_planner, []

    def fake(name, problem, seed, args):
        calls.append(seed)
        if seed == 2:
            raise KeyboardInterrupt
        return real(name, problem, seed, args)

    monkeypatch.setattr(bc, "make_planner", fake)
    monkeypatch.setattr(bc, "build_problem", lambda path, rec: clutter_problem_1)
    code = run_bench(_args(tmp_path))
    assert code == 130 and calls == [0, 1, 2]
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["status"] == "interrupted" and len(doc["runs"]) == 2
    assert len(read_ompl_log(tmp_path / "r.log")["planners"]["unified"]["runs"]) == 2


def test_a_crash_is_recorded_with_its_reproducer(clutter_problem_1, tmp_path, monkeypatch, capsys):
    from tmpc.runtime.bench import sweep as bc
    from tmpc.runtime.cli.bench import run_bench
    class Boom:
        def solve(self, limit, progress=None):
            raise RuntimeError("boom")

    monkeypatch.setattr(bc, "make_planner", lambda *a: Boom())
    monkeypatch.setattr(bc, "build_problem", lambda path, rec: clutter_problem_1)
    code = run_bench(_args(tmp_path, seeds=1))
    assert code == 70
    (run,) = json.loads((tmp_path / "r.json").read_text())["runs"]
    assert run["status"] == "crash" and "boom" in run["error"]
    assert "--seed 0" in run["reproducer"]
    assert "BUG" in capsys.readouterr().err
    log = read_ompl_log(tmp_path / "r.log")
    (r,) = log["planners"]["unified"]["runs"]
    assert log["enums"]["status"][r["status"]] == "Crash"


def test_a_valid_plan_with_a_warning_is_kept_to_check_again(clutter_problem_1, tmp_path,
                                                            monkeypatch):
    """A W830 leaves the plan valid, so the sweep succeeds, but the plan is kept beside the
    results (`warned-...`) so that the warning can be checked again later; a plan without
    one is not kept."""
    from tmpc.runtime.bench import sweep as bc
    from tmpc.runtime.cli.bench import run_bench
    from tmpc.runtime.validate import validate_plan
    monkeypatch.setattr(bc, "build_problem", lambda path, rec: clutter_problem_1)
    warned = SimpleNamespace(text=lambda: "release at 2: `b1` over no support")

    def with_warning(world, path):
        report = validate_plan(world, path)
        assert report.valid and not report.warnings
        return SimpleNamespace(valid=True, violations=[], warnings=[warned])

    monkeypatch.setattr(bc, "validate_plan", with_warning)
    assert run_bench(_args(tmp_path, seeds=1, validate=True)) == 0
    (run,) = json.loads((tmp_path / "r.json").read_text())["runs"]
    assert run["valid"] is True and run["warnings"] == ["W830: " + warned.text()]
    kept = tmp_path / "warned-clutter-unified-0.plan.json"
    assert run["plan_file"] == str(kept)
    assert json.loads(kept.read_text())["actions"] == run["actions"]
    monkeypatch.setattr(bc, "validate_plan", validate_plan)
    assert run_bench(_args(tmp_path, seeds=1, validate=True, output=str(tmp_path / "q.json"))) == 0
    (run,) = json.loads((tmp_path / "q.json").read_text())["runs"]
    assert run["warnings"] == [] and "plan_file" not in run
    assert [p.name for p in tmp_path.glob("*.plan.json")] == [kept.name]


def test_several_problems_one_log_each(clutter_problem_1, tmp_path, monkeypatch):
    from tmpc.runtime.bench import sweep as bc
    from tmpc.runtime.cli.bench import run_bench
    monkeypatch.setattr(bc, "build_problem", lambda path, rec: clutter_problem_1)
    code = run_bench(_args(tmp_path, inputs=[str(CLUTTER), str(CLUTTER)], seeds=1))
    assert code == 0
    doc = json.loads((tmp_path / "r.json").read_text())
    assert [p["name"] for p in doc["problems"]] == ["clutter", "clutter-2"]
    for name in ("clutter", "clutter-2"):
        assert read_ompl_log(tmp_path / f"r-{name}.log")["experiment"] == name
    assert not (tmp_path / "r.log").exists()


def test_both_planners_and_the_optimal_ones_cost_over_time(clutter_problem_1, tmp_path,
                                                            monkeypatch, capsys):
    from tmpc.runtime.bench import sweep as bc
    from tmpc.runtime.cli.bench import run_bench
    monkeypatch.setattr(bc, "build_problem", lambda path, rec: clutter_problem_1)
    code = run_bench(_args(tmp_path, planners="unified,optimal", seeds=1, time_limit=6.0,
                           validate=True))
    assert code == 0
    doc = json.loads((tmp_path / "r.json").read_text())
    runs = {r["planner"]: r for r in doc["runs"]}
    assert runs["unified"]["solved"] and runs["optimal"]["solved"]
    assert runs["optimal"]["valid"] is True
    opt = runs["optimal"]
    assert list(opt["cost_at"]) == ["1", "5"]           # the fixed times within the limit
    trace = opt["cost_trace"]
    assert opt["cost_at"]["5"] == min(c for t, c in trace if t <= 5)
    assert opt["first_solution_seconds"] == trace[0][0] <= opt["solve_seconds"]
    row = next(r for r in doc["summary"] if r["planner"] == "optimal")
    assert row["median_seconds"] == pytest.approx(opt["first_solution_seconds"], abs=1e-3)
    assert "median cost at 5 s" in capsys.readouterr().out


# ---- bad input ---------------------------------------------------------------------------------
def test_bad_input_fails_before_planning(tmp_path):
    from tmpc.runtime.cli.bench import run_bench
    with pytest.raises(TmpcError) as exc:
        run_bench(_args(tmp_path, inputs=[str(CLUTTER), str(tmp_path / "missing.toml")]))
    assert exc.value.diagnostics[0].code == "E010"
    assert not (tmp_path / "r.json").exists()


def test_unknown_planner_and_unwritable_output(tmp_path):
    from tmpc.runtime.cli.bench import run_bench
    with pytest.raises(TmpcError) as exc:
        run_bench(_args(tmp_path, planners="unified,nope"))
    assert exc.value.diagnostics[0].code == "E826"
    with pytest.raises(TmpcError) as exc:
        run_bench(_args(tmp_path, output=str(tmp_path / "no" / "such" / "r.json")))
    assert exc.value.diagnostics[0].code == "E830"
    assert run_bench(_args(tmp_path, seeds=0)) == 2
    assert run_bench(_args(tmp_path, time_limit=0.0)) == 2


def test_unreachable_goal_is_reported_and_skipped(tmp_path, capsys):
    """A problem failing `tmpc run`'s pre-checks mid-sweep: diagnostics, recorded, exit 1."""
    from tmpc.lang.world.generate import clutter_scene
    from tmpc.runtime.cli.bench import run_bench
    (tmp_path / "scene.json").write_text(json.dumps(clutter_scene(1, False)))
    # no manipulator: nothing can ever pick the stick up
    prob = """(define (problem no-hands) (:domain clutter)
  (:objects table1 table2 table3 table4 - surface blue_stick_1 - stick)
  (:init (on-surface blue_stick_1 table1))
  (:goal (on-surface blue_stick_1 table3)))"""
    (tmp_path / "problem.pddl").write_text(prob)
    (tmp_path / "domain.pddl").write_text((CLUTTER.parent / "domain.pddl").read_text())
    cfg = tmp_path / "bad.toml"
    cfg.write_text('[problem]\ndomain = "domain.pddl"\nproblem = "problem.pddl"\n'
                   'scene = "scene.json"\n')
    code = run_bench(_args(tmp_path, inputs=[str(cfg)], seeds=1))
    assert code == 1
    assert "E824" in capsys.readouterr().err
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["runs"] == [] and "E824" in doc["problems"][0]["error"]


def test_quantile_counts_unsolved_runs_as_infinite():
    from tmpc.runtime.bench.sweep import quantile
    assert quantile([1.0, 2.0, 3.0], 0.5) == 2.0
    assert quantile([1.0, 3.0], 0.5) == 2.0
    assert quantile([1.0, math.inf, math.inf], 0.5) == math.inf
    assert quantile([1.0, 2.0, math.inf], 0.5) == 2.0
    assert math.isnan(quantile([], 0.5))
