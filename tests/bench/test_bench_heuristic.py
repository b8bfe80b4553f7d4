"""FF heuristic benchmark: h() and suggest() calls per second on clutter 1..14 sticks and
blocksworld, counter-based propagation vs naive layer scans measured in the same run.

Run with `pytest -m bench -s tests/bench/test_bench_heuristic.py`; prints a table, asserts
behaviour only (the naive variants agree on h_max and give valid h_FF values).

Baselines (same units, same FF extraction; only the layer computation differs):
* naive scan: every layer re-tests every unit not yet fired (``all(level[p] <= L ...)``) until
  nothing changes — the textbook fixpoint;
* naive bitset: the same scan, but each test is one mask test on the reached-atoms bitset.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from tests.support import EXAMPLES
from tmpc.compiler.ground import bits, ground
from tmpc.lang.program import Workspace, check_parsed
from tmpc.lang.source import SourceFile
from tmpc.runtime.planners.heuristic import UNREACHED, GOAL_UNIT, FFHeuristic, Analysis, relaxed_level, relaxed_witness

pytestmark = pytest.mark.bench


class NaiveScan(FFHeuristic):
    """Layers by re-scanning all units until a fixpoint (per layer), atom by atom."""

    def _explore(self, state):
        t = self.task
        level, sup = [UNREACHED] * t.n, [-1] * t.n
        for p in bits(state):
            level[p] = 0
        fired, witness = bytearray(len(t.pre)), {}
        L, reached = 0, state           # reached: the atoms of level <= L, as a bitset
        while True:
            later = []
            changed = True
            while changed:
                changed = False
                for u in range(len(t.pre)):
                    if fired[u] or not self._ready(u, L, level, reached):
                        continue
                    if t.formula[u] is not None:
                        witness[u] = []
                        relaxed_witness(t.formula[u], level, witness[u])
                    if t.act[u] == GOAL_UNIT:
                        return self._extract(state, level, sup, u, L, witness)
                    fired[u] = 1
                    lv = L + t.cost[u]
                    for q in t.adds[u]:
                        if level[q] > lv:
                            level[q], sup[q] = lv, u
                            if lv == L:
                                reached |= 1 << q
                                changed = True
                            else:
                                later.append(q)
            if not later:
                return Analysis(math.inf, math.inf)
            for q in later:
                reached |= 1 << q
            L += 1

    def _ready(self, u, L, level, reached) -> bool:
        t = self.task
        if t.formula[u] is not None:
            return relaxed_level(t.formula[u], level) <= L
        return all(level[p] <= L for p in t.pre[u])


class NaiveBitset(NaiveScan):
    """The same scan with one mask test per unit against the reached-atoms bitset."""

    def __init__(self, problem, **kw):
        super().__init__(problem, **kw)
        self._masks = [sum(1 << p for p in pre) for pre in self.task.pre]

    def _ready(self, u, L, level, reached) -> bool:
        if self.task.formula[u] is not None:
            return relaxed_level(self.task.formula[u], level) <= L
        m = self._masks[u]
        return reached & m == m


def _load(text: str):
    ws = Workspace()
    report = check_parsed(ws, [ws.add_source(SourceFile("b.pddl", text))])
    assert report.ok, report.diagnostics
    return ground(report.programs[0])


def _blocks(n: int) -> str:
    """Invert a tower of ``n`` blocks (the example domain, derived `above` in the goal)."""
    names = [f"b{i}" for i in range(n)]
    init = [f"(on {a} {b})" for a, b in zip(names, names[1:])]
    goal = [f"(on {b} {a})" for a, b in zip(names, names[1:])]
    return ((EXAMPLES / "blocksworld" / "domain.pddl").read_text() +
            f"(define (problem tower-{n}) (:domain blocks) (:objects {' '.join(names)} - block)"
            f" (:init {' '.join(init)} (on-table {names[-1]}) (clear {names[0]}) (hand-empty))"
            f" (:goal (and {' '.join(goal)} (above {names[-1]} {names[0]}))))")


def _walk(gp, n: int, seed: int = 0) -> list[int]:
    """Distinct states of a random walk (restarting from init at dead ends / goal)."""
    rng = np.random.default_rng(seed)
    out, s = {gp.init: None}, gp.init
    for _ in range(20 * n):
        succ = [t for _, t in gp.successors(s)]
        if not succ or gp.goal_satisfied(s):
            s = gp.init
            continue
        s = succ[int(rng.integers(len(succ)))]
        out[s] = None
        if len(out) >= n:
            break
    return list(out)


def _rate(make, states, method: str, budget: float = 0.3) -> float:
    """Cold-cache calls per second: a fresh heuristic per pass over the distinct states."""
    calls, spent = 0, 0.0
    while spent < budget:
        H = make()
        fn = getattr(H, method)
        t = time.perf_counter()
        for s in states:
            fn(s)
        spent += time.perf_counter() - t
        calls += len(states)
    return calls / spent


def _cases():
    from tmpc.lang.world.generate import clutter_problem
    dom = (EXAMPLES / "clutter" / "domain.pddl").read_text()
    for n in range(1, 15):
        yield f"clutter {n}", _load(dom + clutter_problem(n))
    yield "clutter 14 + 14 red", _load(dom + clutter_problem(14, red=True))
    yield "blocksworld p01 (3)", _load((EXAMPLES / "blocksworld" / "domain.pddl").read_text() +
                                       (EXAMPLES / "blocksworld" / "p01.pddl").read_text())
    for n in (6, 10):
        yield f"blocksworld tower {n}", _load(_blocks(n))


def test_heuristic_rates():
    rows = []
    for label, gp in _cases():
        states = _walk(gp, 60)
        fast, scan, bitset = FFHeuristic(gp), NaiveScan(gp), NaiveBitset(gp)
        for s in states:            # the variants agree on h_max and give valid h_FF
            assert fast.h_max(s) == scan.h_max(s) == bitset.h_max(s)
            assert (fast.h(s) == math.inf) == (scan.h(s) == math.inf)
            assert fast.h(s) >= fast.h_max(s)
        small = lambda cls: (lambda: cls(gp, cache_size=1))
        h_fast = _rate(small(FFHeuristic), states, "h")
        h_scan = _rate(small(NaiveScan), states, "h")
        h_bits = _rate(small(NaiveBitset), states, "h")
        s_fast = _rate(lambda: FFHeuristic(gp), states, "suggest")
        s_scan = _rate(lambda: NaiveScan(gp), states[:15], "suggest")
        H = FFHeuristic(gp)
        for s in states:
            H.suggest(s)
        warm = _rate(lambda: H, states, "suggest", budget=0.1)
        rows.append((label, len(gp.atoms), len(H.task.pre), H.h(gp.init), h_fast, h_scan,
                     h_bits, s_fast, s_scan, warm))
    print("\n60 distinct states of a random walk per problem. h: every call a cache miss. suggest "
          "'fresh': a new heuristic per pass over the states (successors shared by states are "
          "computed once a pass); 'cached': every state seen before.")
    print("\n| problem | atoms | units | h(init) | h/s counter | h/s naive scan | h/s naive "
          "bitset | counter/scan | counter/bitset | suggest/s fresh | suggest/s fresh, naive "
          "scan | suggest/s cached |\n|---|---|---|---|---|---|---|---|---|---|---|---|")
    for label, na, nu, h0, hf, hs, hb, sf, ss, w in rows:
        print(f"| {label} | {na} | {nu} | {h0:g} | {hf:,.0f} | {hs:,.0f} | {hb:,.0f} | "
              f"{hf / hs:.1f}x | {hf / hb:.1f}x | {sf:,.0f} | {ss:,.0f} | {w:,.0f} |")
