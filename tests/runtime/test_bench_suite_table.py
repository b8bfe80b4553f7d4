"""The benchmark suite's table (tmpc bench report over an instance's variations) and the
names `tmpc bench` gives its inputs."""

from tmpc.runtime.bench.report import suite_table
from tmpc.runtime.bench.sweep import problem_names


def _run(problem, solved, seconds=None, actions=4, length=2.0):
    rec = {"problem": problem, "planner": "optimal", "seed": 0, "params": {}, "solved": solved,
           "status": "solved" if solved else "partial", "solve_seconds": seconds or 300.0,
           "n_actions": actions, "path_length": length}
    if solved:
        rec["first_solution_seconds"] = seconds
    return rec


def test_suite_table_aggregates_the_variations_of_each_instance():
    recs = [_run("hanoi-3~v0", True, 10.0, 14, 3.0), _run("hanoi-3~v1", True, 70.0, 18, 5.0),
            _run("hanoi-3~v2", False), _run("blocks-D~v0", True, 400.0, 8, 1.0),
            _run("tabletop", True, 1.0)]          # not a variation: not in the suite's table
    table = suite_table(recs)
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in table.splitlines()[2:]}
    assert set(rows) == {"hanoi-3", "blocks-D"}
    planner, runs, solved, in60, in300, med, mean, mx, acts, length = rows["hanoi-3"]
    assert (runs, solved, in60, in300) == ("3", "67%", "1/3", "2/3")
    assert (med, mean, mx, acts, length) == ("40.0", "40.0", "70.0", "16.0", "4.0")
    assert rows["blocks-D"][3:5] == ["0/1", "0/1"]          # solved, but after 300 s
    assert suite_table([_run("tabletop", True, 1.0)]) == ""


def test_a_run_toml_in_its_own_folder_is_named_by_the_folder():
    names = problem_names(["examples/lagriffoul/blocks-D/run.toml", "x/hanoi-3~v0/run.toml",
                           "examples/clutter/clutter.toml", "other/clutter.toml"])
    assert names == ["blocks-D", "hanoi-3~v0", "clutter", "clutter-2"]
