"""`tmpc plan`'s engines side by side: SAT, A* with LM-cut and the `auto` portfolio on gripper
(generated here: the IPC-1998 tasks of 4-10 balls) and on IPC tasks read from the directory
``$TMPC_IPC_DIR`` (``DOMAIN/domain.pddl`` and ``DOMAIN/taskNN.pddl``, the layout of pyperplan's
``benchmarks/`` folder; those tasks are skipped when it is not set). Every plan is replayed and
the engines' lengths must agree. ``TMPC_BENCH_LIMIT`` (default 120) is each engine's time limit.

Run with `pytest -m bench -s -n 0 tests/bench/test_bench_astar.py`."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from tests.bench.gen import GRIPPER_DOMAIN, gripper_problem
from tests.support import EXAMPLES
from tmpc.compiler.ground import ground
from tmpc.lang.program import load_checked
from tmpc.runtime.planners import ENGINES, Limits, simulate

pytestmark = pytest.mark.bench

LIMIT = float(os.environ.get("TMPC_BENCH_LIMIT", "120"))
IPC = [("depot", "task03"), ("elevators", "task03"), ("freecell", "task02"),
       ("freecell", "task03")]


def _tasks() -> list[tuple[str, str | None, str]]:
    """(name, IPC folder or None for generated gripper, problem)"""
    out = [(f"gripper-{balls}", None, str(balls)) for balls in (4, 6, 8)]
    root = os.environ.get("TMPC_IPC_DIR")
    for domain, task in IPC:
        out.append((f"{domain} {task}", str(Path(root or "/nonexistent") / domain), task))
    return out


def _run(gp, engine: str):
    t0, c0 = time.perf_counter(), time.process_time()
    r = ENGINES[engine].run(gp, Limits(LIMIT))
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    if r.solved:
        ok, why = simulate(gp, [gp.actions[i] for i in r.actions])
        assert ok, why
    return r, seconds, cpu


ROWS: list[list] = []


@pytest.mark.timeout(4 * LIMIT + 120)
@pytest.mark.parametrize("name,folder,task", _tasks(), ids=[t[0] for t in _tasks()])
def test_sat_against_astar_against_auto(tmp_path, name, folder, task):
    if folder is None:
        domain, problem = tmp_path / "gripper.pddl", tmp_path / "p.pddl"
        domain.write_text(GRIPPER_DOMAIN)
        problem.write_text(gripper_problem(int(task)))
    else:
        domain, problem = Path(folder) / "domain.pddl", Path(folder) / f"{task}.pddl"
        if not problem.is_file():
            pytest.skip("set TMPC_IPC_DIR to a folder of IPC tasks (pyperplan's benchmarks/)")
    gp = ground(load_checked([domain, problem]))
    sat, sat_s, _ = _run(gp, "sat")
    astar, astar_s, astar_cpu = _run(gp, "astar")
    auto, auto_s, _ = _run(gp, "auto")          # (two child processes: no CPU time here)
    lengths = {len(r.actions) for r in (sat, astar, auto) if r.solved}
    assert len(lengths) <= 1, f"{name}: lengths differ {lengths}"
    st = astar.detail
    # on a shared machine wall time varies with the load; the CPU time of the A* process
    # (setup included) does not
    ROWS.append([name, len(gp.actions), lengths.pop() if lengths else "-",
                 _time(sat, sat_s), _time(astar, astar_s), f"{astar_cpu:.2f}",
                 f"{st.expanded:,}", f"{st.expansions_per_s:,.0f}",
                 f"{st.expanded / max(astar_cpu, 1e-9):,.0f}",
                 f"{st.h_seconds / max(st.seconds, 1e-9):.0%}",
                 f"{_time(auto, auto_s)} ({auto.engine})"])
    print()
    print(ROWS[-1])


def test_the_table():
    """Runs after the tasks above (file order): their table in one piece."""
    _table(["task", "actions", "length", "SAT s", "A* s", "A* CPU s", "A* expanded",
            "expansions/s", "per CPU s", "LM-cut share", "auto s (answered)"], ROWS)


def test_astar_as_the_first_candidate_of_clutter(tmp_path):
    """Issue M's question: would A* give the TMP planners their first candidate faster than SAT
    at 14 sticks (discrete view)?"""
    from tmpc.lang.world.generate import clutter_problem
    from tmpc.runtime.planners import AStarPlanner, TaskPlanner
    rows = []
    for n in (6, 10, 14):
        p = tmp_path / f"clutter{n}.pddl"
        p.write_text(clutter_problem(n))
        gp = ground(load_checked([EXAMPLES / "clutter" / "domain.pddl", p]))
        t0 = time.perf_counter()
        sat = TaskPlanner(gp).plan(max_steps=60, time_limit=LIMIT)
        sat_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        astar = AStarPlanner(gp).plan(LIMIT)
        astar_s = time.perf_counter() - t0
        if astar.actions is not None and sat.actions is not None:
            assert len(astar.actions) == len(sat.actions)
        rows.append([f"clutter-{n}", len(gp.actions), sat.horizon, f"{sat_s:.2f}",
                     f"{astar_s:.2f}" if astar.actions is not None else astar.status,
                     f"{astar.stats.expanded:,}"])
    _table(["task", "actions", "length", "SAT first plan s", "A* s", "A* expanded"], rows)


def _time(r, seconds: float) -> str:
    return f"{seconds:.2f}" if r.solved else f"{r.status} ({seconds:.0f})"


def _table(head: list[str], rows: list[list]) -> None:
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    print()
    print("| " + " | ".join(h.ljust(w) for h, w in zip(head, widths)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for row in rows:
        print("| " + " | ".join(str(x).ljust(w) for x, w in zip(row, widths)) + " |")
