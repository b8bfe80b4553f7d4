"""The FF heuristic (runtime/planners/heuristic.py), checked against an independent naive relaxation."""

from __future__ import annotations

import math
from collections import deque
from types import SimpleNamespace

import numpy as np
import pytest

from tests.support import EXAMPLES, FIXTURES
from tmpc.compiler.ground import bits, ground, relaxed_holds
from tmpc.lang.program import Workspace, check_parsed, load_checked
from tmpc.lang.source import SourceFile
from tmpc.runtime.planners.heuristic import (
    GOAL_PRIORITY,
    FFHeuristic,
    RelaxedTask,
    ScaledPriorities,
)

# ---- problems -----------------------------------------------------------------------------------

CE_CHAIN = """(define (domain ce) (:requirements :strips :conditional-effects)
  (:predicates (p) (q) (r) (s))
  (:action a :parameters () :precondition (p) :effect (and (q) (when (q) (r))))
  (:action b :parameters () :precondition (r) :effect (and (s) (not (p)))))
(define (problem ce1) (:domain ce) (:init (p)) (:goal (s)))"""

DOOR = """(define (domain door)
  (:requirements :strips :negative-preconditions :derived-predicates)
  (:predicates (locked) (open) (inside) (has-key) (safe))
  (:derived (safe) (and (inside) (not (open))))
  (:action take-key :parameters () :precondition (not (has-key)) :effect (has-key))
  (:action unlock :parameters () :precondition (and (locked) (has-key)) :effect (not (locked)))
  (:action open-door :parameters () :precondition (and (not (locked)) (not (open)))
    :effect (open))
  (:action enter :parameters () :precondition (open) :effect (inside))
  (:action close-door :parameters () :precondition (open) :effect (not (open))))
(define (problem door1) (:domain door) (:init (locked)) (:goal (safe)))"""

ALT = """(define (domain alt) (:requirements :strips :disjunctive-preconditions)
  (:predicates (a) (b) (c) (d) (g))
  (:action mk-b :parameters () :precondition (a) :effect (b))
  (:action mk-c :parameters () :precondition (b) :effect (c))
  (:action mk-d :parameters () :precondition (c) :effect (and (d) (not (a))))
  (:action fin :parameters () :precondition (or (d) (and (a) (b))) :effect (g)))
(define (problem alt1) (:domain alt) (:init (a)) (:goal (or (d) (and (c) (g)))))"""

# 2^7 disjuncts: more than the small-DNF limit, so `finish` is a generic (re-evaluated) unit
WIDE = """(define (domain wide) (:requirements :strips :disjunctive-preconditions)
  (:predicates (x1) (x2) (x3) (x4) (x5) (x6) (x7) (y1) (y2) (y3) (y4) (y5) (y6) (y7) (g))
  (:action mk-y7 :parameters () :precondition (x1) :effect (y7))
  (:action mk-y2 :parameters () :precondition (y7) :effect (and (y2) (not (x2))))
  (:action finish :parameters ()
    :precondition (and (or (x1) (y1)) (or (x2) (y2)) (or (x3) (y3)) (or (x4) (y4))
                       (or (x5) (y5)) (or (x6) (y6)) (or (x7) (y7)))
    :effect (g))
  (:action shuffle :parameters () :precondition (g)   ; so that no atom is static
    :effect (and (y1) (y3) (y4) (y5) (y6) (x7)
                 (not (x1)) (not (x3)) (not (x4)) (not (x5)) (not (x6)) (not (y7)))))
(define (problem wide1) (:domain wide) (:init (x1) (x2) (x3) (x4) (x5) (x6)) (:goal (g)))"""

# a generic unit relaxed-true in layer 0 by its negated literals alone (it watches no atom)
WIDE_NEG = """(define (domain wide-neg) (:requirements :strips :disjunctive-preconditions
                                          :negative-preconditions)
  (:predicates (x1) (x2) (x3) (x4) (x5) (x6) (x7) (y1) (y2) (y3) (y4) (y5) (y6) (y7) (g))
  (:action finish :parameters ()
    :precondition (and (or (not (x1)) (y1)) (or (not (x2)) (y2)) (or (not (x3)) (y3))
                       (or (not (x4)) (y4)) (or (not (x5)) (y5)) (or (not (x6)) (y6))
                       (or (not (x7)) (y7)))
    :effect (g))
  (:action shuffle :parameters () :precondition (g)
    :effect (and (y1) (y2) (y3) (y4) (y5) (y6) (y7)
                 (not (x1)) (not (x2)) (not (x3)) (not (x4)) (not (x5)) (not (x6)) (not (x7)))))
(define (problem wide-neg1) (:domain wide-neg)
  (:init (x1) (x2) (x3) (x4) (x5) (x6) (x7)) (:goal (g)))"""

TRAP = """(define (domain trap) (:requirements :strips)
  (:predicates (fuel) (at-a) (at-b))
  (:action go :parameters () :precondition (and (fuel) (at-a)) :effect (and (at-b) (not (at-a))))
  (:action spill :parameters () :precondition (fuel) :effect (not (fuel))))
(define (problem trap1) (:domain trap) (:init (fuel) (at-a)) (:goal (at-b)))"""

NEG_GOAL = """(define (domain neg) (:requirements :strips :negative-preconditions)
  (:predicates (p) (q))
  (:action clear-p :parameters () :precondition (p) :effect (not (p)))
  (:action set-q :parameters () :precondition () :effect (q)))
(define (problem neg1) (:domain neg) (:init (p)) (:goal (not (p))))"""

HANDWRITTEN = {"ce-chain": CE_CHAIN, "door": DOOR, "alt": ALT, "wide": WIDE, "wide-neg": WIDE_NEG,
               "trap": TRAP, "neg-goal": NEG_GOAL}


def _load_text(text: str):
    ws = Workspace()
    report = check_parsed(ws, [ws.add_source(SourceFile("t.pddl", text))])
    assert report.ok, report.diagnostics
    return ground(report.programs[0])


def _corpus() -> dict[str, list]:
    out = {}
    for d in sorted((FIXTURES / "classical").iterdir()) + sorted(EXAMPLES.iterdir()):
        if (d / "domain.pddl").is_file():
            for p in sorted(d.glob("*.pddl")):
                if p.name != "domain.pddl":
                    out[f"{d.name}/{p.stem}"] = [d / "domain.pddl", p]
    return out


CORPUS = _corpus()
ALL = sorted(CORPUS) + sorted(HANDWRITTEN)
_CACHE: dict = {}


def problem(name: str):
    if name not in _CACHE:
        _CACHE[name] = (_load_text(HANDWRITTEN[name]) if name in HANDWRITTEN
                        else ground(load_checked(CORPUS[name])))
    return _CACHE[name]


def states(gp, limit: int = 120, random_states: int = 20, seed: int = 0) -> list[int]:
    """Breadth-first reachable states (geometry optimistic), then random ones (derived atoms
    recomputed): those include relaxed dead ends."""
    seen = {gp.init: None}
    queue = deque([gp.init])
    while queue and len(seen) < limit:
        s = queue.popleft()
        for _, t in gp.successors(s):
            if t not in seen:
                seen[t] = None
                queue.append(t)
    out = list(seen)
    rng = np.random.default_rng(seed)
    derived = sum(1 << i for i, a in enumerate(gp.atoms) if a.kind == "derived")
    for _ in range(random_states):
        bits_ = rng.integers(0, 2, len(gp.atoms))
        s = sum(1 << i for i, b in enumerate(bits_) if b) & ~derived
        out.append(gp.evaluate_derived(s))
    return list(dict.fromkeys(out))


# ---- an independent naive relaxation -----------------------------------------------------------


def _reached(gp, state: int) -> bytearray:
    r = bytearray(len(gp.atoms))
    for i in bits(state):
        r[i] = 1
    _close(gp, r)
    return r


def _close(gp, r: bytearray) -> None:
    """Derived atoms of the relaxation: fire axioms until nothing changes."""
    changed = True
    while changed:
        changed = False
        for ax in gp.axioms:
            if not r[ax.head] and relaxed_holds(ax.body, r):
                r[ax.head] = 1
                changed = True


def _relaxed_adds(gp, action, r: bytearray) -> list[int]:
    out = list(action.adds)
    for ce in action.conditional:
        if relaxed_holds(ce.condition, r):
            out += ce.adds
    return out


def naive_hmax(gp, state: int) -> float:
    """Layers of the delete relaxation until the goal is relaxed-true: one layer applies every
    relaxed-applicable action at once, then axioms close the layer. inf: never."""
    r = _reached(gp, state)
    k = 0
    while not relaxed_holds(gp.goal.formula, r):
        new = [i for a in gp.actions if relaxed_holds(a.pre.formula, r)
               for i in _relaxed_adds(gp, a, r) if not r[i]]
        if not new:
            return math.inf
        for i in new:
            r[i] = 1
        _close(gp, r)
        k += 1
    return k


# ---- h ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ALL)
def test_h_against_the_naive_relaxation(name):
    gp = problem(name)
    H = FFHeuristic(gp)
    for s in states(gp):
        h, hmax, naive = H.h(s), H.h_max(s), naive_hmax(gp, s)
        at_goal = gp.goal_satisfied(s)
        assert (h == 0) == at_goal, (name, gp.state_atoms(s))
        assert (h == math.inf) == (naive == math.inf), (name, gp.state_atoms(s))
        if at_goal:
            assert hmax == 0
        elif naive < math.inf:
            # h_max is the naive layer count (at least 1 away from a goal state)
            assert hmax == max(naive, 1)
            assert h >= hmax and h >= 1


@pytest.mark.parametrize("name", ALL)
def test_relaxed_plan_reaches_the_goal_in_the_relaxation(name):
    gp = problem(name)
    H = FFHeuristic(gp)
    for s in states(gp, limit=60):
        plan = H.relaxed_plan(s)
        if H.h(s) == math.inf:
            assert plan is None
            continue
        r = _reached(gp, s)
        for layer in plan.layers:
            adds = []
            for a in layer:
                assert relaxed_holds(a.pre.formula, r), (name, a.name)
                adds += _relaxed_adds(gp, a, r)
            for i in adds:
                r[i] = 1
            _close(gp, r)
        assert relaxed_holds(gp.goal.formula, r), name
        assert H.h(s) == (plan.length if plan.length else (0 if gp.goal_satisfied(s) else 1))
        assert plan.h_max == (H.h_max(s) if plan.length else 0)
        for k, goals in enumerate(plan.subgoals):
            assert not any((s >> i) & 1 for i in goals), "a subgoal true in the state"


@pytest.mark.parametrize("name", ALL)
def test_helpful_actions_are_applicable_and_add_a_first_layer_subgoal(name):
    gp = problem(name)
    H = FFHeuristic(gp)
    for s in states(gp, limit=60):
        helpful = H.helpful_actions(s)
        assert [a.id for a in helpful] == sorted(a.id for a in helpful)
        plan = H.relaxed_plan(s)
        g1 = plan.first_layer_subgoals if plan else frozenset()
        for a in helpful:
            assert gp.applicable(s, a)
            new = gp.apply(s, a) & ~s
            assert any((new >> i) & 1 for i in g1), (name, a.name)
        # and every applicable action that adds a G_1 atom is helpful
        others = {a.id for a in gp.actions if gp.applicable(s, a)
                  and any((gp.apply(s, a) >> i) & 1 for i in g1)}
        assert others == {a.id for a in helpful}


# ---- suggest ------------------------------------------------------------------------------------


def expected_suggestions(gp, s):
    """planet's priorities recomputed from h' values of a separate heuristic instance."""
    ref = FFHeuristic(gp, cache_size=4)
    if gp.goal_satisfied(s):
        return [(None, GOAL_PRIORITY)]
    if ref.h(s) == math.inf:
        return []
    g1 = ref.relaxed_plan(s).first_layer_subgoals
    rows = []
    for a in gp.actions:
        if gp.applicable(s, a):
            t = gp.apply(s, a)
            h2 = ref.h(t)
            if h2 < math.inf:
                rows.append((a, h2, any((t >> i) & 1 and not (s >> i) & 1 for i in g1)))
    prio = {a.id: (4.0 if h2 == 0 else 1 / h2 ** 2) for a, h2, _ in rows}
    helpful = [prio[a.id] for a, _, is_h in rows if is_h]
    ref_p = min(helpful) if helpful else min(prio.values(), default=0)
    return [(a, prio[a.id] if is_h or h2 == 0 else 0.05 * ref_p) for a, h2, is_h in rows]


@pytest.mark.parametrize("name", ALL)
def test_suggest_follows_planets_priorities(name):
    gp = problem(name)
    H = FFHeuristic(gp)
    for s in states(gp, limit=25, random_states=5):
        got = H.suggest(s)
        want = expected_suggestions(gp, s)
        assert [a for a, _ in got] == [a for a, _ in want]
        assert [p for _, p in got] == pytest.approx([p for _, p in want], rel=1e-12)
        assert all(p > 0 for _, p in got)
        assert H.suggest(s) == got       # cached


def test_suggest_handwritten_values():
    gp = problem("trap")
    H = FFHeuristic(gp)
    go, spill = gp.find_action("go"), gp.find_action("spill")
    assert H.h(gp.init) == 1
    assert H.h(gp.apply(gp.init, spill)) == math.inf
    assert H.suggest(gp.init) == [(go, GOAL_PRIORITY)]           # spill leads to a dead end
    assert H.suggest(gp.apply(gp.init, go)) == [(None, GOAL_PRIORITY)]
    assert H.suggest(gp.apply(gp.init, spill)) == []
    # no helpful action: the door is locked, the first-layer subgoal is (open)
    gp = problem("door")
    H = FFHeuristic(gp)
    assert H.h(gp.init) == 2 and H.helpful_actions(gp.init) == []
    assert H.suggest(gp.init) == [(gp.find_action("take-key"), 0.05 * 1 / 2 ** 2)]
    # a negated goal atom: relaxed-true at once, yet one action is needed
    gp = problem("neg-goal")
    H = FFHeuristic(gp)
    assert H.h(gp.init) == 1 and H.helpful_actions(gp.init) == []
    clear, set_q = gp.find_action("clear-p"), gp.find_action("set-q")
    # no helpful action: the smallest 1/h'^2 (set-q's, h' = 1) stands in for the helpful minimum
    assert H.suggest(gp.init) == [(clear, GOAL_PRIORITY), (set_q, 0.05 * 1.0)]


def test_conditional_effect_that_needs_its_own_add_counts_twice():
    gp = problem("ce-chain")
    H = FFHeuristic(gp)
    plan = H.relaxed_plan(gp.init)
    assert [[a.name for a in layer] for layer in plan.layers] == [["(a)"], ["(a)"], ["(b)"]]
    assert H.h(gp.init) == 3 == H.h_max(gp.init)


def test_disjunctions_and_generic_units():
    gp = problem("alt")
    H = FFHeuristic(gp)
    # goal disjunct (c g) in layer 2 (d needs 3): (mk-b), then (mk-c) and (fin) by its (a b)
    assert H.h(gp.init) == 3 and H.h_max(gp.init) == 2
    assert [[a.name for a in layer] for layer in H.relaxed_plan(gp.init).layers] == [
        ["(mk-b)"], ["(mk-c)", "(fin)"]]
    gp = problem("wide")
    task = RelaxedTask(gp)
    finish = gp.find_action("finish").id
    assert [u for u, a in enumerate(task.act) if a == finish] == task.generic
    H = FFHeuristic(gp)
    assert H.h(gp.init) == 2 and [a.name for a in H.helpful_actions(gp.init)] == ["(mk-y7)"]
    s = gp.apply(gp.init, gp.find_action("mk-y7"))
    assert H.h(s) == 1 and gp.find_action("finish") in H.helpful_actions(s)
    gp = problem("wide-neg")
    assert RelaxedTask(gp).generic
    assert FFHeuristic(gp).h(gp.init) == 1 and not gp.applicable(gp.init, gp.find_action("finish"))


def test_derived_goal_blocksworld():
    gp = problem("blocksworld/p01")
    H = FFHeuristic(gp)
    assert H.h(gp.init) >= naive_hmax(gp, gp.init) == H.h_max(gp.init) >= 1
    assert [a.name for a in H.helpful_actions(gp.init)] == ["(unstack a b)"]


@pytest.mark.parametrize("n", [1, 3, 6])
def test_clutter_sticks(n):
    from tmpc.lang.world.generate import clutter_problem, stick_name
    text = (EXAMPLES / "clutter" / "domain.pddl").read_text() + clutter_problem(n, red=True)
    gp = _load_text(text)
    H = FFHeuristic(gp)
    assert H.h(gp.init) == 2 * n and H.h_max(gp.init) == 2
    helpful = H.helpful_actions(gp.init)
    assert {a.schema for a in helpful} == {"pickup"}
    assert {a.args[0] for a in helpful} == {stick_name(k) for k in range(n)}
    got = H.suggest(gp.init)
    assert {a.id for a in helpful} <= {a.id for a, _ in got}
    # a helpful pickup leaves 2n - 1 actions; a red stick's pickup is not helpful
    prio = {a.name: p for a, p in got}
    assert prio[helpful[0].name] == pytest.approx(1 / (2 * n - 1) ** 2)
    red = [p for a, p in got if a.args[0].startswith("red")]
    assert red and all(p == pytest.approx(0.05 / (2 * n - 1) ** 2) for p in red)


def test_stats_and_cache():
    gp = problem("blocksworld/p01")
    H = FFHeuristic(gp, cache_size=8)
    H.suggest(gp.init)
    first = H.stats.explorations
    assert first > 1 and H.stats.seconds > 0 and H.stats.suggest_calls == 1
    H.suggest(gp.init)
    assert H.stats.explorations == first and H.stats.cache_hits >= 1
    assert len(H._analyses.data) <= 8


# ---- scaled priorities --------------------------------------------------------------------------


class _Fixed:
    def __init__(self, rows):
        self.rows = rows

    def suggest(self, state):
        return list(self.rows)


A, B = SimpleNamespace(id=0), SimpleNamespace(id=1)


def test_scaled_priority_math():
    sp = ScaledPriorities(_Fixed([(A, 1.0), (B, 0.25), (None, 4.0)]))
    assert sp.gamma == 100.0
    assert sp.scaled(7) == [(A, 1.0), (B, 0.25), (None, 4.0)]
    sp.record_failure(sp.entry(7, A))
    sp.record_failure(sp.entry(7, A))
    sp.record_success(sp.entry(7, B))
    sp.record_success(sp.entry(7, None))
    sp.record_failure(sp.entry(8, B))    # another state: counted apart
    assert sp.counts(sp.entry(7, A)) == (2, 0) and sp.counts(sp.entry(7, B)) == (0, 1) and \
        sp.counts(sp.entry(8, B)) == (1, 0)
    assert sp.scaled(7) == [(A, 1.0 / 3), (B, 0.25 / 101), (None, 4.0 / 101)]
    assert ScaledPriorities(_Fixed([(A, 2.0)]), gamma=3).scale(2.0, 1, 2) == 2.0 / 8
    alone = ScaledPriorities(gamma=3)           # bookkeeping only: entries added by hand
    alone.record_success(alone.add(1, A, 1.0))
    assert alone.counts(alone.entry(1, A)) == (0, 1) and alone.scale(1.0, 0, 1) == 0.25
    with pytest.raises(ValueError, match="without a heuristic"):
        alone.scaled(2)                         # a state it has no entries for
    with pytest.raises(ValueError, match="gamma"):
        ScaledPriorities(_Fixed([]), gamma=0.5)
    assert ScaledPriorities(_Fixed([])).choose(np.random.default_rng(0), 0) is None


def test_choose_is_deterministic_and_proportional():
    C = SimpleNamespace(id=2)
    sp = ScaledPriorities(_Fixed([(A, 1.0), (B, 3.0), (C, 2.0), (None, 4.0)]))
    sp.record_failure(sp.entry(0, C))    # C: 2 / 2 = 1

    def draws(seed: int) -> list:
        rng = np.random.default_rng(seed)
        return [sp.choose(rng, 0) for _ in range(50)]

    assert draws(5) == draws(5) and draws(5) != draws(6)
    rng = np.random.default_rng(123)
    n = 40_000
    picks = [sp.entries[sp.choose(rng, 0)][1] for _ in range(n)]
    weights = {0: 1.0, 1: 3.0, 2: 1.0, -1: 4.0}
    total = sum(weights.values())
    for key, w in weights.items():
        p = w / total
        freq = sum(1 for x in picks if (x.id if x is not None else -1) == key) / n
        assert abs(freq - p) < 5 * math.sqrt(p * (1 - p) / n), (key, freq, p)
