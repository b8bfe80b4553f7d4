"""The SAT task planner: every plan replays, lengths are optimal (against breadth-first search),
exclusion and evidence constraints do what docs/math.md §B says, and the static checks."""

from __future__ import annotations

import random
from collections import deque
from pathlib import Path

import pytest

from tests.support import EXAMPLES, FIXTURES, check
from tmpc.compiler.ground import GeoLiteral, ground
from tmpc.compiler.smt import encode, lmcut, smtlib_templates
from tmpc.compiler.smt.mutex import mutex_groups, mutex_pairs
from tmpc.lang.program import Workspace, check_parsed, load_checked
from tmpc.lang.source import SourceFile
from tmpc.runtime.planners.taskplan import EXHAUSTED, SOLVED, UNREACHABLE, TaskPlanner, simulate


def _problems() -> list[tuple[Path, Path]]:
    out = []
    for group in ("classical", "tmpc", "legacy"):
        for dom in sorted((FIXTURES / group).rglob("domain.pddl")):
            out += [(dom, p) for p in sorted(dom.parent.glob("*.pddl")) if p.name != "domain.pddl"]
    for d in sorted(EXAMPLES.iterdir()):
        if (d / "domain.pddl").is_file():
            out += [(d / "domain.pddl", p) for p in sorted(d.glob("*.pddl"))
                    if p.name != "domain.pddl"]
    return out


PROBLEMS = _problems()


def _id(pair) -> str:
    return f"{pair[0].parent.name}/{pair[1].stem}"


def _ground(*texts: str):
    ws = Workspace()
    parsed = [ws.add_source(SourceFile(f"f{i}.pddl", t)) for i, t in enumerate(texts)]
    report = check_parsed(ws, parsed)
    assert report.ok, report.diagnostics
    return ground(report.programs[0])


def bfs_length(gp, max_states: int = 200_000) -> int | None:
    """Length of a shortest plan by breadth-first search (None: none; AssertionError: too big)."""
    depth = {gp.init: 0}
    queue = deque([gp.init])
    while queue:
        s = queue.popleft()
        if gp.goal_satisfied(s):
            return depth[s]
        for _, t in gp.successors(s):
            if t not in depth:
                depth[t] = depth[s] + 1
                queue.append(t)
        assert len(depth) <= max_states, "state space too large for the test"
    return None


def shortest_plan_count(gp, length: int) -> int:
    """How many action sequences of exactly ``length`` steps reach the goal."""
    layer = {gp.init: 1}
    for _ in range(length):
        nxt: dict[int, int] = {}
        for s, n in layer.items():
            for _, t in gp.successors(s):
                nxt[t] = nxt.get(t, 0) + n
        layer = nxt
    return sum(n for s, n in layer.items() if gp.goal_satisfied(s))


def plan_ok(gp, result, optimum: int | None) -> None:
    assert result.status == SOLVED, result.status
    ok, why = simulate(gp, result.actions)
    assert ok, why
    assert len(result.actions) == result.horizon == optimum


# ---- corpus: every fixture and example ---------------------------------------------------------


@pytest.mark.parametrize("pair", PROBLEMS, ids=_id)
def test_plans_replay_and_are_shortest(pair):
    gp = ground(load_checked(list(pair)))
    result = TaskPlanner(gp).plan(max_steps=40, time_limit=60)
    plan_ok(gp, result, bfs_length(gp))


@pytest.mark.parametrize("options", [dict(goal_mode="assumptions"), dict(amo="ladder"),
                                     dict(lower_bound=False, mutexes=False)],
                         ids=["assumptions", "ladder", "bare"])
@pytest.mark.parametrize("name", ["tower-derived/p02", "kitchen-adl/p01", "lift-forall/p01"])
def test_encoding_options_agree(name, options):
    dom, prob = next(p for p in PROBLEMS if _id(p) == name)
    gp = ground(load_checked([dom, prob]))
    plan_ok(gp, TaskPlanner(gp, **options).plan(max_steps=30), bfs_length(gp))


# ---- hand-written features -----------------------------------------------------------------------

REACH = """
(define (domain reach)
  (:requirements :strips :typing :derived-predicates :existential-preconditions)
  (:types node)
  (:predicates (edge ?x ?y - node) (start ?x - node) (reach ?x - node))
  (:derived (reach ?x - node)
    (or (start ?x) (exists (?y - node) (and (reach ?y) (edge ?y ?x)))))
  (:action build :parameters (?x ?y - node)
    :precondition (not (edge ?x ?y)) :effect (edge ?x ?y))
  (:action cut :parameters (?x ?y - node)
    :precondition (edge ?x ?y) :effect (not (edge ?x ?y))))
"""


def test_recursive_derived_atoms_need_real_support():
    # b and c reach each other but not from the start: a completion-only encoding would let
    # the cycle support itself and "solve" this in zero steps (the bound is off so that the
    # encoding itself must refute horizon 0).
    gp = _ground(REACH, """(define (problem p) (:domain reach) (:objects a b c d - node)
      (:init (start a) (edge b c) (edge c b) (edge c d))
      (:goal (reach d)))""")
    assert bfs_length(gp) == 1
    plan_ok(gp, TaskPlanner(gp, lower_bound=False).plan(max_steps=4), 1)
    gp = _ground(REACH, """(define (problem p) (:domain reach) (:objects a b c d - node)
      (:init (start a) (edge b c) (edge c b) (edge c d))
      (:goal (and (reach d) (not (edge c b)))))""")
    plan_ok(gp, TaskPlanner(gp).plan(max_steps=6), 2)


TOWER = """
(define (domain tower)
  (:requirements :strips :typing :negative-preconditions :derived-predicates
                 :existential-preconditions :disjunctive-preconditions)
  (:types block)
  (:predicates (on ?x ?y - block) (on-table ?x - block) (clear ?x - block) (holding ?x - block)
               (hand-empty) (above ?x ?y - block))
  (:derived (above ?x ?y - block)
    (or (on ?x ?y) (exists (?z - block) (and (on ?x ?z) (above ?z ?y)))))
  (:action pick :parameters (?x - block)
    :precondition (and (clear ?x) (hand-empty) (or (on-table ?x) (exists (?y - block) (on ?x ?y))))
    :effect (and (holding ?x) (not (clear ?x)) (not (hand-empty)) (not (on-table ?x))
                 (forall (?y - block) (when (on ?x ?y) (and (clear ?y) (not (on ?x ?y)))))))
  (:action put :parameters (?x - block)
    :precondition (holding ?x)
    :effect (and (on-table ?x) (clear ?x) (hand-empty) (not (holding ?x))))
  (:action stack :parameters (?x ?y - block)
    :precondition (and (holding ?x) (clear ?y) (not (above ?y ?x)))
    :effect (and (on ?x ?y) (clear ?x) (hand-empty) (not (holding ?x)) (not (clear ?y)))))
"""


@pytest.mark.parametrize("goal,length", [
    ("(above d a)", 2),                                      # d onto b, which is on a
    ("(and (above a d) (not (above b d)))", None),
    ("(forall (?x - block) (imply (not (= ?x a)) (above ?x a)))", None),
    ("(exists (?x - block) (and (above ?x b) (above b c)))", None),
])
def test_derived_conditional_disjunctive_quantified(goal, length):
    gp = _ground(TOWER, f"""(define (problem p) (:domain tower) (:objects a b c d - block)
      (:init (on-table a) (on b a) (on-table c) (on-table d) (clear b) (clear c) (clear d)
             (hand-empty))
      (:goal {goal}))""")
    optimum = bfs_length(gp)
    assert optimum is not None and (length is None or optimum == length)
    plan_ok(gp, TaskPlanner(gp).plan(max_steps=20), optimum)


def _random_domain(rng: random.Random, n_atoms: int = 5, n_actions: int = 6) -> str:
    atoms = [f"(f{i})" for i in range(n_atoms)]
    parts = []
    for k in range(n_actions):
        pre = [rng.choice(atoms) if rng.random() < 0.7 else f"(not {rng.choice(atoms)})"
               for _ in range(rng.randint(0, 2))]
        if rng.random() < 0.3:
            pre.append(f"(or {rng.choice(atoms)} {rng.choice(atoms)})")
        eff = [rng.choice(atoms) for _ in range(rng.randint(1, 2))] + \
              [f"(not {rng.choice(atoms)})" for _ in range(rng.randint(0, 2))]
        if rng.random() < 0.4:
            eff.append(f"(when {rng.choice(atoms)} (not {rng.choice(atoms)}))")
        if rng.random() < 0.3:
            eff.append(f"(when (not {rng.choice(atoms)}) {rng.choice(atoms)})")
        parts.append(f"(:action a{k} :parameters () :precondition (and {' '.join(pre)}) "
                     f":effect (and {' '.join(eff)}))")
    preds = " ".join(atoms) + " (g)"
    derived = "(:derived (g) (or (and (f0) (f1)) (and (f2) (not (f3)))))"
    return (f"(define (domain rnd) (:requirements :adl :derived-predicates) (:predicates {preds}) "
            f"{derived} {' '.join(parts)})")


def random_problem(seed: int):
    """The ground random problem of ``seed`` (a random domain, initial state and goal)."""
    rng = random.Random(seed)
    dom = _random_domain(rng)
    init = " ".join(f"(f{i})" for i in range(5) if rng.random() < 0.4)
    goal = rng.choice(["(g)", "(and (f4) (not (f0)))", "(or (f3) (and (g) (f4)))",
                       "(and (f1) (f2) (f3))"])
    return _ground(dom, f"(define (problem p) (:domain rnd) (:init {init}) (:goal {goal}))")


@pytest.mark.parametrize("seed", range(40))
def test_random_problems_against_bfs(seed):
    gp = random_problem(seed)
    optimum = bfs_length(gp)
    result = TaskPlanner(gp).plan(max_steps=12)
    if optimum is None:
        assert result.status in (EXHAUSTED, UNREACHABLE)
    else:
        plan_ok(gp, result, optimum)


def test_the_same_problem_gives_the_same_plans_in_every_planner():
    """Plans depend on the problem and what was added, not on the planners made before in the
    process (each TaskPlanner has its own Z3 context; in the shared one they differed)."""
    from tmpc.lang.world.generate import clutter_problem
    gp = _ground((EXAMPLES / "clutter" / "domain.pddl").read_text(), clutter_problem(4))
    runs = []
    for _ in range(3):
        tp = TaskPlanner(gp, geometric=True)
        first = tp.next_plan(20).actions
        tp.exclude_plan(first)
        runs.append([[a.name for a in first], [a.name for a in tp.next_plan(20).actions]])
    assert runs[0] == runs[1] == runs[2]


def test_goal_true_at_start_gives_the_empty_plan():
    gp = _ground(REACH, """(define (problem p) (:domain reach) (:objects a b - node)
      (:init (start a) (edge a b)) (:goal (reach b)))""")
    plan_ok(gp, TaskPlanner(gp).plan(), 0)


def test_unsolvable_and_unreachable():
    one_shot = """(define (domain once) (:requirements :strips)
      (:predicates (token) (x) (y))
      (:action ax :precondition (token) :effect (and (x) (not (token))))
      (:action ay :precondition (token) :effect (and (y) (not (token)))))"""
    gp = _ground(one_shot, "(define (problem p) (:domain once) (:init (token)) "
                           "(:goal (and (x) (y))))")
    planner = TaskPlanner(gp)
    r = planner.plan(max_steps=5)
    assert r.status == EXHAUSTED and r.actions is None and r.impossible_below == 6
    assert [s.result for s in r.stats] == ["unsat"] * 4          # horizons 2..5 (bound 2)
    r = planner.plan(max_steps=6)                                 # starts past what is proven
    assert [s.horizon for s in r.stats] == [6]
    gp = _ground(one_shot, "(define (problem p) (:domain once) (:init) (:goal (x)))")
    assert TaskPlanner(gp).plan().status == UNREACHABLE


def test_problem_without_actions():
    dom = "(define (domain none) (:requirements :strips) (:predicates (p) (q)))"
    gp = _ground(dom, "(define (problem p) (:domain none) (:init (p)) (:goal (p)))")
    plan_ok(gp, TaskPlanner(gp).plan(), 0)
    gp = _ground(dom, "(define (problem p) (:domain none) (:init (p)) (:goal (q)))")
    assert TaskPlanner(gp).plan().status == UNREACHABLE


def test_time_limit_reports_timeout():
    gp = ground(load_checked([FIXTURES / "classical" / "tower-derived" / "domain.pddl",
                              FIXTURES / "classical" / "tower-derived" / "p02.pddl"]))
    r = TaskPlanner(gp).plan(time_limit=1e-9)
    assert r.status == "timeout" and r.actions is None


# ---- the TMP interface: exclusion and evidence --------------------------------------------------


def _blocks(n: int = 3):
    return ground(load_checked([EXAMPLES / "blocksworld" / "domain.pddl",
                                EXAMPLES / "blocksworld" / "p01.pddl"]))


@pytest.mark.parametrize("goal_mode", ["scope", "assumptions"])
def test_plans_enumerates_every_shortest_plan_once(goal_mode):
    gp = _blocks()
    optimum = bfs_length(gp)
    seen = []
    for plan in TaskPlanner(gp, goal_mode=goal_mode).plans(max_steps=optimum):
        assert simulate(gp, plan)[0]
        seen.append(tuple(a.id for a in plan))
    assert len(seen) == len(set(seen)) == shortest_plan_count(gp, optimum)


def test_exclude_prefix_excludes_every_plan_with_it():
    gp = _blocks()
    planner = TaskPlanner(gp)
    first = planner.plan().actions
    planner.exclude_prefix(first[:2])
    for _ in range(5):
        r = planner.plan(max_steps=12)
        assert r.solved and simulate(gp, r.actions)[0]
        assert [a.id for a in r.actions[:2]] != [a.id for a in first[:2]]
        planner.exclude_plan(r.actions)
    planner.exclude_prefix([])
    assert planner.plan(max_steps=12).status == EXHAUSTED


def test_exclusions_beyond_the_horizon_wait_for_it():
    gp = _blocks()
    planner = TaskPlanner(gp)
    longer = planner.plan(min_steps=8, max_steps=8).actions
    fresh = TaskPlanner(gp)
    fresh.exclude_prefix(longer)                 # step 8 is not encoded yet
    r = fresh.plan(min_steps=8, max_steps=8)
    assert r.solved and [a.id for a in r.actions] != [a.id for a in longer]


ARM = """
(define (domain arm)
  (:requirements :strips :typing :tmpc)
  (:types stick surface manipulator)
  (:predicates
    (on ?x - stick ?s - surface) (free ?m - manipulator) (lit)
    (holding ?m - manipulator ?x - stick :kinematic (link ?m ?x))
    (at ?m - manipulator ?x - stick :semantics (<= (distance (position ?m) (position ?x)) 0.05))
    (above ?m - manipulator ?s - surface :semantics (<= (z (position ?m)) 2.0)))
  (:action pick :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (and (on ?x ?s) (free ?m) (at ?m ?x))
    :effect (and (holding ?m ?x) (not (on ?x ?s)) (not (free ?m))))
  (:action place :parameters (?x - stick ?s - surface ?m - manipulator)
    :precondition (and (holding ?m ?x) (above ?m ?s))
    :effect (and (free ?m) (on ?x ?s) (not (holding ?m ?x))))
  (:action switch :parameters () :precondition (not (lit)) :effect (lit)))
"""


def _arm(goal: str, sticks: str = "x"):
    return _ground(ARM, f"""(define (problem p) (:domain arm)
      (:objects {sticks} - stick t1 t2 - surface m - manipulator)
      (:init {' '.join(f'(on {s} t1)' for s in sticks.split())} (free m))
      (:goal (and {goal})))""")


def test_blockers_refuted_literal_blocks_until_the_mode_changes():
    gp = _arm("(on x t2) (lit)")
    at = GeoLiteral("at", ("m", "x"), True)
    planner = TaskPlanner(gp, geometric=True)
    plan = planner.plan(max_steps=6).actions
    assert len(plan) == 3 and simulate(gp, plan)[0]
    # refuted in the initial mode: no pick of x until a kinematic action changes the mode;
    # `switch` is not kinematic, so the refutation holds after it too
    assert planner.add_evidence([], at, False)
    assert planner.plan(max_steps=8).status == EXHAUSTED
    # with a second stick, moving it changes the mode and makes (at m x) unknown again
    gp = _arm("(on x t2)", "x y")
    planner = TaskPlanner(gp, geometric=True)
    assert planner.plan().horizon == 2
    planner.add_evidence([], ("AT", ("M", "X"), True), False)     # names compare without case
    r = planner.plan(max_steps=8)
    assert r.horizon == 4 and simulate(gp, r.actions)[0]
    assert [a.schema for a in r.actions] == ["pick", "place", "pick", "place"]
    assert r.actions[0].args[0] == "y"


def test_blockers_evidence_after_a_prefix_and_true_evidence_lets_plans_through():
    gp = _arm("(on x t2)")
    pick = gp.find_action("pick", "x", "t1", "m")
    above = GeoLiteral("above", ("m", "t2"), True)
    planner = TaskPlanner(gp, geometric=True)
    assert planner.add_evidence([pick], above, True)
    plan_ok(gp, planner.plan(max_steps=4), 2)
    planner.add_evidence([pick], above, False)         # contradicts: no plan starts with pick
    r = planner.plan(max_steps=6)                      # ... but another prefix is a new mode
    assert r.horizon == 3 and [a.schema for a in r.actions] == ["switch", "pick", "place"]
    fresh = TaskPlanner(gp, geometric=True)
    fresh.add_evidence([pick], above, False)
    assert fresh.plan(max_steps=6).horizon == 3
    assert not fresh.add_evidence([], GeoLiteral("above", ("m", "t1"), False), True)  # unused


def test_changers_say_which_actions_may_change_a_literal():
    gp = _arm("(on x t2)", "x y")
    # nothing changes (at m x): the refutation outlives moving y, so x can never be picked
    planner = TaskPlanner(gp, geometric=True, changers=lambda lit: ())
    planner.add_evidence([], GeoLiteral("at", ("m", "x"), True), False)
    assert planner.plan(max_steps=6).status == EXHAUSTED
    # only `switch` changes it: after switching, x may be picked again
    switch = gp.find_action("switch").id
    planner = TaskPlanner(gp, geometric=True, changers=lambda lit: [switch])
    planner.add_evidence([], GeoLiteral("at", ("m", "x"), True), False)
    r = planner.plan(max_steps=6)
    assert r.horizon == 3 and r.actions[0].schema == "switch"


def test_geometric_view_off_ignores_geometry_and_rejects_evidence():
    gp = _arm("(on x t2)")
    planner = TaskPlanner(gp)
    plan_ok(gp, planner.plan(), 2)
    with pytest.raises(ValueError):
        planner.add_evidence([], GeoLiteral("at", ("m", "x"), True), False)


def test_geometric_goal_literals_get_blockers():
    gp = _arm("(on x t2) (at m x)")
    planner = TaskPlanner(gp, geometric=True)
    plan_ok(gp, planner.plan(max_steps=4), 2)
    place = gp.find_action("place", "x", "t2", "m")
    pick = gp.find_action("pick", "x", "t1", "m")
    planner.add_evidence([pick, place], GeoLiteral("at", ("m", "x"), True), False)
    assert planner.plan(max_steps=2).status == EXHAUSTED


# ---- pieces --------------------------------------------------------------------------------------


def test_smtlib_templates_are_self_contained():
    import z3
    gp = _blocks()
    t = smtlib_templates(gp)
    assert set(t) == {"readme", "layer", "init", "step", "goal", "goal-literals"}

    def horizon(n: int) -> str:
        text = "".join(t["layer"].replace("@K", f"@{k}") for k in range(n + 1)) + t["init"]
        text += "".join(t["step"].replace("@P", f"@{k - 1}").replace("@K", f"@{k}")
                        for k in range(1, n + 1))
        goal = t["goal"] + "".join(f"(assert {lit})" for lit in t["goal-literals"].split("\n"))
        return text + goal.replace("@K", f"@{n}")

    for n, want in ((5, z3.unsat), (6, z3.sat)):
        s = z3.SolverFor("QF_FD")
        s.from_string(horizon(n))
        assert s.check() == want


def test_landmarks_bound_and_mutexes_are_sound():
    for pair in PROBLEMS:
        gp = ground(load_checked(list(pair)))
        lm = lmcut(gp)
        optimum = bfs_length(gp)
        assert lm is not None and lm.bound <= optimum
        sets = lm.sets
        assert all(not (a & b) for i, a in enumerate(sets) for b in sets[i + 1:])
        pairs = mutex_pairs(gp, set(range(len(gp.atoms))))
        groups = mutex_groups(pairs or [])
        mutex = set(pairs or [])
        assert all((a, b) in mutex for g in groups for i, a in enumerate(g) for b in g[i + 1:])
        assert mutex == {(a, b) for g in groups for i, a in enumerate(g) for b in g[i + 1:]}
        if pairs:
            masks = [(1 << p) | (1 << q) for p, q in pairs]
            seen, queue = {gp.init}, deque([gp.init])
            while queue and len(seen) < 20_000:
                s = queue.popleft()
                assert not any(s & m == m for m in masks), _id(pair)
                for _, t in gp.successors(s):
                    if t not in seen:
                        seen.add(t)
                        queue.append(t)


def test_encoding_sizes_and_relevance():
    gp = _ground(REACH, """(define (problem p) (:domain reach) (:objects a b - node)
      (:init (start a)) (:goal (edge b a)))""")
    enc = encode(gp)
    # `reach` is derived but nothing reads it: it has no variables
    reach = {i for i, a in enumerate(gp.atoms) if a.predicate == "reach"}
    assert reach and not reach & enc.relevant
    assert enc.sizes["step"][1] == len(gp.actions)
    assert "(assert ((_ at-most 1)" in enc.step


# ---- static checks ----------------------------------------------------------------------------


def _codes(text: str, budget: float = 5.0) -> list[tuple[str, str]]:
    from tmpc.compiler.smt import static_checks
    report = check(text)
    assert report.ok, report.diagnostics
    return [(d.code, d.message) for d in static_checks(report.programs[0], budget)]


def test_static_checks_find_dead_actions_and_unreachable_goals():
    text = """(define (domain d) (:requirements :strips :negative-preconditions :typing)
      (:types t)
      (:predicates (p ?x - t) (q ?x - t) (r) (never))
      (:action bad :parameters (?x - t) :precondition (and (p ?x) (r) (not (p ?x)))
        :effect (q ?x))
      (:action dead :parameters (?x - t) :precondition (never) :effect (r))
      (:action ok :parameters (?x - t) :precondition (p ?x) :effect (q ?x)))
    (define (problem pr) (:domain d) (:objects a - t) (:init (p a)) (:goal (and (q a) (r))))"""
    got = _codes(text)
    codes = [c for c, _ in got]
    assert codes == ["W610", "W611", "W612"], got
    assert "`bad`" in got[0][1] and "`dead`" in got[1][1] and "(never" in got[1][1]
    assert "(r)" in got[2][1]


def test_static_checks_report_unknown_past_the_budget():
    from tmpc.compiler.smt import static_checks
    prog = load_checked([EXAMPLES / "blocksworld" / "domain.pddl",
                         EXAMPLES / "blocksworld" / "p01.pddl"])
    (d,) = static_checks(prog, budget_s=0.0)
    assert d.code == "W613" and d.severity.value == "note" and "unknown" in d.message


def test_static_checks_quiet_on_the_examples():
    from tmpc.compiler.smt import static_checks
    for pair in PROBLEMS[:12]:
        assert static_checks(load_checked(list(pair))) == []


def test_static_checks_quantifiers_may_be_vacuous():
    text = """(define (domain d) (:requirements :adl) (:types t)
      (:predicates (p ?x - t))
      (:action vac :parameters () :precondition (forall (?x - t) (and (p ?x) (not (p ?x))))
        :effect (and))
      (:action ex :parameters () :precondition (exists (?x - t) (and (p ?x) (not (p ?x))))
        :effect (and)))"""
    got = [c for c, m in _codes(text) if "`ex`" in m or "`vac`" in m]
    assert got == ["W610"]


def test_a_horizon_cap_gives_a_longer_plan_rather_than_a_proof():
    """``horizon_cap`` (the optimal planner's first solution): a horizon whose check outlasts
    the cap is skipped, not proven impossible; the plan found replays, and the next call tries
    the skipped horizon again."""
    import time

    pair = next(p for p in PROBLEMS if p[0].parent.name == "blocksworld")
    gp = ground(load_checked(list(pair)))
    optimum = bfs_length(gp)
    tp = TaskPlanner(gp)
    real, slow = tp._check, {optimum}

    def check(k, deadline):
        if k in slow:                        # this horizon outlasts any cap
            time.sleep(max(0.0, deadline - time.perf_counter()))
            return "unknown", 0.0
        return real(k, deadline)

    tp._check = check
    res = tp.next_plan(40, horizon_cap=0.05)
    assert res.status == SOLVED and simulate(gp, res.actions)[0]
    assert len(res.actions) > optimum and optimum not in tp._unsat
    assert tp.impossible_below() <= optimum
    slow.clear()
    tp.exclude_prefix(res.actions)
    again = tp.next_plan(40, horizon_cap=0.05)
    assert again.status == SOLVED and again.horizon == optimum
