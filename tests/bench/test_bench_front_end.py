"""Front-end benchmark: `tmpc check` process time and parse throughput vs lark alone.

Run with `pytest -m bench -s tests/bench`. Reports numbers; asserts only behaviour (the check
passes), never wall-clock.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time

import pytest

from tests.bench.gen import big_domain, big_problem
from tmpc.lang.reader import parse_source
from tmpc.lang.sexpr import sexpr_parser
from tmpc.lang.source import SourceFile

pytestmark = pytest.mark.bench


def _median_wall(cmd: list[str], runs: int = 7) -> float:
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        times.append(time.perf_counter() - t)
        assert r.returncode == 0, r.stderr
    return statistics.median(times)


def _throughput(fn, text: str, repeat: int = 5) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn(text)
        best = min(best, time.perf_counter() - t)
    return text.count("\n") / best


def test_check_process_time_and_parse_throughput(tmp_path):
    dom, prob = tmp_path / "domain.pddl", tmp_path / "problem.pddl"
    dom.write_text(big_domain())
    prob.write_text(big_problem())
    lines = dom.read_text().count("\n") + prob.read_text().count("\n")
    assert lines >= 2000
    python = _median_wall([sys.executable, "-c", "pass"])
    check = _median_wall([sys.executable, "-m", "tmpc.runtime.cli", "check", str(dom), str(prob)])
    text = dom.read_text()
    lark_only = _throughput(lambda t: sexpr_parser().parse(t), text)
    ours = _throughput(lambda t: parse_source(SourceFile("d.pddl", t)), text)
    print(f"\n| measure | value |\n|---|---|\n"
          f"| input | {lines} lines (domain + problem) |\n"
          f"| `tmpc check` process wall time (median of 7) | {check:.3f} s |\n"
          f"| of which bare interpreter start | {python:.3f} s |\n"
          f"| lark LALR parse alone | {lark_only:,.0f} lines/s |\n"
          f"| tmpc parse (fast s-expression path + AST + diagnostics) | {ours:,.0f} lines/s |\n"
          f"| ratio tmpc / lark-only | {ours / lark_only:.2f} |")
