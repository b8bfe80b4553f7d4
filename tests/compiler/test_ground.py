"""Grounding: checked programs -> GroundProblem, checked by simulation against a naive reference."""

from __future__ import annotations

import time
from collections import deque
from pathlib import Path

import pytest

from tests.ground_reference import Reference
from tests.support import EXAMPLES, FIXTURES, check
from tmpc.compiler.ground import GroundingError, bits, ground
from tmpc.lang.program import Workspace, check_parsed, load_checked
from tmpc.lang.source import SourceFile


def _problems(group: str) -> list[tuple[Path, Path]]:
    out = []
    for dom in sorted((FIXTURES / group).rglob("domain.pddl")):
        out += [(dom, p) for p in sorted(dom.parent.glob("*.pddl")) if p.name != "domain.pddl"]
    return out


def _examples() -> list[tuple[Path, Path]]:
    return [(d / "domain.pddl", p) for d in sorted(EXAMPLES.iterdir())
            if (d / "domain.pddl").is_file()
            for p in sorted(d.glob("*.pddl")) if p.name != "domain.pddl"]


CLASSICAL = _problems("classical")
SYMBOLIC = _problems("tmpc") + _problems("legacy") + _examples()


def _id(pair) -> str:
    return f"{pair[0].parent.name}/{pair[1].stem}"


def _load(text: str, *more: str):
    ws = Workspace()
    parsed = [ws.add_source(SourceFile(f"f{i}.pddl", t)) for i, t in enumerate((text, *more))]
    report = check_parsed(ws, parsed)
    assert report.ok, report.diagnostics
    return report.programs[0]


def bfs(gp, max_states: int = 50_000):
    """Breadth-first search with the grounder's own applicable/apply (geometry optimistic)."""
    parent = {gp.init: None}
    queue = deque([gp.init])
    while queue and len(parent) <= max_states:
        s = queue.popleft()
        if gp.goal_satisfied(s):
            plan = []
            while parent[s] is not None:
                s, a = parent[s]
                plan.append(a)
            return plan[::-1]
        for a, t in gp.successors(s):
            if t not in parent:
                parent[t] = (s, a)
                queue.append(t)
    return None


def _key(a) -> tuple[str, tuple[str, ...]]:
    return a.schema.lower(), tuple(x.lower() for x in a.args)


def _replay(gp, plan) -> int:
    s = gp.init
    for a in plan:
        assert gp.applicable(s, a), a.name
        s = gp.apply(s, a)
    assert gp.goal_satisfied(s)
    return s


# ---- plans by simulation ------------------------------------------------------------------------


@pytest.mark.parametrize("pair", CLASSICAL + SYMBOLIC, ids=_id)
def test_bfs_finds_a_plan_that_replays(pair):
    prog = load_checked(list(pair))
    gp = ground(prog)
    plan = bfs(gp)
    assert plan is not None, f"no plan for {_id(pair)}"
    _replay(gp, plan)
    assert Reference(prog).replay([_key(a) for a in plan]), "the reference rejects the plan"
    assert gp.goal_relaxed_reachable


@pytest.mark.parametrize("pair", [p for p in SYMBOLIC if p[0].parent.name != "blocksworld"],
                         ids=_id)
def test_kinematic_effects_follow_kinematic_atoms(pair):
    gp = ground(load_checked(list(pair)))
    kinds = {a.kind for a in gp.atoms}
    assert "kinematic" in kinds and gp.geometric
    for a in gp.actions:
        links = {k.atom for k in a.kinematic if k.op == "link"}
        unlinks = {k.atom for k in a.kinematic if k.op == "unlink"}
        assert links == {i for i in a.adds if gp.atoms[i].kind == "kinematic"}
        assert unlinks == {i for i in a.dels if gp.atoms[i].kind == "kinematic"}
        for k in a.kinematic:
            assert {k.parent, k.child} <= set(gp.atoms[k.atom].args)


NAIVE = ["kitchen-adl/p01", "lab-inspection/p01", "lamp-grid/p02", "tower-derived/p01",
         "seating-equality/p01", "office-courier/p01", "power-grid/p01", "lift-forall/p01",
         "rover-costs/p02", "morning-zero-arity/p02", "parcel-untyped/p01"]


def _ref_state(gp, facts) -> int:
    out = 0
    for pred, args in facts:
        if (pred, args) in gp.static_facts:
            continue
        i = gp.atom_id(pred, *args)
        assert i is not None, f"reachable fact ({pred} {' '.join(args)}) has no atom id"
        out |= 1 << i
    return out


@pytest.mark.parametrize("name", NAIVE)
def test_agrees_with_naive_reference(name):
    pair = next(p for p in CLASSICAL if _id(p) == name)
    prog = load_checked(list(pair))
    gp, ref = ground(prog), Reference(prog)
    naive = {n for _, _, n in ref.actions()}
    mine = {_key(a) for a in gp.actions}
    assert mine <= naive
    for a in gp.atoms:     # every atom is type-correct for its predicate
        decl = prog.scope.predicates[a.predicate.lower()]
        for obj, p in zip(a.args, decl.params):
            assert obj.lower() in ref.objects_of(p)
    plan, used, explored = ref.bfs(max_states=3000)
    assert plan is not None and len(explored) < 3000
    assert set(plan) <= mine and used <= mine, "pruning removed a usable action"
    by_key = {_key(a): a for a in gp.actions}
    acts = {a.name.key: a for a in prog.domain.actions}
    for facts in explored:      # the whole reachable state space of these small problems
        s = _ref_state(gp, facts)
        assert gp.evaluate_derived(s) == s
        app = {_key(a) for a in gp.actions if gp.applicable(s, a)}
        ref_app = set()
        for k in mine | used:
            act = acts[k[0]]
            env = dict(zip((p.name.key for p in act.params), k[1]))
            if ref.holds(act.precondition, env, facts):
                ref_app.add(k)
                env_next = ref.apply(act, env, facts)
                assert gp.apply(s, by_key[k]) == _ref_state(gp, env_next), k
        assert app == ref_app


# ---- structure ----------------------------------------------------------------------------------


def test_clutter_14_plus_14_red():
    from tmpc.lang.world.generate import clutter_problem
    prog = _load((EXAMPLES / "clutter" / "domain.pddl").read_text(), clutter_problem(14, True))
    t0 = time.perf_counter()
    gp = ground(prog)
    dt = time.perf_counter() - t0
    print(f"\nclutter 14+14: {len(gp.objects)} objects, {len(gp.atoms)} atoms, "
          f"{len(gp.actions)} actions, {len(gp.geometric)} geometric atoms, {dt:.3f} s")
    # 28 sticks x 4 tables x 2 arms: on-surface 112, holding 56, arm-empty 2
    assert (len(gp.atoms), len(gp.actions)) == (170, 448)
    assert gp.stats.bindings_considered == 448
    pick = gp.find_action("pickup", "blue_stick_1", "table1", "l_gripper_tool_frame")
    assert {gp.atom_name(i) for i in pick.pre_pos} == {
        "(on-surface blue_stick_1 table1)", "(arm-empty l_gripper_tool_frame)"}
    assert pick.pre_geometric == (("at", ("l_gripper_tool_frame", "blue_stick_1"), True),)
    assert [(k.op, k.parent, k.child) for k in pick.kinematic] == [
        ("link", "l_gripper_tool_frame", "blue_stick_1")]
    put = gp.find_action("putdown", "blue_stick_1", "table3", "l_gripper_tool_frame")
    assert [k.op for k in put.kinematic] == ["unlink"]
    assert pick.pre.is_conjunctive and pick.cost == 1.0


def test_geometry_oracle_decides_geometric_literals():
    gp = ground(load_checked([EXAMPLES / "tabletop/domain.pddl", EXAMPLES / "tabletop/problem.pddl"]))
    pick = gp.find_action("pick", "panda_hand_tcp", "red_cube", "bench")
    assert pick.pre_geometric == (("reach", ("panda_hand_tcp", "red_cube"), True),)
    assert gp.applicable(gp.init, pick)                          # geometry possibly true
    assert not gp.applicable(gp.init, pick, geo=lambda p, args: False)
    seen = []
    assert gp.applicable(gp.init, pick, geo=lambda p, args: seen.append((p, args)) or True)
    assert seen == [("reach", ("panda_hand_tcp", "red_cube"))]
    assert {(g.predicate, g.args) for g in gp.geometric} >= {("reach", ("panda_hand_tcp", "red_cube"))}


def test_unreachable_goal_atoms_are_kept_and_reported():
    gp = ground(_load("""(define (domain d) (:predicates (p) (q) (r) (s))
      (:action a :parameters () :precondition (p) :effect (q))
      (:action b :parameters () :precondition (s) :effect (r)))
    (define (problem x) (:domain d) (:init (p)) (:goal (and (q) (r))))"""))
    assert not gp.goal_relaxed_reachable and [a.name for a in gp.actions] == ["(a)"]
    assert gp.atom_id("r") is not None and gp.atom_id("r") in gp.goal.pos
    assert bfs(gp) is None


def test_problem_without_actions_or_init():
    gp = ground(_load("""(define (domain d) (:predicates (p ?x)) (:action a :parameters (?x)
      :precondition (p ?x) :effect (not (p ?x))))
    (define (problem x) (:domain d) (:objects k) (:init) (:goal (p k)))"""))
    assert gp.actions == () and gp.init == 0 and gp.atom_id("p", "k") == 0
    assert not gp.goal_satisfied(gp.init) and not gp.goal_relaxed_reachable


def test_atom_names_keep_spelling_and_lookup_ignores_case():
    gp = ground(load_checked([FIXTURES / "classical/office-courier/domain.pddl",
                              FIXTURES / "classical/office-courier/p01.pddl"]))
    i = gp.atom_id("AT", "r2UNIT", "CHARGING_DOCK")
    assert gp.atom_name(i) == "(at R2unit charging_Dock)"
    assert gp.state(["(at R2unit charging_Dock)"]) == 1 << i
    assert list(bits(gp.init)) == sorted(bits(gp.init))


def test_types_with_either_and_multiple_parents():
    prog = _load("""(define (domain t) (:requirements :typing)
      (:types car boat - vehicle amphibian - car amphibian - boat)
      (:predicates (wet ?x - (either boat place)) (p ?x - vehicle))
      (:action dip :parameters (?x - (either boat place)) :precondition (p ?x) :effect (wet ?x)))
    (define (problem q) (:domain t) (:objects duck - amphibian c - car place1 - place)
      (:init (p duck) (p c)) (:goal (wet duck)))""")
    gp = ground(prog)
    types = {o.name: o.types for o in gp.objects}
    assert types["duck"] == {"amphibian", "car", "boat", "vehicle", "object"}
    assert {a.name for a in gp.actions} == {"(dip duck)"}   # place1 typed but `p` never holds
    assert "(wet duck)" in {str(a) for a in gp.atoms}


def test_static_predicates_pruned_and_failing_bindings_dropped():
    gp = ground(load_checked([FIXTURES / "classical/parcel-untyped/domain.pddl",
                              FIXTURES / "classical/parcel-untyped/p02.pddl"]))
    assert {a.predicate for a in gp.atoms} == {"at", "loaded"}
    assert ("van", ("vanone",)) in gp.static_facts
    drives = [a for a in gp.actions if a.schema == "drive"]
    assert drives and all(a.args[0].lower().startswith("van") for a in drives)
    # untyped: 8^3 = 512 bindings per schema, but the join on static facts and reached atoms
    # builds only 2 vans x 3 depots x 3 (depots or parcels) per schema: nothing is thrown away
    assert len(gp.objects) == 8
    assert gp.stats.bindings_considered == len(gp.actions) == 3 * 18


def test_conditional_effects_read_the_state_before_the_action():
    gp = ground(load_checked([FIXTURES / "classical/lamp-grid/domain.pddl",
                              FIXTURES / "classical/lamp-grid/p02.pddl"]))
    press = gp.find_action("press", "north")
    assert press.conditional and not press.adds
    after = gp.apply(gp.init, press)
    assert set(gp.state_atoms(after)) == {"(lit east)", "(lit south)", "(lit west)"}


def test_static_atoms_decide_imply_and_exists_while_grounding():
    gp = ground(load_checked([FIXTURES / "classical/kitchen-adl/domain.pddl",
                              FIXTURES / "classical/kitchen-adl/p01.pddl"]))
    # (imply (needs-liquid ?i) (exists (?p - pot) (and (= ?p ?c) (has-water ?p)))):
    # needs-liquid is static, `=` is decided, so no disjunction is left
    stir = gp.find_action("stir", "noodles", "stockPot", "wooden_spoon")
    assert stir.pre.is_conjunctive and gp.atom_id("has-water", "stockPot") in stir.pre_pos
    assert gp.find_action("stir", "noodles", "skillet", "wooden_spoon") is None
    egg = gp.find_action("stir", "egg", "skillet", "wooden_spoon")
    assert gp.atom_id("has-water", "stockPot") not in egg.pre_pos


def test_add_wins_over_delete_also_for_conditional_effects():
    gp = ground(_load("""(define (domain d) (:requirements :adl) (:predicates (p) (q) (r))
      (:action a :parameters () :precondition (q)
        :effect (and (p) (when (q) (and (not (p)) (r))) (not (r)))))
    (define (problem x) (:domain d) (:init (q)) (:goal (and (p) (r))))"""))
    a = gp.actions[0]
    s = gp.apply(gp.init, a)
    assert gp.goal_satisfied(s) and not a.dels


def test_disjunctive_precondition_keeps_a_formula_and_a_dnf():
    gp = ground(load_checked([FIXTURES / "classical/lab-inspection/domain.pddl",
                              FIXTURES / "classical/lab-inspection/p01.pddl"]))
    certs = [a for a in gp.actions if a.schema == "certify" and not a.pre.is_conjunctive]
    assert certs
    pre = certs[0].pre
    dnf = pre.dnf()
    assert len(dnf) > 1
    for pos, neg, geo in dnf:    # each disjunct implies the formula
        assert pre.holds(sum(1 << i for i in pos))


def test_derived_axioms_and_costs():
    gp = ground(load_checked([FIXTURES / "classical/power-grid/domain.pddl",
                              FIXTURES / "classical/power-grid/p01.pddl"]))
    powered = {gp.atom_name(i) for i in bits(gp.init) if gp.atoms[i].kind == "derived"}
    assert powered == {"(powered plant)"}
    assert gp.uses_costs
    assert gp.find_action("travel", "crew1", "plant", "sub_A").cost == 10
    close = gp.find_action("close-breaker", "crew1", "plant", "sub_A")
    s = gp.apply(gp.init, close)
    assert gp.atom_id("powered", "sub_A") in set(bits(s))
    assert close.cost == 0


def test_legacy_facts_with_undeclared_objects_are_dropped():
    dom = (FIXTURES / "legacy/tmit-star/bin-picking/domain.pddl").read_text()
    prog = _load(dom, """(define (problem p) (:domain binpicking)
      (:objects b1 b2 -bin m -manipulator x -objs)
      (:init (in-bin x b1) (in-bin ghost b2) (gripper-empty m))
      (:goal (in-bin x b2)))""")
    assert "W015" in [d.code for d in prog.diagnostics]
    gp = ground(prog)
    assert gp.state_atoms(gp.init) == ["(in-bin x b1)", "(gripper-empty m)"]
    assert all("ghost" not in str(a) for a in gp.atoms)
    assert bfs(gp) is not None


# ---- errors -------------------------------------------------------------------------------------


def _error(text: str, **kw) -> GroundingError:
    with pytest.raises(GroundingError) as info:
        ground(_load(text), **kw)
    return info.value


def test_e600_too_many_bindings_names_the_action():
    params = " ".join(f"?x{i}" for i in range(10))
    objs = " ".join(f"o{i}" for i in range(50))
    err = _error(f"""(define (domain big) (:requirements :typing) (:types thing)
      (:predicates (p ?a - thing) (done))
      (:action huge :parameters ({params} - thing) :effect (and (done) (p ?x0))))
    (define (problem q) (:domain big) (:objects {objs} - thing) (:init) (:goal (done)))""")
    d = err.diagnostics[0]
    assert d.code == "E600"
    assert "`huge`" in d.message and "?x9: 50 (thing)" in d.message and "2,000,000" in d.message
    assert d.span is not None and d.hint


def test_e600_counts_after_unary_static_narrowing():
    prog = load_checked([FIXTURES / "classical/parcel-untyped/domain.pddl",
                         FIXTURES / "classical/parcel-untyped/p02.pddl"])
    # 8 untyped objects: 512 bindings per schema, but (van ?v) (depot ?d) ... narrow `drive` and
    # `load` to 18 each; `unload` has no static precondition and is the one over the limit
    with pytest.raises(GroundingError) as info:
        ground(prog, max_bindings=511)
    assert "`unload` has 512" in info.value.diagnostics[0].message


def test_e601_quantifier_expansion_too_large():
    objs = " ".join(f"o{i}" for i in range(20))
    err = _error(f"""(define (domain d) (:requirements :adl) (:predicates (p ?a ?b ?c) (g))
      (:action a :parameters () :precondition (forall (?a ?b ?c) (p ?a ?b ?c)) :effect (g)))
    (define (problem q) (:domain d) (:objects {objs}) (:init) (:goal (g)))""", max_bindings=1000)
    assert err.diagnostics[0].code == "E601"


def test_e602_numeric_state_is_unsupported():
    err = _error("""(define (domain d) (:requirements :numeric-fluents) (:predicates (g))
      (:functions (fuel))
      (:action a :parameters () :effect (and (g) (decrease (fuel) 1))))
    (define (problem q) (:domain d) (:init (= (fuel) 3)) (:goal (g)))""")
    assert err.diagnostics[0].code == "E602" and "fuel" in err.diagnostics[0].message


def test_e603_cost_without_a_value():
    err = _error("""(define (domain d) (:requirements :action-costs) (:predicates (g ?x))
      (:functions (total-cost) (c ?x))
      (:action a :parameters (?x) :effect (and (g ?x) (increase (total-cost) (c ?x)))))
    (define (problem q) (:domain d) (:objects k) (:init) (:goal (g k)))""")
    assert err.diagnostics[0].code == "E603" and "(a k)" in err.diagnostics[0].message


def test_e604_unstratifiable_derived_predicates():
    err = _error("""(define (domain d) (:requirements :derived-predicates :negative-preconditions)
      (:predicates (p) (q) (g))
      (:derived (p) (not (q))) (:derived (q) (not (p)))
      (:action a :parameters () :precondition (p) :effect (g)))
    (define (problem x) (:domain d) (:init) (:goal (g)))""")
    assert err.diagnostics[0].code == "E604"


def test_e605_domain_without_problem():
    report = check("(define (domain d) (:predicates (g)) (:action a :parameters () :effect (g)))")
    with pytest.raises(GroundingError) as info:
        ground(report.programs[0])
    assert info.value.diagnostics[0].code == "E605"



def test_e600_counts_the_join_over_binary_static_preconditions():
    # 30 cells on a line: 30^3 = 27,000 typed bindings for `move`, but `(adj ?from ?to)` and
    # `(adj ?to ?next)` leave 2 * 28 of them; the limit applies to the joined count
    cells = " ".join(f"c{i}" for i in range(30))
    adj = " ".join(f"(adj c{i} c{i + 1}) (adj c{i + 1} c{i})" for i in range(29))
    text = f"""(define (domain line) (:requirements :typing :equality) (:types cell)
      (:predicates (adj ?a ?b - cell) (at ?c - cell))
      (:action move :parameters (?from ?to ?next - cell)
        :precondition (and (at ?from) (adj ?from ?to) (adj ?to ?next) (not (= ?from ?next)))
        :effect (and (at ?next) (not (at ?from)))))
    (define (problem p) (:domain line) (:objects {cells} - cell)
      (:init (at c0) {adj}) (:goal (at c28)))"""
    gp = ground(_load(text), max_bindings=1000)
    # two steps at a time from c0: the even cells; ids follow object order parameter by parameter
    want = sorted([(i, i + 1, i + 2) for i in range(0, 27, 2)] +
                  [(i, i - 1, i - 2) for i in range(2, 29, 2)])
    assert [a.args for a in gp.actions] == [tuple(f"c{i}" for i in t) for t in want]
    assert [a.id for a in gp.actions] == list(range(len(want)))
    assert bfs(gp) is not None
    # without `(adj ?to ?next)` the join leaves 58 adjacent pairs * 30 cells - 58 (?from = ?next)
    err = _error(text.replace("(adj ?to ?next) ", ""), max_bindings=1000)
    d = err.diagnostics[0]
    assert d.code == "E600" and "`move` has more than 1,000 parameter bindings" in d.message
    assert "after joining its static preconditions (27,000 before)" in d.message
