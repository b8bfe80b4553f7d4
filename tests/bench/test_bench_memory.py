"""Memory benchmark (issue L): `tmpc check` and `tmpc fmt` of a generated ~5 MB and ~50 MB
problem, each in its own process; peak RSS above the interpreter's own (a `check` of a tiny
problem) divided by the input size, and seconds.

Run with `pytest -m bench -s -n 0 tests/bench/test_bench_memory.py` (about 2 minutes, 1 GB).
Asserts the ratio (at most 20x the input), never wall-clock.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from tests.bench.gen import large_problem, logistics_domain

pytestmark = pytest.mark.bench

SIZES_MB = tuple(int(s) for s in os.environ.get("TMPC_BENCH_MEMORY_MB", "5,50").split(","))
MAX_RATIO = 20


#: `tmpc ARGV...` that reports its peak resident memory (VmHWM: of this process since its exec;
#: the rusage of a child would count the forking pytest's own pages as well)
_CHILD = """import sys
from tmpc.runtime.cli.main import main
code = main(sys.argv[2:])
with open("/proc/self/status") as f:
    hwm = next(line for line in f if line.startswith("VmHWM:")).split()[1]
with open(sys.argv[1], "w") as f:
    f.write(hwm)
sys.exit(code)
"""


def _run(args: list[str], report) -> tuple[float, float]:
    """(peak RSS in MB, seconds) of ``tmpc ARGS`` in a fresh process."""
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", _CHILD, str(report), *args], capture_output=True,
                       text=True)
    seconds = time.perf_counter() - t
    assert r.returncode == 0, r.stderr
    return int(report.read_text()) / 1024, seconds          # VmHWM is in kB


def test_check_and_fmt_memory_is_linear(tmp_path):
    domain = tmp_path / "domain.pddl"
    domain.write_text(logistics_domain())
    tiny = tmp_path / "tiny.pddl"
    tiny.write_text(large_problem(2_000))
    report = tmp_path / "hwm"
    base, _ = _run(["check", str(domain), str(tiny)], report)
    rows, ratios = [], []
    for mb in SIZES_MB:
        problem = tmp_path / f"problem{mb}.pddl"
        problem.write_text(large_problem(mb * 1_000_000))
        size = problem.stat().st_size / 1e6
        for what, args in (("check", ["check", str(domain), str(problem)]),
                           ("fmt", ["fmt", str(problem)])):
            rss, seconds = _run(args, report)
            ratio = (rss - base) / size
            ratios.append((what, mb, ratio))
            rows.append(f"| `tmpc {what}` | {size:.1f} | {rss:.0f} | {ratio:.1f}x | {seconds:.1f} |")
        problem.unlink()
    print(f"\n(interpreter and tmpc alone: {base:.0f} MB)\n"
          "| command | input MB | peak RSS MB | (RSS - alone) / input | seconds |\n"
          "|---|---|---|---|---|\n" + "\n".join(rows))
    for what, mb, ratio in ratios:
        assert ratio <= MAX_RATIO, f"tmpc {what} of {mb} MB: {ratio:.1f}x the input"
