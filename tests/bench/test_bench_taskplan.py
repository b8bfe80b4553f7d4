"""Task planning benchmarks: per-step encoding and solve time of the SAT planner on blocksworld
(4-12 blocks, generated) and clutter (1-14 sticks, discrete view), the goal-mode and at-most-one
variants, and pyperplan's breadth-first and A*/LM-cut search on the same tasks in the same run
(skipped when pyperplan is not installed; it is not a tmpc dependency). Run with
`pytest -m bench -s tests/bench/test_bench_taskplan.py`."""

from __future__ import annotations

import random
import subprocess
import sys
import time

import pytest

from tests.support import EXAMPLES

pytestmark = pytest.mark.bench

PYPERPLAN_LIMIT = 60.0          # seconds per pyperplan search

BLOCKS = """(define (domain blocks)
  (:requirements :strips :typing)
  (:types block)
  (:predicates (on ?x - block ?y - block) (on-table ?x - block) (clear ?x - block)
               (holding ?x - block) (hand-empty))
  (:action pick-up :parameters (?x - block)
    :precondition (and (clear ?x) (on-table ?x) (hand-empty))
    :effect (and (holding ?x) (not (on-table ?x)) (not (clear ?x)) (not (hand-empty))))
  (:action put-down :parameters (?x - block)
    :precondition (holding ?x)
    :effect (and (on-table ?x) (clear ?x) (hand-empty) (not (holding ?x))))
  (:action stack :parameters (?x - block ?y - block)
    :precondition (and (holding ?x) (clear ?y))
    :effect (and (on ?x ?y) (clear ?x) (hand-empty) (not (holding ?x)) (not (clear ?y))))
  (:action unstack :parameters (?x - block ?y - block)
    :precondition (and (on ?x ?y) (clear ?x) (hand-empty))
    :effect (and (holding ?x) (clear ?y) (not (on ?x ?y)) (not (clear ?x)) (not (hand-empty)))))
"""

#: the clutter domain in its discrete view, for pyperplan (which reads plain STRIPS only)
CLUTTER_STRIPS = """(define (domain clutter)
  (:requirements :strips :typing)
  (:types stick surface manipulator - object)
  (:predicates (on-surface ?x - stick ?s - surface) (arm-empty ?m - manipulator)
               (holding ?m - manipulator ?x - stick))
  (:action pickup :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (and (on-surface ?x ?s) (arm-empty ?m))
    :effect (and (holding ?m ?x) (not (on-surface ?x ?s)) (not (arm-empty ?m))))
  (:action putdown :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (holding ?m ?x)
    :effect (and (arm-empty ?m) (on-surface ?x ?s) (not (holding ?m ?x)))))
"""


def blocks_problem(n: int, seed: int = 1) -> str:
    """Random initial and goal towers of ``n`` blocks (deterministic in ``seed``)."""
    rng = random.Random(seed)
    blocks = [f"b{i}" for i in range(n)]

    def towers() -> list[str]:
        order = blocks[:]
        rng.shuffle(order)
        facts, stacks = [], []
        for b in order:
            if stacks and rng.random() < 0.6:
                s = rng.choice(stacks)
                facts.append(f"(on {b} {s[-1]})")
                s.append(b)
            else:
                stacks.append([b])
                facts.append(f"(on-table {b})")
        return facts + [f"(clear {s[-1]})" for s in stacks]

    init = towers() + ["(hand-empty)"]
    goal = [f for f in towers() if f.startswith("(on ")]
    return (f"(define (problem bw{n}) (:domain blocks) (:objects {' '.join(blocks)} - block)\n"
            f"  (:init {' '.join(init)})\n  (:goal (and {' '.join(goal)})))\n")


def _tasks(tmp_path):
    from tmpc.lang.world.generate import clutter_problem
    out = []
    (tmp_path / "blocks.pddl").write_text(BLOCKS)
    (tmp_path / "clutter.pddl").write_text(CLUTTER_STRIPS)
    for n in (4, 6, 8, 10, 12):
        p = tmp_path / f"bw{n}.pddl"
        p.write_text(blocks_problem(n))
        out.append((f"blocks-{n}", tmp_path / "blocks.pddl", p, tmp_path / "blocks.pddl"))
    for n in (1, 2, 4, 6, 8, 10, 12, 14):
        p = tmp_path / f"clutter{n}.pddl"
        p.write_text(clutter_problem(n))
        out.append((f"clutter-{n}", EXAMPLES / "clutter" / "domain.pddl", p,
                    tmp_path / "clutter.pddl"))
    return out


def _plan(domain, problem, **options):
    from tmpc.compiler.ground import ground
    from tmpc.lang.program import load_checked
    from tmpc.runtime.planners import TaskPlanner, simulate
    t0 = time.perf_counter()
    gp = ground(load_checked([domain, problem]))
    t1 = time.perf_counter()
    planner = TaskPlanner(gp, **options)
    t2 = time.perf_counter()
    result = planner.plan(max_steps=80, time_limit=120)
    t3 = time.perf_counter()
    if result.solved:
        assert simulate(gp, result.actions)[0]
    return dict(result=result, planner=planner, ground=t1 - t0, setup=t2 - t1, search=t3 - t2,
                total=t3 - t0)


def _pyperplan(domain, problem, search: str, heuristic: str | None) -> tuple[str, float]:
    """(plan length or "timeout"/"error", seconds) of a pyperplan search in a subprocess."""
    code = ("import sys, time, logging; logging.disable(logging.CRITICAL)\n"
            "from pyperplan.planner import search_plan, SEARCHES, HEURISTICS\n"
            "t = time.perf_counter()\n"
            f"h = HEURISTICS[{heuristic!r}] if {heuristic!r} else None\n"
            f"plan = search_plan({str(domain)!r}, {str(problem)!r}, SEARCHES[{search!r}], h)\n"
            "print(len(plan) if plan is not None else 'none', time.perf_counter() - t)\n")
    t0 = time.perf_counter()
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=PYPERPLAN_LIMIT)
    except subprocess.TimeoutExpired:
        return "timeout", time.perf_counter() - t0
    if r.returncode != 0:
        return "error", time.perf_counter() - t0
    length, seconds = r.stdout.split()
    return length, float(seconds)


def test_sat_planner_against_pyperplan(tmp_path):
    try:
        import pyperplan  # noqa: F401
        have_pyperplan = True
    except ImportError:
        have_pyperplan = False
    rows = []
    for name, domain, problem, strips in _tasks(tmp_path):
        run = _plan(domain, problem)
        r, planner = run["result"], run["planner"]
        steps = [s for s in r.stats]
        per_step = sum(s.encode_s for s in steps) / max(1, r.horizon) * 1e3
        row = [name, len(planner.problem.actions), r.horizon if r.solved else r.status,
               planner.lower_bound, f"{planner.encoding.sizes['step'][0]:,}",
               f"{per_step:.1f}", f"{sum(s.solve_s for s in steps):.2f}",
               f"{run['setup']:.2f}", f"{run['total']:.2f}"]
        if have_pyperplan:
            for search, h in (("bfs", None), ("astar", "lmcut")):
                length, secs = _pyperplan(strips, problem, search, h)
                if length.isdigit():
                    assert int(length) == r.horizon, f"{name}: pyperplan {search} {length}"
                row.append(f"{secs:.2f}" if length.isdigit() else length)
        rows.append(row)
    head = ["task", "actions", "length", "bound", "clauses/step", "encode ms/step", "solve s",
            "setup s", "tmpc total s"] + (["pyperplan BFS s", "pyperplan A*/LM-cut s"]
                                          if have_pyperplan else [])
    _table(head, rows)


def test_goal_modes_and_at_most_one(tmp_path):
    rows = []
    tasks = {t[0]: t for t in _tasks(tmp_path)}
    for name in ("blocks-10", "blocks-12", "clutter-10", "clutter-14"):
        _, domain, problem, _ = tasks[name]
        row = [name]
        for options in (dict(), dict(goal_mode="assumptions"), dict(amo="ladder"),
                        dict(mutexes=False), dict(lower_bound=False, mutexes=False)):
            run = _plan(domain, problem, **options)
            r = run["result"]
            row.append(f"{run['search']:.2f}" if r.solved else f"{r.status}@{r.horizon}")
        rows.append(row)
    _table(["task", "scope+pb (default)", "assumptions", "ladder AMO", "no mutexes",
            "no landmarks, no mutexes"], rows)


def test_clutter_14_first_plan_under_a_second(tmp_path):
    from tmpc.compiler.ground import ground
    from tmpc.lang.program import load_checked
    from tmpc.lang.world.generate import clutter_problem
    from tmpc.runtime.planners import TaskPlanner
    p = tmp_path / "clutter14.pddl"
    p.write_text(clutter_problem(14))
    gp = ground(load_checked([EXAMPLES / "clutter" / "domain.pddl", p]))
    times = []
    for geometric in (False, True, False, True, False):
        t0 = time.perf_counter()
        r = TaskPlanner(gp, geometric=geometric).plan(max_steps=40)
        times.append(time.perf_counter() - t0)
        assert r.horizon == 28
    print(f"\nclutter 14 sticks, first plan (setup + search), 5 runs alternating discrete and "
          f"geometric view: {', '.join(f'{t:.2f}' for t in times)} s; median "
          f"{sorted(times)[2]:.2f} s")


def _table(head: list[str], rows: list[list]) -> None:
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    print()
    for r in [head, ["-" * w for w in widths], *rows]:
        print("  ".join(str(x).rjust(w) for x, w in zip(r, widths)))
