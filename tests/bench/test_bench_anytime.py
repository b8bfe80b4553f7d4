"""Anytime cost of `tmpc run --planner optimal` against tmit-star's own anytime mode (`-o`), in one
session, on tmit-star's clutter and shelves problems (issue H).

For each problem and trial: tmit-star once with ``-o`` (it keeps optimising until
``max_duration``; its trials file lists every solution's cost and time), then tmpc with the same
limit. Both costs are tmit-star's composite path length (tmpc's plans report it in
``stats.cost_trace``; tmit-star's own ``cost``). Reported: median first-solution time and the
median best cost at 1, 5, 10 and 30 s of planning. Needs the shared baseline
(``../shared/baselines/tmit-star``, restored tmit-star); skipped without it.

    TMIT_TRIALS=2 TMIT_LIMIT=30 pytest -m bench -s -n 0 --timeout 3000 tests/bench/test_bench_anytime.py

(all seven problems take ~15 min at these settings: past pytest-timeout's default 600 s)
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.bench

ROOT = Path(__file__).resolve().parents[2]
BASE = ROOT.parent / "shared" / "baselines" / "tmit-star"
TMIT = Path(os.environ.get("TMIT_STAR", Path.home() / ".cache" / "tmit-star" / "bin" / "tmit-star"))
PROBLEMS = ["clutter:1", "clutter:2", "clutter:3", "clutter:4", "shelves:2", "shelves:3",
            "shelves:4"]
TIMES = (1, 5, 10, 30)


def _best_at(trace, t: float):
    got = [c for s, c in trace if s <= t]
    return min(got) if got else math.inf


def _tmit(work: Path, spec: str, limit: float) -> list[tuple[float, float]]:
    """tmit-star -o in a scratch cwd: [(seconds, cost)] of its solutions."""
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    for d in ("problems", "lua", "models"):
        (work / d).symlink_to(BASE / "data" / d)
    (work / "SPEC.json").write_text(json.dumps({"num_trials": 1, "batch_size": 50,
                                                "batch_budget": 5, "max_duration": limit}))
    subprocess.run([str(TMIT), spec, "-e", "SPEC.json", "-o"], cwd=work, capture_output=True,
                   timeout=limit + 120)
    trials = next(work.glob("*_trials_*.json"), None)
    if trials is None:
        return []
    runs = json.loads(trials.read_text())["trial_data"]
    return [(s["time_ms"] / 1000.0, s["cost"]) for s in runs[0]] if runs and runs[0] else []


def _tmpc(work: Path, spec: str, seed: int, limit: float) -> tuple[list, bool]:
    """tmpc's [(seconds, cost)] of its solutions, and whether its last plan validates."""
    out = work / f"plan-{seed}.json"
    env = dict(os.environ, TMPC_MESH_PATH=str(BASE / "data" / "models"))
    cli = [sys.executable, "-m", "tmpc.runtime.cli"]
    subprocess.run(cli + ["run", str(BASE / "data" / spec), "--planner", "optimal", "--seed",
                          str(seed), "--time-limit", str(limit), "-q", "-o", str(out)],
                   env=env, capture_output=True, timeout=3 * limit + 120)
    if not out.exists():
        return [], False
    valid = subprocess.run(cli + ["validate", str(BASE / "data" / spec), str(out)], env=env,
                           capture_output=True, timeout=600).returncode == 0
    return [tuple(x) for x in json.loads(out.read_text())["stats"].get("cost_trace", [])], valid


@pytest.mark.skipif(not (BASE.is_dir() and TMIT.exists()),
                    reason="needs ../shared/baselines/tmit-star and a restored tmit-star")
def test_anytime_cost_against_tmit_star(tmp_path):
    trials = int(os.environ.get("TMIT_TRIALS", "2"))
    limit = float(os.environ.get("TMIT_LIMIT", "30"))
    problems = os.environ.get("TMIT_PROBLEMS", " ".join(PROBLEMS)).split()
    rows, raw, invalid = [], {}, 0
    for pb in problems:
        dom, k = pb.split(":")
        spec = f"problems/{dom}/problems/{dom}_pb_{k}.json"
        got = {"tmit-star": [], "tmpc": []}
        for t in range(1, trials + 1):
            got["tmit-star"].append(_tmit(tmp_path / "tmit", spec, limit))
            trace, valid = _tmpc(tmp_path, spec, t, limit)
            got["tmpc"].append(trace)
            invalid += bool(trace) and not valid
        raw[pb] = got
        for who, traces in got.items():
            first = [tr[0][0] if tr else math.inf for tr in traces]
            at = [float(np.median([_best_at(tr, x) for tr in traces])) for x in TIMES
                  if x <= limit]
            rows.append((pb, who, sum(bool(tr) for tr in traces), len(traces),
                         float(np.median(first)), at))
    assert rows
    print("\n| problem | planner | solved | median first solution s | "
          + " | ".join(f"median best cost at {x} s" for x in TIMES if x <= limit) + " |")
    print("|---|---|---|---|" + "---|" * len([x for x in TIMES if x <= limit]))
    for pb, who, ok, n, first, at in rows:
        print(f"| {pb} | {who} | {ok}/{n} | {first:.2f} | "
              + " | ".join("—" if math.isinf(c) else f"{c:.1f}" for c in at) + " |")
    print("raw traces (seconds, cost):", json.dumps(raw))
    assert invalid == 0, f"{invalid} tmpc plans failed tmpc validate"
