"""`tmpc eval` end to end on the bundled examples: in this process (:func:`tests.support.tmpc_here`),
and one question in a fresh interpreter (`test_predicate_distance_and_gradient`)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.support import EXAMPLES, tmpc_here

TABLETOP = str(EXAMPLES / "tabletop" / "tabletop.toml")
CLUTTER = str(EXAMPLES / "clutter" / "clutter.toml")


def run(*args, stdin=None):
    return tmpc_here("eval", *args, stdin=stdin)


def run_process(*args, stdin=None):
    return subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", "eval", *args], input=stdin,
                          capture_output=True, text=True)


def test_expression_value_matches_the_scene_file():
    r = run(str(EXAMPLES / "tabletop" / "scene.json"), "--expr", "(position red_cube)", "--json")
    assert r.returncode == 0, r.stderr
    scene = json.loads((EXAMPLES / "tabletop" / "scene.json").read_text())
    cube = next(o for o in scene["objects"] if o["name"] == "red_cube")
    assert json.loads(r.stdout)["value"] == pytest.approx(cube["pose"]["translation"])


def test_predicate_truth_changes_with_the_state(tmp_path):
    r = run(TABLETOP, "--predicate", "over", "panda_hand_tcp", "bench", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["value"] is True
    state = tmp_path / "s.json"
    state.write_text(json.dumps({"joints": {"panda_joint1": 2.8}}))   # swing the arm away
    r = run(TABLETOP, "--state", str(state), "--predicate", "over", "panda_hand_tcp", "bench",
            "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["value"] is False


def test_predicate_distance_and_gradient():
    r = run_process(TABLETOP, "--predicate", "reach", "panda_hand_tcp", "red_cube", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["value"] is False and out["distance"] > 0.1
    assert set(out["gradient"]) == {f"panda_joint{i}" for i in range(1, 8)}
    assert any(abs(g) > 1e-3 for g in out["gradient"].values())


def test_held_object_in_state_json_moves_with_the_hand():
    state = {"mode": {"held": {"red_cube": "panda_hand_tcp"}}, "joints": {"panda_joint1": 0.5}}
    r = run(TABLETOP, "--state", "-", "--expr", "(position red_cube)", "--json",
            stdin=json.dumps(state))
    assert r.returncode == 0, r.stderr
    # a grasp keeps the object's world pose at the moment of the grasp (this state)
    assert json.loads(r.stdout)["value"] == pytest.approx([0.5, 0.15, 0.425])
    state["mode"]["held"] = {"red_cube": "no_such_frame"}
    r = run(TABLETOP, "--state", "-", "--expr", "(position red_cube)", stdin=json.dumps(state))
    assert r.returncode == 1 and "unknown robot frame" in r.stderr


@pytest.mark.parametrize("args, code", [
    (["--expr", "(position nowhere)"], "E581"),
    (["--expr", "(position"], "E001"),
    (["--predicate", "on", "red_cube", "bench"], "E586"),
    (["--predicate", "over", "panda_hand_tcp"], "E588"),
])
def test_errors_are_diagnostics(args, code):
    r = run(TABLETOP, *args)
    assert r.returncode == 1 and code in r.stderr and "Traceback" not in r.stderr


def test_bad_state_file(tmp_path):
    bad = tmp_path / "s.json"
    bad.write_text('{"joints": {"panda_joint1": 1.0,}}')
    r = run(TABLETOP, "--state", str(bad), "--expr", "(position red_cube)")
    assert r.returncode == 1 and "E580" in r.stderr and "Traceback" not in r.stderr
    r = run(TABLETOP, "--state", str(tmp_path / "missing.json"), "--expr", "1")
    assert r.returncode == 1 and "E010" in r.stderr


def test_usage_without_a_question():
    assert run(TABLETOP).returncode == 2


def test_missing_robot_meshes_block_collisions_but_not_kinematics(tmp_path):
    (tmp_path / "arm.urdf").write_text("""<robot name="arm">
  <link name="base"/>
  <link name="tip"><collision><geometry><mesh filename="meshes/tip.stl"/></geometry></collision>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
    <origin xyz="0 0 1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>""")
    (tmp_path / "scene.json").write_text(json.dumps({
        "format": "tmpc-scene/1", "bounds": [[-2, 2], [-2, 2], [0, 2]],
        "robot": {"urdf": "arm.urdf"}, "objects": []}))
    r = run(str(tmp_path / "scene.json"), "--expr", "(position tip)", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["value"] == pytest.approx([0.0, 0.0, 1.0])
    r = run(str(tmp_path / "scene.json"), "--collisions")
    assert r.returncode == 1 and "E562" in r.stderr and "tip.stl" in r.stderr



def test_division_by_zero_is_ieee_as_in_the_kernels():
    """`x/0` is +-inf and `0/0` nan in `tmpc eval` and the validator (its evaluator), as in the
    planner's JAX kernels; it was an error here and inf there (L 8)."""
    import math

    import jax.numpy as jnp
    out = {}
    for expr in ("(/ -1 0)", "(/ 2 0)", "(/ 0 0)", "(<= (/ -1 0) 1)", "(<= (/ 0 0) 1)"):
        r = run(TABLETOP, "--expr", expr, "--json")
        assert r.returncode == 0, r.stderr
        out[expr] = json.loads(r.stdout)["value"]
    kernel = [float(jnp.float64(-1.0) / 0.0), float(jnp.float64(2.0) / 0.0)]
    assert [out["(/ -1 0)"], out["(/ 2 0)"]] == kernel == [-math.inf, math.inf]
    assert out["(/ 0 0)"] is None or math.isnan(out["(/ 0 0)"])
    assert out["(<= (/ -1 0) 1)"] is True and out["(<= (/ 0 0) 1)"] is False
