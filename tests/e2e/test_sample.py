"""`tmpc sample`: every state it prints satisfies the predicate (checked by the independent numpy
interpreter) and is collision-free (checked again by the collision checker)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.support import TABLETOP, tmpc_here
from tmpc.compiler.compile import compile_world
from tmpc.runtime.collision import collision_world


def run(*args, stdin=None):
    """`tmpc sample ARGS` in this process (:func:`tests.support.tmpc_here`)."""
    return tmpc_here("sample", *args, stdin=stdin)


def run_process(*args, stdin=None):
    """`tmpc sample ARGS` in a fresh interpreter."""
    return subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", "sample", *args],
                          capture_output=True, text=True, input=stdin)


def _holds(world, state_json, text):
    from tmpc.compiler.state import initial_state, state_from_json, world_poses
    from tmpc.lang.reader_formulas import parse_expr
    from tmpc.runtime.evaluate import Evaluator
    st = state_from_json(state_json, world.scene, compile_world(world).model,
                         initial_state(world.scene, compile_world(world).model))
    frames = compile_world(world).fk(st.q)
    ev = Evaluator(world.scene, compile_world(world).model, st.q, frames, world_poses(st, compile_world(world).model, frames),
                   world.program.scope)
    return ev.value(parse_expr(text)[0]), st


@pytest.mark.parametrize("what, check", [
    (["--predicate", "reach", "panda_hand_tcp", "red_cube"], "(reach panda_hand_tcp red_cube)"),
    # at the start the cube is on the bench, not held: placing it there is what can be sampled
    (["--action", "place", "panda_hand_tcp", "red_cube", "bench"],
     "(and (over panda_hand_tcp bench) (resting red_cube bench))"),
])
def test_sampled_states_satisfy_and_are_valid(tabletop_world, what, check):
    world = tabletop_world
    r = run(str(TABLETOP), *what, "-n", "4", "--seed", "7")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 4 and "starts; rejected" in r.stderr
    collision = collision_world(world, compile_world(world))
    for line in lines:
        holds, st = _holds(world, json.loads(line), check)
        assert holds
        assert collision.check(st.q, poses=st.poses).valid
    # deterministic per seed, whatever the process (another interpreter: its own hash seed)
    again = run_process(str(TABLETOP), *what, "-n", "4", "--seed", "7")
    assert again.returncode == 0, again.stderr
    assert again.stdout == r.stdout


def test_unreachable_request_exits_3(tmp_path):
    far = tmp_path / "far.json"
    far.write_text(json.dumps({"object_poses": {"red_cube": {"translation": [4.0, 4.0, 0.4]}}}))
    r = run(str(TABLETOP), "--predicate", "reach", "panda_hand_tcp", "red_cube", "--state",
            str(far), "--max-starts", "128")
    assert r.returncode == 3
    assert r.stdout == "" and "0 of 1 state(s) from 128 starts" in r.stderr


@pytest.mark.parametrize("args, code", [
    (["--predicate", "reach", "panda_hand_tcp"], "E588"),
    (["--predicate", "free", "panda_hand_tcp"], "E586"),
    (["--predicate", "reach", "red_cube", "panda_hand_tcp"], "E591"),
    (["--action", "fly", "panda_hand_tcp"], "E587"),
])
def test_bad_requests(args, code):
    r = run(str(TABLETOP), *args)
    assert r.returncode == 1 and code in r.stderr and "Traceback" not in r.stderr
