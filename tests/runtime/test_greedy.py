"""The greedy task planner and the portfolio (runtime/planners/greedy.py): plans replay, a
problem without a plan is reported exhausted (against breadth-first search), the constraints
mean what they mean to the SAT planner (the same problems solvable under the same random
constraints, and no greedy plan shorter than the SAT planner's shortest), and blocker rules."""

from __future__ import annotations

import itertools
import random

import pytest

from tests.compiler.test_smt import _arm, _ground, bfs_length, random_problem
from tmpc.compiler.ground import GeoLiteral
from tmpc.runtime.planners.greedy import GreedyTaskPlanner, PortfolioTaskPlanner
from tmpc.runtime.planners.taskplan import (
    EXHAUSTED,
    SOLVED,
    TIMEOUT,
    UNREACHABLE,
    PlanResult,
    TaskPlanner,
    simulate,
)


@pytest.mark.parametrize("seed", range(40))
def test_random_problems_replay_or_have_no_plan(seed):
    gp = random_problem(seed)
    optimum = bfs_length(gp)
    result = GreedyTaskPlanner(gp).next_plan(max_steps=12)
    if optimum is None:
        assert result.status in (EXHAUSTED, UNREACHABLE)
    else:
        assert result.status == SOLVED
        assert simulate(gp, result.actions)[0]
        assert len(result.actions) >= optimum


def _random_constraints(rng: random.Random, gp, planners, n: int) -> None:
    """``n`` random exclusions and evidence (prefixes of applicable actions) to every planner."""
    lits = [GeoLiteral("at", ("m", s), True) for s in ("x", "y")] + \
        [GeoLiteral("above", ("m", t), True) for t in ("t1", "t2")]
    for _ in range(n):
        state, prefix = gp.init, []
        for _ in range(rng.randint(0, 3)):
            moves = [a for a, _ in gp.successors(state)]
            if not moves:
                break
            a = rng.choice(moves)
            prefix.append(a)
            state = gp.apply(state, a)
        if rng.random() < 0.3:
            for pl in planners:
                pl.exclude_prefix(prefix)
        else:
            lit, value = rng.choice(lits), rng.random() < 0.3
            for pl in planners:
                pl.add_evidence(prefix, lit, value)


@pytest.mark.parametrize("seed", range(30))
def test_constraints_mean_what_they_mean_to_the_sat_planner(seed):
    rng = random.Random(seed)
    gp = _arm("(on x t2) (on y t2)" if seed % 2 else "(on x t2)", "x y")
    sat, greedy = TaskPlanner(gp, geometric=True), GreedyTaskPlanner(gp)
    _random_constraints(rng, gp, (sat, greedy), rng.randint(1, 8))
    a, b = sat.next_plan(max_steps=10), greedy.next_plan(max_steps=10)
    assert (a.status == SOLVED) == (b.status == SOLVED), (a.status, b.status)
    if b.status == SOLVED:
        assert simulate(gp, b.actions)[0]
        assert greedy.satisfies(b.actions)
        assert len(b.actions) >= len(a.actions)
        # the greedy plan keeps the SAT planner's constraints, so that planner has a plan of
        # its length too
        assert sat.next_plan(min_steps=len(b.actions), max_steps=len(b.actions)).solved


def test_exclusion_and_evidence_in_the_greedy_planner():
    gp = _arm("(on x t2)")
    pick = gp.find_action("pick", "x", "t1", "m")
    g = GreedyTaskPlanner(gp)
    r = g.next_plan(max_steps=6)
    assert r.solved and [a.schema for a in r.actions] == ["pick", "place"]
    g.exclude_prefix([pick])
    r = g.next_plan(max_steps=6)                  # no plan starts with pick: switch first
    assert [a.schema for a in r.actions] == ["switch", "pick", "place"]
    g.exclude_prefix(r.actions[:1])
    assert g.next_plan(max_steps=6).status == EXHAUSTED
    g = GreedyTaskPlanner(gp)
    assert g.add_evidence([], ("AT", ("M", "X"), True), False)   # names compare without case
    assert g.next_plan(max_steps=6).status == EXHAUSTED      # switch does not move anything
    assert not g.add_evidence([], GeoLiteral("above", ("m", "t1"), False), True)   # unused
    g.exclude_prefix([])
    assert g.next_plan().status == EXHAUSTED


def test_a_blocker_rule_holds_in_every_plan_until_its_blocker_moves():
    gp = _arm("(on x t2)", "x y z")
    at_x = GeoLiteral("at", ("m", "x"), True)
    g = GreedyTaskPlanner(gp)
    # x's grasp failed in the initial state, colliding with y: false until y moves, whatever
    # comes first (moving z first does not help, unlike the SAT planner's evidence)
    assert g.add_evidence([], at_x, False, blockers=["y"])
    r = g.next_plan(max_steps=10)
    assert r.solved and simulate(gp, r.actions)[0]
    names = [(a.schema, a.args[0]) for a in r.actions]
    assert names.index(("pick", "y")) < names.index(("pick", "x"))
    pick = {s: gp.find_action("pick", s, "t1", "m") for s in "xyz"}
    place = {s: gp.find_action("place", s, "t2", "m") for s in "xyz"}
    assert not g.satisfies([pick["z"], place["z"], pick["x"], place["x"]])
    assert g.satisfies([pick["y"], place["y"], pick["x"], place["x"]])
    sat = TaskPlanner(gp, geometric=True)
    sat.add_evidence([], at_x, False)
    assert len(sat.next_plan(max_steps=10).actions) == 4       # z first: weaker
    # blockers that moved in the prefix: the evidence stays at that prefix, until they move
    g = GreedyTaskPlanner(gp)
    g.add_evidence([pick["y"], place["y"]], at_x, False, blockers=["y"])
    assert not g.satisfies([pick["y"], place["y"], pick["z"], place["z"], pick["x"],
                            place["x"]])
    assert g.satisfies([pick["z"], place["z"], pick["x"], place["x"]])
    # ... and moving y again there makes x's grasp unknown again
    assert g.satisfies([pick["y"], place["y"], gp.find_action("pick", "y", "t2", "m"),
                        gp.find_action("place", "y", "t1", "m"), pick["x"], place["x"]])


def test_the_portfolio_keeps_shortest_plans_and_the_greedy_constraints():
    gp = _arm("(on x t2) (on y t2)", "x y z")
    pf = PortfolioTaskPlanner(gp)
    r = pf.next_plan(max_steps=10, horizon_cap=1.0)
    assert r.solved and len(r.actions) == 4 == pf.sat.impossible_below()
    pick_x = gp.find_action("pick", "x", "t1", "m")
    pf.add_evidence([], GeoLiteral("at", ("m", "x"), True), False, blockers=["z"])
    r = pf.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and pf.greedy.satisfies(r.actions)
    names = [(a.schema, a.args[0]) for a in r.actions]
    assert names.index(("pick", "z")) < names.index(("pick", "x"))
    assert r.actions[0] is not pick_x
    # the SAT planner's plans that broke the rule were excluded through the breaking step
    # until its shortest plan kept it: z moved too, 6 steps
    assert pf.answers == {"greedy": 0, "sat": 2} and len(r.actions) == 6
    assert pf.greedy.violation([pick_x]) == 1
    assert pf.greedy.violation(r.actions) is None


def test_blockers_are_the_movable_objects_a_collided_attempt_hit(tabletop_world):
    """TaskPlans.blockers on the tabletop (a Panda, two cubes): a configuration that hits the
    blue cube and nothing else makes the blue cube the red cube's blocker; the action's own
    object, and a configuration that also hits what never moves, are no blockers."""
    import numpy as np

    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import TaskPlans, Transition
    from tmpc.runtime.problem import PlanningProblem

    p = PlanningProblem(tabletop_world)
    mode = p.initial
    # the blue cube also 25 cm up, in the air: configurations that hit it and nothing else
    lifted = np.array(mode.poses["blue_cube"])
    lifted[2, 3] += 0.25
    air = p.make_mode(1, mode.sym, {**mode.poses, "blue_cube": lifted}, mode.held)
    hits = _configurations(p, {"blue": lambda s: s == {"blue_cube"}}, air)
    hits |= _configurations(p, {
        "blue+static": lambda s: "blue_cube" in s and "red_cube" not in s and len(s) > 1,
        "static": lambda s: not s & {"blue_cube", "red_cube"}})
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), {})
    gp = p.ground
    pick_red = next(a for a in gp.actions if a.kinematic and "red_cube" in a.args)
    pick_blue = next(a for a in gp.actions if a.kinematic and "blue_cube" in a.args
                     and a.schema == pick_red.schema)
    tr = Transition(gp.init, pick_red, gp.init)
    tr.record_failure(mode, hits["static"], True, 0.0)        # only the bench: no blocker
    tr.record_failure(mode, hits["blue+static"], True, 0.0)   # moving blue would not free it
    assert tasks.blockers(tr) == []
    tr.record_failure(air, hits["blue"], True, 0.0)
    assert tasks.blockers(tr) == ["blue_cube"]
    tr.record_failure(mode, hits["static"], True, 0.0)        # ... the blue one stays one
    assert tasks.blockers(tr) == ["blue_cube"]
    own = Transition(gp.init, pick_blue, gp.init)
    own.record_failure(air, hits["blue"], True, 0.0)
    assert tasks.blockers(own) == []


def test_the_task_planner_option_picks_the_planner(tabletop_world):
    """`task_planner` (a manifest's [planner], `tmpc bench --param`): auto is the portfolio to a
    first solution and SAT otherwise; sat and greedy force one."""
    from tmpc.runtime.planners.decoupled import DecoupledPlanner
    from tmpc.runtime.planners.optimal import OptimalPlanner
    from tmpc.runtime.problem import PlanningProblem

    p = PlanningProblem(tabletop_world)
    kinds = {}
    for over in ({}, {"first_solution": True}, {"task_planner": "sat", "first_solution": True},
                 {"task_planner": "greedy"}):
        planner = OptimalPlanner.from_options(p, 0, over)
        kinds[str(over)] = type(planner.tasks.task_planner()).__name__
    assert list(kinds.values()) == ["TaskPlanner", "PortfolioTaskPlanner", "TaskPlanner",
                                    "PortfolioTaskPlanner"]
    dec = DecoupledPlanner.from_options(p, 0, {"task_planner": "sat"})
    assert type(dec.tasks.task_planner()) is TaskPlanner
    assert type(DecoupledPlanner.from_options(p, 0).tasks.task_planner()) is \
        PortfolioTaskPlanner


def test_an_action_rule_holds_where_its_atoms_do_until_its_objects_move():
    """An action rule rules a ground action out wherever its atoms all hold and none of its
    objects has moved, whatever came before; none given: everywhere. The portfolio excludes SAT
    plans that break one."""
    gp = _arm("(on x t2) (lit)", "x y")
    lit = next(i for i, atom in enumerate(gp.atoms) if atom.predicate == "lit")
    switch = gp.find_action("switch")
    pick, place = gp.find_action("pick", "x", "t1", "m"), gp.find_action("place", "x", "t2", "m")
    pick_y, place_y = gp.find_action("pick", "y", "t1", "m"), gp.find_action("place", "y", "t2",
                                                                                 "m")
    # placing x on t2 is ruled out where (lit) holds
    g = GreedyTaskPlanner(gp)
    assert g.add_action_rule([], place, atoms=[lit])
    assert not g.add_action_rule([], place, atoms=[lit])          # known
    assert g.violation([switch, pick, place]) == 3
    assert g.satisfies([pick, place, switch])
    r = g.next_plan(max_steps=6)
    assert r.solved and r.actions == [pick, place, switch]
    pf = PortfolioTaskPlanner(gp)
    assert pf.add_action_rule([], place, atoms=[lit])
    r = pf.next_plan(max_steps=6, horizon_cap=1.0)
    assert r.solved and pf.greedy.satisfies(r.actions) and r.actions[-1] is switch
    # picking x is ruled out until y moves: y first
    g = GreedyTaskPlanner(gp)
    assert g.add_action_rule([], pick, objects=["y"])
    r = g.next_plan(max_steps=8)
    assert r.solved and r.actions.index(pick_y) < r.actions.index(pick)
    assert g.violation([pick]) == 1 and g.satisfies([pick_y, place_y, pick, place, switch])
    # ... not a rule when y had moved where the failure was seen
    assert not GreedyTaskPlanner(gp).add_action_rule([pick_y, place_y], pick, objects=["y"])
    # neither atoms nor objects: never
    g = GreedyTaskPlanner(gp)
    assert g.add_action_rule([pick_y], place)
    assert g.next_plan(max_steps=8).status == EXHAUSTED


def _configurations(p, want: dict, mode=None, n: int = 4000):
    """Uniform configurations of ``mode`` (``p``'s initial one) by what they collide with:
    ``want`` maps a name to a test of the set of scene objects a configuration hits."""
    import numpy as np
    mode = p.initial if mode is None else mode
    found = {}
    for q in p.uniform(np.random.default_rng(0), n):
        names = frozenset(x for a, b, _ in p.collision.check(q, poses=mode.poses,
                                                            attached=mode.held).pairs
                          for x in (a, b) if x in mode.poses)
        for key, test in want.items():
            if key not in found and names and test(names):
                found[key] = q
        if len(found) == len(want):
            return found
    raise AssertionError(f"no such configurations among the samples: {set(want) - set(found)}")


def test_failures_no_movable_object_explains_become_anchors_and_state_rules(blocks_d):
    """TaskPlans.anchor_rules on Blocks World D: a grasp never reached (a real miss) is false
    until its block moves, in every plan; a placement on `c` whose attempts all hit the
    scene's fixed objects is false wherever `c` stands on its stack again; neither comes
    before RULE_FAILURES failures, nor from an attempt that hit a block. A placement never
    held in MISS_FAILURES attempts is unreached however close they came; one on a fixed
    support whose attempts all hit fixed objects is ruled out for good."""
    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import (
        MISS_FAILURES,
        RULE_FAILURES,
        TaskPlans,
        Transition,
    )

    p = blocks_d
    gp, mode = p.ground, p.initial
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), {"evidence": 0})
    greedy = tasks.task_planner().greedy
    atom = {gp.atom_name(i): i for i in range(len(gp.atoms))}
    # the file says b stands on the table, the scene on the blue tray: plans start from the
    # scene's placement (tmpc.runtime.start_atoms)
    assert sorted(tasks.support_chain(gp.init, ["d"])) == sorted(
        [atom["(on d b)"], atom["(on-surface b blue-tray)"]])
    assert tasks.support_chain(gp.init, ["table"]) == []
    hits = _configurations(p, {
        "fixed": lambda s: "table" in s and not s & {"a", "b", "c", "d"},
        "block": lambda s: "a" in s and s <= {"a", "b", "c", "d"}})
    assert tasks.collisions(mode, hits["fixed"]) == (set(), True)
    assert "a" in tasks.collisions(mode, hits["block"])[0]
    assert "a" not in tasks.collisions(mode, hits["block"], {"a"})[0]     # the action's own

    R = "r_gripper_tool_frame"
    unstack = gp.find_action("unstack", "d", "b", R)
    tr = Transition(gp.init, unstack, gp.apply(gp.init, unstack))

    def learn(tasks, plan, transitions):
        tasks.plan, tasks.plan_transitions = plan, transitions
        tasks.learn()
    for _ in range(RULE_FAILURES - 1):
        tr.record_failure(mode, p.q0, False, 0.1)
    learn(tasks, [unstack], [tr])
    assert not greedy.rules                      # one failure short
    tr.record_failure(mode, p.q0, False, 0.1)
    learn(tasks, [unstack], [tr])
    assert list(greedy.rules) == [("grasp", (R.lower(), "d"), True)]      # the literal's
    assert greedy.violation([unstack]) == 1
    assert greedy.satisfies([gp.find_action("unstack", "d", "b", "l_gripper_tool_frame")])

    # a placement of d on c: every attempt hit the table, none a block (the mode where the
    # left hand holds d: its attempts' configurations need not hold d there for this)
    import dataclasses

    import numpy as np
    pick_d = gp.find_action("unstack", "d", "b", "l_gripper_tool_frame")
    held = gp.apply(gp.init, pick_d)
    holding = dataclasses.replace(mode, held={"d": ("l_gripper_tool_frame", np.eye(4))})
    stack = gp.find_action("stack", "d", "c", "l_gripper_tool_frame")
    tr = Transition(held, stack, gp.apply(held, stack))
    for _ in range(RULE_FAILURES):
        tr.record_failure(holding, hits["fixed"], True, 0.0)
    tasks.anchor_rules([pick_d], tr)
    assert greedy.action_rules == {stack.id: [(0, 1 << atom["(on-surface c red-tray)"])]}
    assert greedy.violation([pick_d, stack]) == 2
    # ... another block among the collisions as well as the table: ruled out there until that
    # block moves
    fresh = TaskPlans(p, OptimalOptions(first_solution=True), {})
    both = _configurations(p, {"both": lambda s: "table" in s and "a" in s})["both"]
    tr.collided[-1] = (holding, both)
    fresh.anchor_rules([pick_d], tr)
    g = fresh.task_planner().greedy
    assert g.action_rules == {stack.id: [(g._object_mask(["a"]),
                                          1 << atom["(on-surface c red-tray)"])]}
    assert g.violation([pick_d, stack]) == 2
    pick_a = gp.find_action("pickup", "a", "table", "r_gripper_tool_frame")
    put_a = gp.find_action("putdown", "a", "table", "r_gripper_tool_frame")
    assert g.satisfies([pick_a, put_a, pick_d, stack])
    # ... a block alone in one attempt: nothing learnt here (a blocker, learn()'s business)
    fresh = TaskPlans(p, OptimalOptions(first_solution=True), {})
    tr.collided[-1] = (holding, hits["block"])
    fresh.anchor_rules([pick_d], tr)
    assert not fresh.task_planner().greedy.action_rules
    # a placement on a tray never reached: that action is ruled out for good, the other arm's
    # is not (the literal does not name the hand)
    put = gp.find_action("putdown", "d", "red-tray", "l_gripper_tool_frame")
    tr = Transition(held, put, gp.apply(held, put))
    for _ in range(RULE_FAILURES):
        tr.record_failure(holding, p.q0, False, 0.3)
    fresh = TaskPlans(p, OptimalOptions(first_solution=True), {})
    fresh.anchor_rules([pick_d], tr)
    g = fresh.task_planner().greedy
    assert g.action_rules == {put.id: [(0, 0)]} and not g.rules
    assert g.violation([pick_d, put]) == 2
    # ... never held, every attempt within MISS: unreached only after MISS_FAILURES of them
    near = Transition(held, put, gp.apply(held, put))
    for _ in range(MISS_FAILURES - 1):
        near.record_failure(holding, p.q0, False, 0.01)
    assert not near.unreached
    fresh = TaskPlans(p, OptimalOptions(first_solution=True), {})
    fresh.anchor_rules([pick_d], near)
    assert not fresh.task_planner().greedy.action_rules
    near.record_failure(holding, p.q0, False, 0.01)
    assert near.unreached
    fresh.anchor_rules([pick_d], near)
    assert fresh.task_planner().greedy.action_rules == {put.id: [(0, 0)]}
    # a placement on a fixed support whose attempts all hit the table: ruled out for good;
    # with a block hit as well, until that block moves
    for other, mask in ((hits["fixed"], []), (both, ["a"])):
        tr = Transition(held, put, gp.apply(held, put))
        for _ in range(RULE_FAILURES):
            tr.record_failure(holding, hits["fixed"], True, 0.0)
        tr.collided[-1] = (holding, other)
        counts: dict = {}
        fresh = TaskPlans(p, OptimalOptions(first_solution=True), counts)
        fresh.anchor_rules([pick_d], tr)
        g = fresh.task_planner().greedy
        assert g.action_rules == {put.id: [(g._object_mask(mask), 0)]}
        assert counts["fixed_rules"] == 1 and g.violation([pick_d, put]) == 2
    assert g.satisfies([pick_a, put_a, pick_d, put])


def test_an_attempt_that_hit_only_the_robot_does_not_stand_in_a_state_rules_way(blocks_d):
    """TaskPlans.fixed_only: a placement on `c` whose kept attempts all hit the table but one
    that hit nothing but the robot itself learns its state rule (that attempt says nothing
    about the movable objects); attempts that hit only the robot learn none."""
    import dataclasses

    import numpy as np

    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import RULE_FAILURES, TaskPlans, Transition

    p = blocks_d
    gp, mode = p.ground, p.initial
    atom = {gp.atom_name(i): i for i in range(len(gp.atoms))}
    pick_d = gp.find_action("unstack", "d", "b", "l_gripper_tool_frame")
    held = gp.apply(gp.init, pick_d)
    holding = dataclasses.replace(mode, held={"d": ("l_gripper_tool_frame", np.eye(4))})
    fixed = _configurations(p, {"fixed": lambda s: "table" in s and not s & {"a", "b", "c",
                                                                               "d"}},
                            holding)["fixed"]
    own = next(q for q in p.uniform(np.random.default_rng(1), 20000)
               if (pairs := p.collision.check(q, poses=holding.poses,
                                              attached=holding.held).pairs)
               and not any(x in mode.poses for a, b, _ in pairs for x in (a, b)))
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), {})
    assert tasks.collisions(holding, own) == (set(), False)
    assert tasks.collisions(holding, fixed) == (set(), True)
    stack = gp.find_action("stack", "d", "c", "l_gripper_tool_frame")
    for selves, learnt in ((1, True), (RULE_FAILURES, False)):
        tr = Transition(held, stack, gp.apply(held, stack))
        for k in range(RULE_FAILURES):
            tr.record_failure(holding, own if k >= RULE_FAILURES - selves else fixed, True, 0.0)
        counts: dict = {}
        fresh = TaskPlans(p, OptimalOptions(first_solution=True), counts)
        fresh.anchor_rules([pick_d], tr)
        rules = fresh.task_planner().greedy.action_rules
        if learnt:
            assert rules == {stack.id: [(0, 1 << atom["(on-surface c red-tray)"])]}
            assert counts["state_rules"] == 1
        else:
            assert not rules and "state_rules" not in counts


def _modes_at_places(mode, block: str, first: int, n: int, held: dict | None) -> list:
    """``n`` copies of ``mode`` (ids from 1000 + ``first``) with ``block`` moved 5 cm along x
    per place from place ``first`` on, the robot holding ``held``: attempts at ``n`` places."""
    import dataclasses

    import numpy as np
    name = next(k for k in mode.poses if k.lower() == block)
    out = []
    for k in range(first, first + n):
        T = np.array(mode.poses[name], dtype=float)
        T[0, 3] += 0.05 * k
        out.append(dataclasses.replace(mode, id=1000 + k, poses={**mode.poses, name: T},
                                       held=held))
    return out


def test_unreached_where_a_plan_put_its_anchor_holds_on_the_anchors_support_chain(blocks_d):
    """TaskPlans.anchor_rules on Blocks World D where the prefix moved the anchor (`c` taken
    up and put back on the red tray): a placement on `c` never reached at REACH_PLACES
    places of `c` is ruled out wherever `c` stands on the red tray, whatever came before (a
    reach rule; the anchor rule "until c moves" cannot hold: c moved); at fewer places
    nothing is learnt. A grasp of `c` likewise: its literal false wherever c stands there.
    The other arm's placement stays open."""
    import dataclasses

    import numpy as np

    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import (
        MISS_FAILURES,
        REACH_PLACES,
        TaskPlans,
        Transition,
    )

    p = blocks_d
    gp, mode = p.ground, p.initial
    atom = {gp.atom_name(i): i for i in range(len(gp.atoms))}
    R, L = "r_gripper_tool_frame", "l_gripper_tool_frame"
    prefix = [gp.find_action("pickup", "c", "red-tray", R),
              gp.find_action("putdown", "c", "red-tray", R),
              gp.find_action("unstack", "d", "b", L)]
    states = [gp.init]                   # the states along the prefix
    for a in prefix:
        states.append(gp.apply(states[-1], a))
    sym = states[-1]
    stack = gp.find_action("stack", "d", "c", L)

    def places(n: int) -> list:
        return _modes_at_places(mode, "c", 0, n, {"d": (L, np.eye(4))})

    def failed(action, at, n: int) -> Transition:
        tr = Transition(at, action, gp.apply(at, action))
        modes = places(n)
        for i in range(MISS_FAILURES):
            tr.record_failure(modes[i % n], p.q0, False, 0.3)
        assert tr.unreached
        return tr

    chain = 1 << atom["(on-surface c red-tray)"]
    few = TaskPlans(p, OptimalOptions(first_solution=True), {})
    few.anchor_rules(prefix, failed(stack, sym, REACH_PLACES - 1))
    g = few.task_planner().greedy
    assert not g.action_rules and not g.atom_rules
    counts: dict = {}
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), counts)
    tasks.anchor_rules(prefix, failed(stack, sym, REACH_PLACES))
    g = tasks.task_planner().greedy
    assert g.action_rules == {stack.id: [(0, chain)]} and counts["reach_rules"] == 1
    assert g.violation(prefix + [stack]) == 4
    assert g.violation([prefix[2], stack]) == 2          # c never moved: on the tray still
    assert g.satisfies(prefix[:2] + [gp.find_action("unstack", "d", "b", R),
                                     gp.find_action("stack", "d", "c", R)])
    # a grasp of c after c was put back: its literal false wherever c stands on the tray
    after = states[2]
    pick = gp.find_action("pickup", "c", "red-tray", L)
    tr = Transition(after, pick, gp.apply(after, pick))
    free = [dataclasses.replace(m, held=None) for m in places(REACH_PLACES)]
    for i in range(MISS_FAILURES):
        tr.record_failure(free[i % REACH_PLACES], p.q0, False, 0.3)
    tasks.anchor_rules(prefix[:2], tr)
    assert list(g.atom_rules.values()) == [[chain]] and counts["reach_rules"] == 2
    assert g.violation([pick]) == 1 and g.violation(prefix[:2] + [pick]) == 3
    assert g.satisfies(prefix[:2] + [gp.find_action("pickup", "c", "red-tray", R)])


def test_reach_places_add_up_over_the_states_where_the_anchors_chain_holds(blocks_d):
    """TaskPlans.anchor_rules counts an unreached action's places per support chain of its
    anchors, over symbolic states: a stack on `c` put on the red tray, tried at 2 places of
    `c` after one prefix and 2 others after another (where `a` stands elsewhere), is ruled
    out on the red tray; places on another chain (`c` on the blue tray) count apart."""
    import numpy as np

    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import (
        MISS_FAILURES,
        REACH_PLACES,
        TaskPlans,
        Transition,
    )

    p = blocks_d
    gp, mode = p.ground, p.initial
    atom = {gp.atom_name(i): i for i in range(len(gp.atoms))}
    R, L = "r_gripper_tool_frame", "l_gripper_tool_frame"
    stack = gp.find_action("stack", "d", "c", L)

    def after(*steps) -> tuple[list, int]:
        prefix = [gp.find_action(*step) for step in steps]
        sym = gp.init
        for a in prefix:
            sym = gp.apply(sym, a)
        return prefix, sym

    def failed(at: int, first: int, n: int) -> Transition:
        tr = Transition(at, stack, gp.apply(at, stack))
        modes = _modes_at_places(mode, "c", first, n, {"d": (L, np.eye(4))})
        for i in range(MISS_FAILURES):
            tr.record_failure(modes[i % n], p.q0, False, 0.3)
        assert tr.unreached and len(tr.places) == n
        return tr

    half = REACH_PLACES // 2
    red = [("pickup", "c", "red-tray", R), ("putdown", "c", "red-tray", R),
           ("unstack", "d", "b", L)]
    moved_a = [("pickup", "a", "table", R), ("putdown", "a", "blue-tray", R)]
    blue = [("pickup", "c", "red-tray", R), ("putdown", "c", "blue-tray", R),
            ("unstack", "d", "b", L)]
    counts: dict = {}
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), counts)
    g = tasks.task_planner().greedy
    first, second, other = after(*red), after(*moved_a, *red), after(*blue)
    assert first[1] != second[1]
    tasks.anchor_rules(first[0], failed(first[1], 0, half))
    tasks.anchor_rules(other[0], failed(other[1], half, REACH_PLACES - half))
    assert not g.action_rules and "reach_rules" not in counts
    tasks.anchor_rules(second[0], failed(second[1], half, REACH_PLACES - half))
    chain = 1 << atom["(on-surface c red-tray)"]
    assert g.action_rules == {stack.id: [(0, chain)]} and counts["reach_rules"] == 1
    assert g.violation(first[0] + [stack]) == len(first[0]) + 1
    assert g.violation(other[0] + [stack]) is None        # c on the blue tray: still open


def test_a_state_rule_does_not_wait_for_what_its_stack_stands_on(blocks_d):
    """TaskPlans.anchor_rules: a placement on `d` (on `b` on the blue tray) whose attempts
    all hit the table is ruled out wherever that stack stands, though they hit `b` as well
    and the plan had moved `b`: `b` cannot move while the stack holds. A block beside the
    stack that the plan moved (`c`) and the attempts hit: the rule comes only once the
    attempts were at REACH_PLACES places of `d` (over every state the stack stood in)."""
    import numpy as np

    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import (
        REACH_PLACES,
        RULE_FAILURES,
        TaskPlans,
        Transition,
    )

    p = blocks_d
    gp, mode = p.ground, p.initial
    atom = {gp.atom_name(i): i for i in range(len(gp.atoms))}
    R, L = "r_gripper_tool_frame", "l_gripper_tool_frame"
    restack = [("unstack", "d", "b", R), ("putdown", "d", "red-tray", R),
               ("pickup", "b", "blue-tray", R), ("putdown", "b", "blue-tray", R),
               ("pickup", "d", "red-tray", R), ("stack", "d", "b", R)]
    prefix = [gp.find_action(*step) for step in restack + [("pickup", "a", "table", L)]]
    sym = gp.init
    for a in prefix:
        sym = gp.apply(sym, a)
    stack = gp.find_action("stack", "a", "d", L)
    chain = (1 << atom["(on d b)"]) | (1 << atom["(on-surface b blue-tray)"])
    hits = _configurations(p, {
        "b": lambda s: "table" in s and "b" in s and not s & {"a", "c", "d"},
        "c": lambda s: "table" in s and "c" in s and not s & {"a", "b", "d"}})

    def failed(at: int, first: int, n: int, q) -> Transition:
        tr = Transition(at, stack, gp.apply(at, stack))
        modes = _modes_at_places(mode, "d", first, n, {"a": (L, np.eye(4))})
        for i in range(RULE_FAILURES):
            tr.record_failure(modes[i % n], q, True, 0.0)
        return tr

    counts: dict = {}
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), counts)
    tasks.anchor_rules(prefix, failed(sym, 0, 1, hits["b"]))
    g = tasks.task_planner().greedy
    assert g.action_rules == {stack.id: [(0, chain)]} and counts["state_rules"] == 1
    # c moved, then hit: at fewer places nothing; at REACH_PLACES of them (two transitions)
    moved_c = [gp.find_action("pickup", "c", "red-tray", R),
               gp.find_action("putdown", "c", "red-tray", R)]
    other = gp.apply(gp.apply(sym, moved_c[0]), moved_c[1])
    half = REACH_PLACES // 2
    counts = {}
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), counts)
    g = tasks.task_planner().greedy
    tasks.anchor_rules(prefix + moved_c, failed(other, 0, half, hits["c"]))
    assert not g.action_rules
    tasks.anchor_rules(moved_c + prefix, failed(other, half, REACH_PLACES - half, hits["c"]))
    assert g.action_rules == {stack.id: [(0, chain)]} and counts["state_rules"] == 1


def test_a_z3_exception_in_the_sat_planner_leaves_the_greedy_planner_to_answer():
    """Z3 raises "canceled" where an interrupt lands outside a check (a Hanoi 6 run crashed on
    one): the portfolio takes it as a timeout, asks the SAT planner no more and keeps every
    constraint in the greedy planner."""
    import z3

    gp = _arm("(on x t2)", "x y")
    pf = PortfolioTaskPlanner(gp)

    def canceled(*args, **kwargs):
        raise z3.Z3Exception("canceled")
    pf.sat.next_plan = canceled
    r = pf.next_plan(max_steps=6, horizon_cap=1.0)
    assert r.solved and pf.sat_broken and pf.answers == {"greedy": 1, "sat": 0}
    pf.sat.exclude_prefix = canceled
    pf.exclude_prefix(r.actions[:1])                      # no exception, and the greedy ...
    assert pf.next_plan(max_steps=6).actions[:1] != r.actions[:1]    # ... planner keeps it

    def other(*args, **kwargs):
        raise ValueError("a bug")
    pf = PortfolioTaskPlanner(gp)
    pf.sat.next_plan = other
    with pytest.raises(ValueError):
        pf.next_plan(max_steps=6, horizon_cap=1.0)


def test_an_atom_rule_makes_a_literal_false_wherever_its_atoms_hold():
    """An atom rule: the literal is false wherever its atoms all hold, whatever came before (a
    blocker put back where it stood blocks again); the portfolio excludes SAT plans that
    break one."""
    gp = _arm("(on x t2)", "x y")
    at = GeoLiteral("at", ("m", "x"), True)
    y_on_t1 = next(i for i, atom in enumerate(gp.atoms) if gp.atom_name(i) == "(on y t1)")
    pick, place = gp.find_action("pick", "x", "t1", "m"), gp.find_action("place", "x", "t2", "m")
    pick_y = gp.find_action("pick", "y", "t1", "m")
    y_back, y_away = gp.find_action("place", "y", "t1", "m"), gp.find_action("place", "y", "t2",
                                                                            "m")
    g = GreedyTaskPlanner(gp)
    assert not g.add_atom_rule(at, [])                       # no atoms: no rule
    assert g.add_atom_rule(at, [y_on_t1])
    assert not g.add_atom_rule(at, [y_on_t1])                # known
    assert not g.add_atom_rule(GeoLiteral("nowhere", ("m",), True), [y_on_t1])   # unused
    assert g.moved([pick_y, y_back]) == {"y"} and g.moved([]) == set()
    # moved and put back: y blocks again; moved away: x may go
    assert g.violation([pick]) == 1
    assert g.violation([pick_y, y_back, pick]) == 3
    assert g.satisfies([pick_y, y_away, pick, place])
    r = g.next_plan(max_steps=8)
    assert r.solved and simulate(gp, r.actions)[0] and y_away in r.actions
    assert r.actions.index(y_away) < r.actions.index(pick)
    pf = PortfolioTaskPlanner(gp)
    assert pf.add_atom_rule(at, [y_on_t1]) and pf.moved([pick_y]) == {"y"}
    r = pf.next_plan(max_steps=8, horizon_cap=1.0)
    assert r.solved and pf.greedy.satisfies(r.actions) and y_away in r.actions


def test_a_blocker_put_back_where_it_stood_blocks_there_again(blocks_d):
    """TaskPlans.put_back on Blocks World D: blockers that stand where they stood at the start
    (their placement atoms, their positions within PUT_BACK), one of them having moved in the
    prefix, give the atoms of their support chains; none moved, one elsewhere or 2 cm off:
    none. learn() turns the first into an atom rule on the literal."""
    import numpy as np

    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import PUT_BACK, TaskPlans, Transition

    p = blocks_d
    gp, mode = p.ground, p.initial
    R = "r_gripper_tool_frame"
    # c starts on the red tray (the scene's placement: tmpc.runtime.start_atoms)
    pick_c = gp.find_action("pickup", "c", "red-tray", R)
    back, away = (gp.find_action("putdown", "c", s, R) for s in ("red-tray", "table"))
    unstack = gp.find_action("unstack", "d", "b", R)
    atom = {gp.atom_name(i): i for i in range(len(gp.atoms))}

    def attempt(prefix, shift=0.0):
        sym = gp.init
        for a in prefix:
            sym = gp.apply(sym, a)
        poses = dict(mode.poses)
        c = np.array(poses["c"])
        c[0, 3] += shift
        poses["c"] = c
        tr = Transition(sym, unstack, gp.apply(sym, unstack))
        tr.record_failure(p.make_mode(1, sym, poses, mode.held), p.q0, True, 0.0)
        return tr

    tasks = TaskPlans(p, OptimalOptions(first_solution=True), {"evidence": 0})
    assert tasks.put_back([pick_c, back], attempt([pick_c, back]), ["c"]) == \
        [atom["(on-surface c red-tray)"]]
    assert tasks.put_back([pick_c, back], attempt([pick_c, back], PUT_BACK / 2), ["c"])
    assert tasks.put_back([pick_c, back], attempt([pick_c, back], 0.02), ["c"]) == []
    assert tasks.put_back([], attempt([]), ["c"]) == []                    # never moved
    # with a blocker that never moved (d stands where it stood): both chains
    assert sorted(tasks.put_back([pick_c, back], attempt([pick_c, back]), ["c", "d"])) == \
        sorted([atom["(on-surface c red-tray)"], atom["(on d b)"],
                atom["(on-surface b blue-tray)"]])
    assert tasks.put_back([pick_c, away], attempt([pick_c, away]), ["c"]) == []  # elsewhere
    # learn(): the attempt hit c alone, after c went back where it stood
    tr = attempt([pick_c, back])
    tr.collided.clear()
    hit = _configurations(p, {"c": lambda s: s == {"c"}})["c"]
    tr.collided.append((p.make_mode(1, tr.sym, mode.poses, mode.held), hit))
    tasks.plan, tasks.plan_transitions = [pick_c, back, unstack], [
        Transition(gp.init, pick_c, gp.apply(gp.init, pick_c), successes=1),
        Transition(gp.apply(gp.init, pick_c), back, tr.sym, successes=1), tr]
    tasks.learn()
    greedy = tasks.task_planner().greedy
    assert tasks.counts.get("put_back") and ("grasp", (R.lower(), "d"), True) in \
        greedy.atom_rules
    assert greedy.violation([pick_c, back, unstack]) == 3
    assert greedy.violation([pick_c, away, unstack]) is None


def test_a_plan_stuck_where_its_arm_cannot_reach_is_hopeless(blocks_d):
    """TaskPlans.hopeless: the current plan's first transition without a success failed
    RULE_FAILURES times, never held and never within MISS, ends the plan (what its anchor
    rule will say); one failure fewer, a collided attempt, a near miss or a success: not."""
    from tmpc.runtime.planners.optimal import OptimalOptions
    from tmpc.runtime.planners.optimal.tasks import MISS, RULE_FAILURES, TaskPlans, Transition

    p = blocks_d
    gp, mode = p.ground, p.initial
    L, R = "l_gripper_tool_frame", "r_gripper_tool_frame"
    first = gp.find_action("unstack", "d", "b", L)
    put = gp.find_action("putdown", "d", "table", L)
    after = gp.apply(gp.init, first)

    def plan(failures, held=False, distance=0.3, successes=0):
        tasks = TaskPlans(p, OptimalOptions(first_solution=True), {"evidence": 0})
        tasks.task_planner()
        tr = Transition(after, put, gp.apply(after, put))
        for _ in range(failures):
            tr.record_failure(mode, p.q0, held, distance)
        tr.successes = successes
        tasks.plan = [first, put]
        tasks.plan_transitions = [Transition(gp.init, first, after, successes=1), tr]
        return tasks

    assert plan(RULE_FAILURES).hopeless()
    assert not plan(RULE_FAILURES - 1).hopeless()
    assert not plan(RULE_FAILURES, held=True).hopeless()           # collided: geometry reached
    assert not plan(RULE_FAILURES, distance=MISS / 2).hopeless()   # a projection run short
    assert not plan(RULE_FAILURES, successes=1).hopeless()
    # close attempts make a transition unreached for the rules after MISS_FAILURES of them,
    # but never end its plan: more batches may get there (Blocks World D v8 planned from
    # 8,107 vertices in 7 s, and from 18,686 in 30 s when this ended its second plan)
    from tmpc.runtime.planners.optimal.tasks import MISS_FAILURES
    near = plan(10 * MISS_FAILURES, distance=MISS / 2)
    assert near.plan_transitions[-1].unreached and not near.hopeless()
    # a placement on c whose kept attempts all hit the table: from FIXED_FAILURES on
    import dataclasses

    import numpy as np

    from tmpc.runtime.planners.optimal.tasks import FIXED_FAILURES
    hits = _configurations(p, {"fixed": lambda s: "table" in s and not s & {"a", "b", "c", "d"},
                               "block": lambda s: "a" in s and s <= {"a", "b", "c", "d"}})
    holding = dataclasses.replace(mode, held={"d": (L, np.eye(4))})
    stack = gp.find_action("stack", "d", "c", L)

    def stacking(failures, q):
        tasks = TaskPlans(p, OptimalOptions(first_solution=True), {"evidence": 0})
        tasks.task_planner()
        tr = Transition(after, stack, gp.apply(after, stack))
        for _ in range(failures):
            tr.record_failure(holding, q, True, 0.0)
        tasks.plan = [first, stack]
        tasks.plan_transitions = [Transition(gp.init, first, after, successes=1), tr]
        return tasks
    assert stacking(FIXED_FAILURES, hits["fixed"]).hopeless()
    assert not stacking(FIXED_FAILURES - 1, hits["fixed"]).hopeless()
    assert not stacking(FIXED_FAILURES, hits["block"]).hopeless()     # a block: a blocker
    # failures that no rule explains do not end the plan, however many: rare configurations
    # (the kitchen's cabbage behind its radish) still come
    assert not stacking(10 * FIXED_FAILURES, hits["block"]).hopeless()
    stuck = plan(RULE_FAILURES)
    stuck.plan = None                                               # no plan (exhausted)
    assert not stuck.hopeless()
    # the right arm: the same failures at the first step
    tasks = TaskPlans(p, OptimalOptions(first_solution=True), {"evidence": 0})
    tasks.task_planner()
    r = gp.find_action("unstack", "d", "b", R)
    tr = Transition(gp.init, r, gp.apply(gp.init, r))
    for _ in range(RULE_FAILURES):
        tr.record_failure(mode, p.q0, False, 0.2)
    tasks.plan, tasks.plan_transitions = [r], [tr]
    assert tasks.hopeless()


BLOCKS = """(define (domain bw) (:requirements :strips)
  (:predicates (on ?x ?y) (ontable ?x) (clear ?x) (holding ?x) (empty))
  (:action pickup :parameters (?x) :precondition (and (clear ?x) (ontable ?x) (empty))
    :effect (and (holding ?x) (not (ontable ?x)) (not (clear ?x)) (not (empty))))
  (:action putdown :parameters (?x) :precondition (holding ?x)
    :effect (and (ontable ?x) (clear ?x) (empty) (not (holding ?x))))
  (:action stack :parameters (?x ?y) :precondition (and (holding ?x) (clear ?y))
    :effect (and (on ?x ?y) (clear ?x) (empty) (not (holding ?x)) (not (clear ?y))))
  (:action unstack :parameters (?x ?y) :precondition (and (on ?x ?y) (clear ?x) (empty))
    :effect (and (holding ?x) (clear ?y) (not (on ?x ?y)) (not (clear ?x))
                 (not (empty)))))"""


def _towers(rng: random.Random, blocks: list[str]) -> list[str]:
    towers: list[list[str]] = []
    for b in rng.sample(blocks, len(blocks)):
        if towers and rng.random() < 0.6:
            rng.choice(towers).append(b)
        else:
            towers.append([b])
    facts = []
    for t in towers:
        facts += [f"(ontable {t[0]})", f"(clear {t[-1]})"]
        facts += [f"(on {above} {below})" for below, above in itertools.pairwise(t)]
    return facts


def test_weighted_search_shortens_greedy_plans():
    """Random six-block problems: the weighted search's plan replays, is never longer than the
    greedy one nor shorter than breadth-first search's, and shortens some (seed 8: 14 steps
    to the optimal 10)."""
    shortened = 0
    for seed in range(12):
        rng = random.Random(seed)
        blocks = list("abcdef")
        init = _towers(rng, blocks) + ["(empty)"]
        goal = [f for f in _towers(rng, blocks) if not f.startswith("(clear")]
        gp = _ground(BLOCKS, f"(define (problem p) (:domain bw) (:objects {' '.join(blocks)}) "
                             f"(:init {' '.join(init)}) (:goal (and {' '.join(goal)})))")
        greedy = GreedyTaskPlanner(gp).next_plan(max_steps=40)
        planner = GreedyTaskPlanner(gp, weight=2.0)
        weighted = planner.next_plan(max_steps=40)
        assert greedy.status == weighted.status == SOLVED
        assert simulate(gp, weighted.actions)[0]
        assert bfs_length(gp) <= len(weighted.actions) <= len(greedy.actions)
        shortened += planner.shortened
        assert planner.shortened == (len(weighted.actions) < len(greedy.actions))
    assert shortened >= 1


@pytest.mark.parametrize("seed", range(8))
def test_indexed_successors_are_every_applicable_action(seed):
    """The search visits only the actions whose indexing atom holds: along a random walk,
    those that pass the discrete test are exactly the actions applicable there."""
    rng = random.Random(seed)
    gp = random_problem(seed)
    g = GreedyTaskPlanner(gp)
    state = gp.init
    for _ in range(12):
        found = [a.id for a, pos, neg, extra in g._candidates(state)
                 if state & pos == pos and not state & neg and
                 (not extra or a.pre.holds(state))]
        assert found == [a.id for a in gp.actions if a.pre.holds(state)]
        moves = [a for a, _ in gp.successors(state)]
        if not moves:
            break
        state = gp.apply(state, rng.choice(moves))


def test_the_sat_planner_holds_the_greedy_planners_rules():
    """Blocker, atom and action rules encoded in the SAT planner (every layer, encoded or to
    come): its shortest plan keeps them, so the portfolio takes it without asking again."""
    gp = _arm("(on x t2)", "x y z")
    at_x = GeoLiteral("at", ("m", "x"), True)
    pick = {s: gp.find_action("pick", s, "t1", "m") for s in "xyz"}
    # a blocker rule added before any horizon is encoded: x's grasp is false until y moves
    sat = TaskPlanner(gp, geometric=True)
    assert sat.add_blocker_rule(at_x, ["Y"]) and not sat.add_blocker_rule(at_x, ["y"])
    assert not sat.add_blocker_rule(at_x, ["t1"])             # never moved: no rule
    r = sat.next_plan(max_steps=10)
    assert r.solved and len(r.actions) == 4 and simulate(gp, r.actions)[0]
    assert r.actions.index(pick["y"]) < r.actions.index(pick["x"])
    # ... and added once horizons are encoded (the same plan, now excluded)
    sat = TaskPlanner(gp, geometric=True)
    assert sat.next_plan(max_steps=10).actions == [pick["x"], gp.find_action("place", "x",
                                                                             "t2", "m")]
    assert sat.add_blocker_rule(at_x, ["y"])
    r = sat.next_plan(max_steps=10)
    assert r.solved and r.actions.index(pick["y"]) < r.actions.index(pick["x"])
    # an atom rule: x's grasp is false wherever y stands on t1 (moved and put back: again)
    gp2 = _arm("(on x t2)", "x y")
    y_on_t1 = next(i for i in range(len(gp2.atoms)) if gp2.atom_name(i) == "(on y t1)")
    y_away = gp2.find_action("place", "y", "t2", "m")
    sat = TaskPlanner(gp2, geometric=True)
    sat.next_plan(max_steps=3)
    assert sat.add_atom_rule(at_x, [y_on_t1]) and not sat.add_atom_rule(at_x, [y_on_t1])
    r = sat.next_plan(max_steps=8)
    assert r.solved and y_away in r.actions and len(r.actions) == 4
    # action rules: placing x on t2 is ruled out where (lit) holds; picking x until y moves
    gp3 = _arm("(on x t2) (lit)", "x y")
    lit = next(i for i, atom in enumerate(gp3.atoms) if atom.predicate == "lit")
    place, switch = gp3.find_action("place", "x", "t2", "m"), gp3.find_action("switch")
    sat = TaskPlanner(gp3, geometric=True)
    assert sat.add_action_rule([], place, atoms=[lit])
    assert not sat.add_action_rule([], place, atoms=[lit])               # known
    r = sat.next_plan(max_steps=8)
    assert r.solved and r.actions[-1] is switch and len(r.actions) == 3
    pick_x, pick_y = gp3.find_action("pick", "x", "t1", "m"), gp3.find_action("pick", "y", "t1",
                                                                             "m")
    assert not sat.add_action_rule([pick_y], pick_x, objects=["y"])       # y moved there
    assert sat.add_action_rule([], pick_x, objects=["y"])
    r = sat.next_plan(max_steps=8)
    assert r.solved and len(r.actions) == 5 and r.actions[0].args[0] == "y"
    assert simulate(gp3, r.actions)[0] and sat.rules == 2


def _random_rules(rng: random.Random, gp, planners, n: int) -> None:
    """``n`` random rules of the three kinds, from the initial state, to every planner."""
    lits = [GeoLiteral("at", ("m", s), True) for s in ("x", "y")] + \
        [GeoLiteral("above", ("m", t), True) for t in ("t1", "t2")]
    atoms = [i for i in range(len(gp.atoms)) if gp.atoms[i].predicate in ("on", "lit")]
    for _ in range(n):
        kind, lit = rng.choice(("blocker", "atom", "action")), rng.choice(lits)
        objs = rng.sample(["x", "y"], rng.randint(0, 2))
        some = rng.sample(atoms, rng.randint(1, 2))
        action = gp.actions[rng.randrange(len(gp.actions))]
        with_atoms = rng.random() < 0.5
        for pl in planners:
            if kind == "blocker" and objs:
                pl.add_evidence([], lit, False, blockers=objs)
            elif kind == "atom":
                pl.add_atom_rule(lit, some)
            elif kind == "action":
                pl.add_action_rule([], action, objs, some if with_atoms else ())


@pytest.mark.parametrize("seed", range(30))
def test_sat_plans_keep_random_rules(seed):
    """Against the greedy planner (complete under its constraints): the same problems have a
    plan under the same random rules, the portfolio's SAT planner is never asked again for a
    plan breaking one, and no greedy plan is shorter than its shortest."""
    rng = random.Random(seed)
    gp = _arm("(on x t2) (on y t2)" if seed % 2 else "(on x t2) (lit)", "x y")
    pf, greedy = PortfolioTaskPlanner(gp), GreedyTaskPlanner(gp)
    _random_rules(rng, gp, (pf, greedy), rng.randint(1, 6))
    a, b = pf.next_plan(max_steps=10, horizon_cap=5.0), greedy.next_plan(max_steps=10)
    assert (a.status == SOLVED) == (b.status == SOLVED), (a.status, b.status)
    if a.status == SOLVED:
        assert pf.rejected == 0 and pf.answers["sat"] == 1
        assert greedy.satisfies(a.actions) and len(a.actions) <= len(b.actions)


def test_where_evidence_beats_a_rule_the_greedy_planner_answers():
    """Evidence from a plan's own prefix beats a rule in the greedy planner; in the SAT
    planner the two contradict, so its "no plan" is not the portfolio's answer."""
    gp = _arm("(on x t2)", "x y")
    at_x = GeoLiteral("at", ("m", "x"), True)
    pf = PortfolioTaskPlanner(gp)
    pf.add_evidence([], at_x, False, blockers=["y"])          # a blocker rule: y first
    pf.add_evidence([], at_x, True)                           # ... but x's grasp held here
    assert pf.sat.rules == 1
    assert pf.sat.next_plan(max_steps=6).status == EXHAUSTED
    r = pf.next_plan(max_steps=6, horizon_cap=1.0)
    assert r.solved and [a.schema for a in r.actions] == ["pick", "place"]
    assert pf.answers == {"greedy": 1, "sat": 0} and not pf.sat_stalled


def test_a_greedy_search_past_its_budget_asks_the_stalled_sat_planner_again():
    """Once the SAT planner is stalled (a slow check on a loaded machine), a greedy search
    that runs past ``greedy_budget`` expansions asks it once more: Blocks World I v2's greedy
    search ran 250 s of a 300 s run where the SAT planner answers in a second. Its plan keeps
    the greedy planner's constraints, and the SAT planner, answering, is asked first again;
    with the retry off the greedy search answers."""
    gp = _arm("(on x t2) (on y t2)", "x y z")
    pf = PortfolioTaskPlanner(gp, greedy_budget=1)
    pf.sat_stalled = True
    pf.add_evidence([], GeoLiteral("at", ("m", "x"), True), False, blockers=["z"])
    r = pf.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and pf.retries == 1 and pf.answers == {"greedy": 0, "sat": 1}
    assert pf.greedy.satisfies(r.actions) and len(r.actions) == 6 and not pf.sat_stalled
    pf.exclude_prefix(r.actions[:1])
    r = pf.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and pf.retries == 1 and pf.answers == {"greedy": 0, "sat": 2}
    # stalled again, within its budget the greedy search answers
    pf.sat_stalled, pf._retry_at = True, 10 ** 6
    r = pf.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and pf.retries == 1 and pf.answers == {"greedy": 1, "sat": 2}
    off = PortfolioTaskPlanner(gp, greedy_budget=1, retry_budget=0)
    off.sat_stalled = True
    r = off.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and off.retries == 0 and off.answers == {"greedy": 1, "sat": 0}
    # a retry without an answer leaves the SAT planner stalled and the greedy search on
    slow = PortfolioTaskPlanner(gp, greedy_budget=1)
    slow.sat_stalled = True
    slow.sat.next_plan = lambda *args, **kwargs: PlanResult(TIMEOUT, None, 0)
    r = slow.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and slow.retries == 1 and slow.sat_stalled
    assert slow.answers == {"greedy": 1, "sat": 0}
    # ... and the greedy search's budget 4 times larger: within 4 expansions it answers
    # the next time without asking the SAT planner (with 1 it would ask again)
    assert slow._retry_at == 4
    slow.exclude_prefix(r.actions[:1])
    r = slow.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and slow.retries == 1 and slow.answers == {"greedy": 2, "sat": 0}
    slow._retry_at = 1
    r = slow.next_plan(max_steps=12, horizon_cap=1.0)
    assert r.solved and slow.retries == 2 and slow._retry_at == 4
