"""`tmpc validate`: valid plan fixtures pass; targeted corruptions are reported at the right
state; malformed files are one clear error; the checker never touches the planner's acceptance
code (JAX kinematics, CollisionWorld, the grounder)."""

from __future__ import annotations

import copy
import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from tests.support import EXAMPLES, FIXTURES, TABLETOP, tmpc_here

PLANS = FIXTURES / "plans"


@pytest.fixture(scope="module")
def tabletop(tabletop_world):
    from tmpc.runtime.validate.core import Validator
    return Validator(tabletop_world)


@pytest.fixture
def plan():
    return json.loads((PLANS / "tabletop.json").read_text())


def validate(validator, data):
    from tmpc.lang.source import SourceFile
    from tmpc.runtime.plans import parse_plan
    return validator.validate(parse_plan(SourceFile("<plan>", json.dumps(data))))


def kinds(report):
    return [(v.state, v.kind) for v in report.violations]


def motion_state(s, **joints):
    """A copy of state ``s`` without action, with some joints changed."""
    out = copy.deepcopy(s)
    out["action"] = None
    out["joints"].update(joints)
    return out


# ---- valid plans --------------------------------------------------------------------------------

def test_tabletop_fixture_is_valid(tabletop, plan):
    rep = validate(tabletop, plan)
    assert rep.valid, rep.text()
    assert (rep.states, rep.actions) == (10, 4)
    assert rep.motion_checks > 20
    assert rep.summary().startswith("valid: 10 states, 4 actions, ")


def test_clutter_pr2_fixture_is_valid(clutter_world):
    from tmpc.runtime.validate import validate_plan
    rep = validate_plan(clutter_world, str(PLANS / "clutter.json"))
    assert rep.valid, rep.text()
    assert rep.actions == 2 and rep.motion_checks > 20


@pytest.mark.parametrize("flavour", ["planet", "tmit-star"])
def test_bare_legacy_arrays_are_simulated(tabletop, plan, flavour):
    states = []
    for s in plan["states"]:
        s = {k: v for k, v in s.items() if k != "mode"}
        if s["action"] and flavour == "planet":
            s["action"] = s["action"].strip("()").split()
        states.append(s)
    rep = validate(tabletop, states)
    assert rep.valid, rep.text()
    assert any("reconstructed by simulation" in n for n in rep.notes)
    # without modes, a skipped action still shows: the goal is not reached
    del states[7:]
    states[-1]["action"] = None
    rep = validate(tabletop, states)
    assert ("goal" in {v.kind for v in rep.violations})


# ---- corruptions --------------------------------------------------------------------------------

def test_state_in_collision(tabletop, plan):
    s = plan["states"]
    s.insert(1, motion_state(s[0], panda_joint2=0.6, panda_joint4=-1.5))   # arm in the bench
    rep = validate(tabletop, plan)
    coll = [v for v in rep.violations if v.kind == "collision"]
    assert coll and all(v.state == 1 for v in coll)
    assert any("bench" in v.message for v in coll)
    assert "state 1: panda_" in rep.text()


def test_dropped_effect_atom(tabletop, plan):
    atoms = plan["states"][2]["mode"]["atoms"]
    atoms.remove("(holding panda_hand_tcp red_cube)")
    rep = validate(tabletop, plan)
    msgs = [v.text() for v in rep.violations if v.kind == "mode"]
    assert any(m.startswith("state 2: mode does not follow from action (pick panda_hand_tcp "
                            "red_cube bench): missing (holding panda_hand_tcp red_cube)")
               for m in msgs), rep.text()


def test_extra_atom_after_a_motion(tabletop, plan):
    plan["states"][0]["mode"]["atoms"].append("(holding panda_hand_tcp blue_cube)")
    rep = validate(tabletop, plan)
    assert (0, "mode") in kinds(rep)
    assert "extra (holding panda_hand_tcp blue_cube)" in rep.text()


def test_wrong_action_arguments(tabletop, plan):
    plan["states"][1]["action"] = "(pick panda_hand_tcp blue_cube bench)"
    plan["actions"][0] = plan["states"][1]["action"]
    rep = validate(tabletop, plan)
    pre = [v.text() for v in rep.violations if v.kind == "precondition"]
    assert any(t.startswith("state 1: precondition (reach panda_hand_tcp blue_cube) false: "
                            "distance ") for t in pre), rep.text()
    assert (2, "mode") in kinds(rep)          # the effects of the action taken differ too


def test_ill_typed_and_unknown_actions(tabletop, plan):
    plan.pop("actions")
    plan["states"][1]["action"] = "(pick red_cube panda_hand_tcp bench)"
    plan["states"][3]["action"] = "(teleport panda_hand_tcp)"
    rep = validate(tabletop, plan)
    act = {v.state: v.message for v in rep.violations if v.kind == "action"}
    assert "`red_cube` is cube, but parameter ?g of `pick` is gripper" in act[1]
    assert "unknown action `teleport`" in act[3]


def test_actions_list_must_match_the_states(tabletop, plan):
    plan["actions"] = plan["actions"][:2]
    rep = validate(tabletop, plan)
    assert kinds(rep) == [(None, "actions")]


def test_goal_not_reached(tabletop, plan):
    del plan["states"][5:]
    plan["actions"] = plan["actions"][:2]
    rep = validate(tabletop, plan)
    goal = [v.text() for v in rep.violations]
    assert goal == ["goal (on blue_cube tray) false at the last state (state 4)"]


def test_plan_ending_with_an_action(tabletop, plan):
    del plan["states"][-1]
    rep = validate(tabletop, plan)
    assert "state 8: the plan ends with action (place panda_hand_tcp blue_cube tray): its " \
           "effects need a following state (same configuration, the new mode)" in rep.text()


def test_object_that_is_not_held_moves(tabletop, plan):
    plan["states"][4]["object_poses"]["blue_cube"]["translation"][2] += 0.1
    rep = validate(tabletop, plan)
    moved = [v for v in rep.violations if v.kind == "object"]
    assert moved[0].state == 4 and "object `blue_cube` moved 0.1 m but is not held" in \
        moved[0].message


def test_static_object_moves(tabletop, plan):
    for s in plan["states"][3:]:
        s["object_poses"]["tray"]["translation"][0] += 0.05
    rep = validate(tabletop, plan)
    assert [v.text() for v in rep.violations if v.kind == "object"] == \
        ["state 3: static object `tray` moved 0.05 m but is not held"]


def test_held_object_left_behind(tabletop, plan):
    plan["states"][3]["object_poses"]["red_cube"]["translation"][0] += 0.03
    rep = validate(tabletop, plan)
    held = [v for v in rep.violations if v.kind == "held"]
    assert held[0].state == 3 and "where `panda_hand_tcp` carries it" in held[0].message


def test_configuration_changes_across_an_action(tabletop, plan):
    plan["states"][2]["joints"]["panda_joint1"] += 0.1
    rep = validate(tabletop, plan)
    conf = [v for v in rep.violations if v.kind == "configuration"]
    assert conf and (conf[0].state, conf[0].to) == (1, 2)
    assert "panda_joint1" in conf[0].message


def test_joint_out_of_bounds_and_fixed_joint_moved(tabletop, plan):
    s = plan["states"]
    s.insert(1, motion_state(s[0], panda_joint4=0.5, panda_finger_joint1=0.01))
    rep = validate(tabletop, plan)
    assert [v.message for v in rep.violations if v.kind == "bounds"] == \
        ["joint `panda_joint4` = 0.5 is outside its limits [-3.0718, -0.0698]"]
    fixed = [v for v in rep.violations if v.kind == "joint"]
    assert fixed[0].state == 1 and "`panda_finger_joint1` is not controllable" in \
        fixed[0].message


def test_first_state_must_be_the_initial_state(tabletop, plan):
    s0 = plan["states"][0]
    s0["joints"]["panda_joint1"] = 0.2
    s0["object_poses"]["red_cube"]["translation"][1] += 0.01
    rep = validate(tabletop, plan)
    init = [v.message for v in rep.violations if v.kind == "initial"]
    assert any("panda_joint1" in m for m in init)
    assert any("red_cube" in m for m in init)


def test_unknown_names(tabletop, plan):
    plan["states"][2]["joints"]["elbow"] = 0.0
    plan["states"][2]["object_poses"]["ghost"] = {"translation": [0, 0, 0]}
    rep = validate(tabletop, plan)
    msgs = [v.text() for v in rep.violations]
    assert "state 2: unknown joint `elbow` (the robot `panda` has no movable joint of that " \
           "name)" in msgs
    assert "state 2: unknown object `ghost` in object_poses" in msgs


def test_motion_through_the_bench_between_free_states(tabletop, plan):
    """Both ends are collision-free; the straight joint-space motion sweeps the arm through the
    bench: only the motion check can catch it."""
    s0 = plan["states"][0]
    up = motion_state(s0, panda_joint1=-1.5)
    a = motion_state(s0, panda_joint1=-1.5, panda_joint2=0.6, panda_joint4=-1.5)
    b = motion_state(s0, panda_joint1=1.5, panda_joint2=0.6, panda_joint4=-1.5)
    plan = {"format": "tmpc-plan/1", "states": [s0, up, a, b]}
    rep = validate(tabletop, plan)
    assert [(v.state, v.to, v.kind) for v in rep.violations if v.kind != "goal"] == \
        [(2, 3, "motion")]
    v = rep.violations[0]
    assert "collides with bench at t=" in v.message and 0.0 < v.details["t"] < 1.0
    # a coarse resolution steps over the bench: the same plan is then only short of its goal
    from tmpc.runtime.validate.core import Validator
    coarse = Validator(tabletop.world, resolution=10.0)
    assert {v.kind for v in validate(coarse, plan).violations} == {"goal"}


def test_penetration_tolerance(tmp_path, plan):
    """A cube resting 5 mm into the bench: a collision at tolerance 0, none at planet's
    0.021 m."""
    import shutil

    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.validate.core import Validator
    for f in ("domain.pddl", "problem.pddl", "tabletop.toml"):
        shutil.copy(EXAMPLES / "tabletop" / f, tmp_path / f)
    scene = json.loads((EXAMPLES / "tabletop" / "scene.json").read_text())
    cube = next(o for o in scene["objects"] if o["name"] == "red_cube")
    cube["pose"]["translation"][2] -= 0.005
    (tmp_path / "scene.json").write_text(json.dumps(scene))
    world = open_world(tmp_path / "tabletop.toml")
    plan["states"][0]["object_poses"]["red_cube"]["translation"][2] -= 0.005
    del plan["states"][1:]
    plan["actions"] = []
    strict = validate(Validator(world), plan)
    coll = [v for v in strict.violations if v.kind == "collision"]
    assert [(v.state, v.details["pair"]) for v in coll] == [(0, ["red_cube", "bench"])] or \
        [(v.state, v.details["pair"]) for v in coll] == [(0, ["bench", "red_cube"])]
    assert coll[0].details["depth"] == pytest.approx(0.005, abs=1e-6)
    loose = validate(Validator(world, tolerance=0.021), plan)
    assert {v.kind for v in loose.violations} == {"goal"}


def test_objects_mounted_on_the_robot_ride_along(tmp_path, plan):
    """An object whose scene parent is a robot link is held by it from the start."""
    import shutil

    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.validate.core import Validator
    for f in ("domain.pddl", "problem.pddl", "tabletop.toml"):
        shutil.copy(EXAMPLES / "tabletop" / f, tmp_path / f)
    scene = json.loads((EXAMPLES / "tabletop" / "scene.json").read_text())
    scene["objects"].append({"name": "tool", "parent": "panda_hand", "movable": True,
                             "pose": {"translation": [0, 0, 0.02], "rotation": [0, 0, 0, 1]},
                             "shape": {"type": "sphere", "radius": 0.01}})
    (tmp_path / "scene.json").write_text(json.dumps(scene))
    v = Validator(open_world(tmp_path / "tabletop.toml"))
    for s in plan["states"]:
        s["mode"]["held"]["tool"] = "panda_hand"
    rep = validate(v, plan)
    assert rep.valid, rep.text()
    plan["states"][0]["object_poses"]["tool"] = {"translation": [0, 0, 1]}
    first = validate(v, plan).violations[0]
    assert (first.state, first.kind) == (0, "initial") and "object `tool`" in first.message


LUA = """local t = require('tmit-star')
local m = t.math
return {
  ['reach'] = function(g, c)
    local dx, dy, dz = g.px - c.px, g.py - c.py, g.pz - c.pz
    return m.sqrt(dx * dx + dy * dy + dz * dz) - 0.02
  end,
  ['over'] = function(g, s)
    local d = m.max(s.px + s.x_low - g.px, g.px - (s.px + s.x_high))
    d = m.max(d, m.max(s.py + s.y_low - g.py, g.py - (s.py + s.y_high)))
    return m.max(d, m.max(s.pz + s.z_low - g.pz, g.pz - (s.pz + s.z_high + 0.3)))
  end,
  ['resting'] = function(c, s)
    local d = m.max(s.px + s.x_low - c.px, c.px - (s.px + s.x_high))
    d = m.max(d, m.max(s.py + s.y_low - c.py, c.py - (s.py + s.y_high)))
    local gap = c.pz - 0.025 - (s.pz + s.z_low)
    return m.max(d, m.max(-gap, gap - 0.008))
  end,
}
"""


def test_lua_predicates_are_evaluated_directly(tmp_path, plan):
    """Legacy geometric predicates (no inline body): their Lua functions run at each state."""
    import shutil

    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.validate.core import Validator
    for f in ("problem.pddl", "scene.json"):
        shutil.copy(EXAMPLES / "tabletop" / f, tmp_path / f)
    domain = (EXAMPLES / "tabletop" / "domain.pddl").read_text()
    head, rest = domain.split("    ; the tool centre point is at the cube", 1)
    domain = head + "    (reach ?g - gripper ?c - cube :geometric)\n" \
        "    (over ?g - gripper ?s - surface :geometric)\n" \
        "    (resting ?c - cube ?s - surface :geometric))\n" + rest[rest.index("  (:action"):]
    (tmp_path / "domain.pddl").write_text(domain)
    (tmp_path / "preds.lua").write_text(LUA)
    (tmp_path / "run.toml").write_text('[problem]\ndomain = "domain.pddl"\nproblem = '
                                       '"problem.pddl"\nscene = "scene.json"\nsemantics = '
                                       '"preds.lua"\n')
    v = Validator(open_world(tmp_path / "run.toml"))
    rep = validate(v, plan)
    assert rep.valid, rep.text()
    assert rep.notes == ["Lua predicates evaluated directly: over, reach, resting"]
    plan["states"][1]["action"] = plan["actions"][0] = "(pick panda_hand_tcp blue_cube bench)"
    pre = [x.text() for x in validate(v, plan).violations if x.kind == "precondition"]
    assert len(pre) == 1 and pre[0].startswith("state 1: precondition (reach panda_hand_tcp "
                                               "blue_cube) false: distance 0.")


# ---- malformed files ----------------------------------------------------------------------------

@pytest.mark.parametrize("data, code, where", [
    ({"format": "tmpc-plan/2", "states": []}, "E802", "/format"),
    ({"format": "tmpc-plan/1", "states": []}, "E803", "/states"),
    ({"format": "tmpc-plan/1"}, "E803", "/"),
    ("not a plan", "E801", "/"),
    ([{"joints": {"a": "x"}}], "E805", "/0/joints/a"),
    ([{"base_pose": {"rotation": [0, 0, 0, 2]}}], "E806", "/0/base_pose/rotation"),
    ([{"object_poses": {"o": {"translation": [0, 0]}}}], "E806", "/0/object_poses/o/translation"),
    ([{"object_poses": []}], "E807", "/0/object_poses"),
    ([{"action": 3}], "E808", "/0/action"),
    ([{"mode": {"atoms": "(a)"}}], "E809", "/0/mode/atoms"),
    ([{"mode": {"atoms": ["(a b"]}}], "E810", "/0/mode/atoms/0"),
    ([{"velocity": 1}], "E804", "/0/velocity"),
    ({"format": "tmpc-plan/1", "status": 1, "states": [{}]}, "E811", "/status"),
])
def test_malformed_plans(data, code, where):
    from tmpc.lang.source import SourceFile
    from tmpc.runtime.plans.read import PlanError, parse_plan
    src = SourceFile("p.json", json.dumps(data, indent=1))
    with pytest.raises(PlanError) as exc:
        parse_plan(src)
    d = exc.value.diagnostics[0]
    assert d.code == code and f"p.json: {where}: " in d.message
    if where != "/":
        assert d.span is not None and d.span.start > 0


def test_action_forms():
    from tmpc.runtime.plans import parse_ground
    want = ("pick", ("g", "c", "s"))
    assert parse_ground("(pick g c s)") == want
    assert parse_ground("pick g c s") == want
    assert parse_ground("pick(g, c, s)") == want
    assert parse_ground("pick(") is None


# ---- the command --------------------------------------------------------------------------------

def cli(*args):
    """`tmpc validate ARGS` in this process (tests.support.tmpc_here: exit code, stdout, stderr)."""
    return tmpc_here("validate", *args)


def test_cli_valid_invalid_json_and_malformed(tmp_path, plan):
    ok = cli(TABLETOP, PLANS / "tabletop.json")
    assert ok.returncode == 0, ok.stderr
    assert ok.stdout.startswith("valid: 10 states, 4 actions, ")
    del plan["states"][5:]
    plan["actions"] = plan["actions"][:2]
    bad = tmp_path / "short.json"
    bad.write_text(json.dumps(plan))
    r = cli(TABLETOP, bad, "--json")
    assert r.returncode == 1
    out = json.loads(r.stdout)
    assert out["valid"] is False and out["violations"][0]["kind"] == "goal"
    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "tmpc-plan/1",\n "states": [}\n')
    r = cli(TABLETOP, broken)
    assert r.returncode == 1 and "E800" in r.stderr and "broken.json:2:" in r.stderr
    assert "Traceback" not in r.stderr
    r = cli(TABLETOP, PLANS / "tabletop.json", "--resolution", "0")
    assert r.returncode == 1 and "E813" in r.stderr
    scene = EXAMPLES / "tabletop" / "scene.json"
    r = cli(scene, PLANS / "tabletop.json")
    assert r.returncode == 1 and "E812" in r.stderr


def test_independent_of_the_planners_acceptance_code():
    code = ("import sys\n"
            "from tmpc.compiler.artifact import open_world\n"
            "from tmpc.runtime.validate.core import validate_plan\n"
            f"r = validate_plan(open_world({str(TABLETOP)!r}), {str(PLANS / 'tabletop.json')!r})\n"
            "assert r.valid and r.kinematics in ('pinocchio', 'urdf')\n"
            "bad = [m for m in sys.modules if m.split('.')[0] == 'jax' or m in\n"
            "       ('tmpc.runtime.collision.world', 'tmpc.runtime.collision.spheres', 'tmpc.compiler.ground.problem',\n"
            "        'tmpc.compiler.kernels.emit', 'tmpc.compiler.kernels.project')]\n"
            "print(bad)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


@pytest.mark.parametrize("backend", ["yourdfpy", "urdf"])
def test_fallback_kinematics_agree_with_pinocchio(tabletop, backend):
    import numpy as np

    from tmpc.runtime.validate import Kinematics, full_joint_values
    pytest.importorskip("pinocchio")
    other = Kinematics(tabletop.desc, backend)
    rng = np.random.default_rng(0)
    for _ in range(3):
        vals = {j.name: rng.uniform(j.lower, j.upper) for j in tabletop.desc.joints
                if j.movable and j.mimic is None}
        vals = full_joint_values(tabletop.desc, vals)
        assert np.allclose(tabletop.kin.poses(np.eye(4), vals), other.poses(np.eye(4), vals),
                           atol=1e-9)


def test_the_tree_walk_agrees_with_yourdfpy_on_the_pr2():
    """The validator's own kinematics without pinocchio (``urdf``: a walk down its joint tree)
    against yourdfpy's scene graph on the PR2: 82 links, mimic gripper joints, continuous and
    prismatic joints, a moved root."""
    import numpy as np

    from tests.support import CLUTTER
    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.validate import Kinematics, full_joint_values
    from tmpc.runtime.validate.kinematics import read_urdf, urdf_path
    desc = read_urdf(urdf_path(open_world(CLUTTER).scene))
    assert {j.type for j in desc.joints if j.movable} >= {"revolute", "continuous", "prismatic"}
    assert any(j.mimic is not None for j in desc.joints)
    walk, ref = Kinematics(desc, "urdf"), Kinematics(desc, "yourdfpy")
    rng = np.random.default_rng(3)
    for _ in range(5):
        vals = full_joint_values(desc, {
            j.name: rng.uniform(-3, 3) if j.lower is None else rng.uniform(j.lower, j.upper)
            for j in desc.joints if j.movable and j.mimic is None})
        T = np.eye(4)
        T[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        T[:3, :3] *= np.linalg.det(T[:3, :3])
        T[:3, 3] = rng.normal(size=3)
        assert np.allclose(walk.poses(T, vals), ref.poses(T, vals), atol=1e-12, rtol=0)


def test_a_plan_for_another_problem_is_said_so_first(tmp_path):
    """The tabletop plan against the clutter configuration: one E817 naming what does not fit
    (it once listed 149 violations; `view` drew the wrong robot without a word)."""
    from tests.support import CLUTTER
    r = cli(CLUTTER, PLANS / "tabletop.json")
    assert r.returncode == 1 and "error[E817]" in r.stderr and "made for another problem" in \
        r.stderr and "panda_joint1" in r.stderr, r.stderr
    assert "violation" not in r.stdout
    r = subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", "view", str(CLUTTER),
                        str(PLANS / "tabletop.json"), "--png", str(tmp_path / "x.png")],
                       capture_output=True, text=True)
    assert r.returncode == 1 and "error[E817]" in r.stderr and not (tmp_path / "x.png").exists()


# ---- plans of the other planners (docs/validate.md "Conventions") -------------------------------

def _legacy(plan, flavour: str, drop=(2, 4, 7)) -> list[dict]:
    """The tabletop plan as planet or tmit-star write theirs: bare states, the planner's action
    spelling, and no separate state after an action (the next one is elsewhere in the new
    mode): the fixture's actions are at states 1, 3, 6 and 8, each followed by its new mode's
    state (5 is a waypoint), and the last is kept."""
    out = []
    for i, s in enumerate(plan["states"]):
        if i in drop:
            continue
        s = {k: v for k, v in s.items() if k != "mode"}
        if s["action"]:
            name, *args = s["action"].strip("()").split()
            s["action"] = [name, *args] if flavour == "planet" else f"{name}({', '.join(args)})"
        out.append(s)
    return out


def test_planet_plans_move_on_from_the_action_state(tabletop, plan):
    from tmpc.runtime.validate.core import Validator
    states = _legacy(plan, "planet")
    rep = validate(tabletop, states)
    assert rep.valid, rep.text()
    note = next(n for n in rep.notes if "planet's conventions" in n)
    assert "3 such" in note                      # pick -> place, place -> pick, pick -> place
    # read as tmpc plans, the same states change configuration across each action
    strict = Validator(tabletop.world, convention="tmpc")
    got = validate(strict, states)
    assert [v.kind for v in got.violations].count("configuration") == 3


def test_tmit_star_plans_snap_grasped_objects_onto_the_frame(tabletop, plan, tmp_path):
    """tmit-star puts a grasped object on the gripper frame itself. Written that way, the plan
    is valid under tmit-star's conventions (at its tolerance, 0.029 m: the snap pushes the
    cubes 3-13 mm into the bench and the fingers); the same poses are a violation under planet's.
    The snap turns a cube upside down, so the example's `resting` (upright, on the tray) cannot
    hold: here `place` asks for the hand over the tray only, as tmit-star's own `over` did."""
    import shutil

    from scipy.spatial.transform import Rotation

    from tmpc.lang.inputs import load_world
    from tmpc.runtime.validate.core import Validator
    shutil.copytree(TABLETOP.parent, tmp_path / "tabletop")
    domain = tmp_path / "tabletop" / "domain.pddl"
    domain.write_text(domain.read_text().replace("(over ?g ?s) (resting ?c ?s))", "(over ?g ?s))"))
    v = Validator(load_world(tmp_path / "tabletop" / "tabletop.toml"), tolerance=0.029)

    def tcp(s):
        values = dict(v.defaults, **s["joints"])
        return v.link_poses(v.T_base0, values)[v.link_index["panda_hand_tcp"]]

    def as_pose(T):
        return {"translation": T[:3, 3].tolist(),
                "rotation": Rotation.from_matrix(T[:3, :3]).as_quat().tolist()}

    st = plan["states"]
    for obj, grasp, place, after in (("red_cube", 1, 3, (4, 5, 6, 7, 8, 9)),
                                     ("blue_cube", 6, 8, (9,))):
        snapped = tcp(st[place])
        # the snap moves the object: the test means something
        assert np.linalg.norm(tcp(st[grasp])[:3, 3]
                              - np.array(st[grasp]["object_poses"][obj]["translation"])) > 1e-3
        for k in (place, *after):
            st[k]["object_poses"][obj] = as_pose(snapped)
    rep = validate(v, _legacy(plan, "tmit-star"))
    assert rep.valid, rep.text()
    note = next(n for n in rep.notes if "tmit-star's conventions" in n)
    assert "2 grasps" in note
    got = validate(v, _legacy(plan, "planet"))
    assert any(x.kind == "held" for x in got.violations), got.text()


# ---- released objects rest on a support (L 9) -----------------------------------------------

def _released(validator, name: str, T) -> list:
    """The W830 warnings for ``name`` released at world pose ``T`` (the other objects where the
    scene puts them)."""
    from types import SimpleNamespace

    from tmpc.runtime.plans import pose_matrix
    objects = {o.name: pose_matrix(o.pose.translation, o.pose.rotation)
               for o in validator.scene.objects}
    objects[name] = T
    validator.v, validator.w, validator.strict = [], [], False
    validator._check_support(SimpleNamespace(index=3, objects=objects, held={}), name)
    return validator.w


def _at(x, y, z, roll=0.0):
    c, s = np.cos(roll), np.sin(roll)
    T = np.eye(4)
    T[:3, :3] = [[1, 0, 0], [0, c, -s], [0, s, c]]
    T[:3, 3] = (x, y, z)
    return T


def test_a_released_object_must_rest_on_a_support(tabletop):
    # the tray's support region starts at its top, z 0.41; a cube's half height 0.025
    floor = 0.41
    assert _released(tabletop, "red_cube", _at(0.45, -0.3, floor + 0.025 + 0.008)) == []
    high = _released(tabletop, "red_cube", _at(0.45, -0.3, floor + 0.025 + 0.10))
    assert [(w.kind, w.details["support"], w.details["gap"]) for w in high] == \
        [("support", "tray", pytest.approx(0.10, abs=1e-6))]
    assert "10.0 cm above `tray`" in high[0].message
    tilted = _released(tabletop, "red_cube", _at(0.45, -0.3, floor + 0.034, roll=0.17))
    assert tilted and tilted[0].details["tilt"] == pytest.approx(np.degrees(0.17), abs=0.01)
    nothing = _released(tabletop, "red_cube", _at(2.0, 2.0, 0.1))
    assert "over no support" in nothing[0].message and nothing[0].details["gap"] is None
    # stacked on the other cube (no support region: its top counts)
    assert _released(tabletop, "red_cube", _at(0.6, 0.25, 0.45 + 0.025 + 0.002)) == []


@pytest.mark.parametrize("seed", [0, 1])
def test_the_tabletop_example_puts_its_cubes_down(tabletop_world, tmp_path, seed):
    """The bundled tabletop example's plans release each cube resting in the tray (L 9): its
    `place` needs `resting` (the stdlib's `rests-on`); `over` alone let go 16-18 cm up."""
    from tmpc.runtime.cli.main import main
    from tmpc.runtime.validate import validate_plan
    plan = tmp_path / "plan.json"
    assert main(["run", str(TABLETOP), "--seed", str(seed), "-q", "-o", str(plan)]) == 0
    rep = validate_plan(tabletop_world, str(plan))
    assert rep.valid and rep.warnings == [], [w.message for w in rep.warnings]


@pytest.mark.slow
def test_floating_releases_warn_and_strict_makes_them_errors(tmp_path, capsys):
    """A tabletop domain whose `place` asks only for the hand over the tray (as the example's
    did) releases cubes in the air: validate says so (W830) and stays valid; --strict makes the
    plan invalid (exit 1). Slow: the changed domain compiles from scratch."""
    from tmpc.lang.inputs import load_world
    from tmpc.runtime.cli.main import main
    from tmpc.runtime.validate import validate_plan
    shutil.copytree(TABLETOP.parent, tmp_path / "tabletop")
    domain = tmp_path / "tabletop" / "domain.pddl"
    domain.write_text(domain.read_text().replace("(over ?g ?s) (resting ?c ?s))", "(over ?g ?s))"))
    config = tmp_path / "tabletop" / "tabletop.toml"
    world = load_world(config)
    plan = tmp_path / "plan.json"
    capsys.readouterr()
    assert main(["run", str(config), "--seed", "0", "-q", "-o", str(plan)]) == 0
    rep = validate_plan(world, str(plan))
    assert rep.valid and len(rep.warnings) == 2
    assert all(w.details["gap"] > 0.05 for w in rep.warnings)
    capsys.readouterr()
    assert main(["validate", str(config), str(plan)]) == 0
    assert capsys.readouterr().out.count("warning[W830]: state ") == 2
    assert main(["validate", str(config), str(plan), "--strict", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    assert not doc["valid"] and [v["kind"] for v in doc["violations"]] == ["support"] * 2


def _rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _box_pd(RA, tA, hA, RB, tB, hB) -> float:
    """Penetration depth of two boxes by the separating axis theorem (the 15 axes: exact for
    boxes), 0 when apart: an independent reference for the validator's polytope depth."""
    axes = [RA[:, i] for i in range(3)] + [RB[:, i] for i in range(3)]
    axes += [np.cross(RA[:, i], RB[:, j]) for i in range(3) for j in range(3)]
    best = np.inf
    for n in axes:
        if np.linalg.norm(n) < 1e-9:
            continue
        n = n / np.linalg.norm(n)
        ra, rb = np.abs(RA.T @ n) @ hA, np.abs(RB.T @ n) @ hB
        overlap = ra + rb - abs((tB - tA) @ n)
        best = min(best, overlap)
    return max(0.0, best)


def test_polytope_depth_is_exact_on_boxes():
    """The validator's exact depth (qhull of the Minkowski difference) against the separating
    axis theorem on 300 random overlapping box pairs."""
    from tmpc.runtime.validate.collision import polytope_depth
    rng = np.random.default_rng(3)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    seen = 0
    for _ in range(300):
        hA, hB = rng.uniform(0.01, 0.3, 3), rng.uniform(0.01, 0.3, 3)
        RA, RB = _rotation(rng), _rotation(rng)
        tA, tB = rng.uniform(-0.1, 0.1, 3), rng.uniform(-0.1, 0.1, 3) + rng.normal(size=3) * 0.2
        ref = _box_pd(RA, tA, hA, RB, tB, hB)
        got = polytope_depth(corners * hA @ RA.T + tA, corners * hB @ RB.T + tB)
        assert got == pytest.approx(ref, abs=1e-9)
        seen += ref > 0
    assert seen > 100


def test_a_depth_fcl_overestimates_is_confirmed_exactly(tmp_path):
    """Two box meshes (the validator gives meshes fcl's EPA depth between their hulls): where
    libccd's EPA puts the depth over the tolerance and the exact depth is under it, the
    validator's depth is the exact one (EPA overestimated 5% of contacts near the tolerance
    on tmit-star's clutter; a planner's valid motion was rejected for it)."""
    import fcl
    import trimesh

    from tmpc.runtime.validate.collision import Checker, fcl_shape, Geom
    box = tmp_path / "stick.stl"
    trimesh.creation.box(extents=(0.04, 0.04, 0.2)).export(box)
    checker = Checker.__new__(Checker)
    checker.tolerance = 0.01
    checker._req = fcl.CollisionRequest(num_max_contacts=1, enable_contact=True)
    geoms = []
    for _ in range(2):
        g, hull, c, h, pts = fcl_shape("mesh", path=box)
        geoms.append(Geom(0, np.eye(4), fcl.CollisionObject(g), fcl.CollisionObject(hull), c, h,
                           pts))
    rng = np.random.default_rng(0)
    half = np.array([0.02, 0.02, 0.1])
    found = 0
    for _ in range(3000):
        Ts = []
        for k, g in enumerate(geoms):
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = _rotation(rng), rng.normal(size=3) * 0.03 * k
            tf = fcl.Transform(T[:3, :3], T[:3, 3])
            g.obj.setTransform(tf)
            g.hull.setTransform(tf)
            g.T = T
            Ts.append(T)
        ref = _box_pd(Ts[0][:3, :3], Ts[0][:3, 3], half, Ts[1][:3, :3], Ts[1][:3, 3], half)
        res = fcl.CollisionResult()
        if not fcl.collide(geoms[0].hull, geoms[1].hull, checker._req, res):
            continue
        epa = abs(res.contacts[0].penetration_depth)
        depth = checker._depth(*geoms)
        if epa > checker.tolerance and ref < 0.9 * epa:
            found += 1
            assert depth == pytest.approx(ref, abs=1e-6), (epa, ref)     # STL: float32
        elif depth is not None and epa > checker.tolerance:
            assert depth == pytest.approx(ref, abs=1e-6)
    assert found >= 3


def test_a_plan_from_an_observed_start_is_checked_from_its_first_state(tmp_path):
    """start="plan" (a replanned plan, `tmpc validate --from-plan-start`): the first state's
    configuration, poses and mode are taken as given; what follows is still checked."""
    import json

    from tmpc.compiler.artifact import open_world
    from tmpc.lang.source import SourceFile
    from tmpc.runtime.plans import parse_plan
    from tmpc.runtime.validate import validate_plan
    world = open_world(TABLETOP)
    doc = json.loads((FIXTURES / "plans" / "tabletop.json").read_text())
    # drop the first motion: the plan now starts where the robot was after it
    first = next(i for i, s in enumerate(doc["states"]) if s["action"] is not None)
    cut = dict(doc, states=doc["states"][first:])
    plan = parse_plan(SourceFile("<cut>", json.dumps(cut)))
    assert not validate_plan(world, plan).valid                 # not the scene's start
    assert validate_plan(world, plan, start="plan").valid
    # and a later state that breaks the plan is still caught
    bad = json.loads(json.dumps(cut))
    bad["states"][-1]["object_poses"]["red_cube"]["translation"][2] += 0.3
    rep = validate_plan(world, parse_plan(SourceFile("<bad>", json.dumps(bad))), start="plan")
    assert not rep.valid
