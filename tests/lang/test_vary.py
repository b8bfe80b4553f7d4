"""examples/lagriffoul/vary.py: a variation keeps every object resting on its support (its
height unchanged, its origin in the support's region) and collision-free (tmpc's own collision
check, robot included), is the same for the same seed, and writes a scene that differs from the
original only in `<pose>` values and a run.toml that works from any directory."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
import tomllib

import numpy as np
import pytest

from tests.support import EXAMPLES
from tmpc.lang.world import load_config, load_config_scene, load_scene
from tmpc.lang.world.loaders import matrix_from_quat

LAGRIFFOUL = EXAMPLES / "lagriffoul"
DATA = LAGRIFFOUL / "data"
SCENES = {
    "hanoi3": DATA / "problem1" / "hanoi_xml" / "hanoi3.xml",
    "blocksD": DATA / "problem2" / "blocksworld_xml" / "blocksworldD.xml",
    "clutter": DATA / "problem3" / "clutter.xml",
    "nonmono": DATA / "problem4" / "nonmono.xml",
    "kitchen": DATA / "problem5" / "kitchen.xml",
}
SEEDS = (0, 1, 2)


def load_vary():
    spec = importlib.util.spec_from_file_location("lagriffoul_vary", LAGRIFFOUL / "vary.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod          # its dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


VARY = load_vary()


def frame(pose) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = np.array(matrix_from_quat(pose.rotation))
    T[:3, 3] = pose.translation
    return T


_CHECKS: dict[str, tuple] = {}


def checked(name: str) -> tuple:
    """(scene, its RobotCheck), compiled once per module."""
    if name not in _CHECKS:
        scene = load_scene(SCENES[name])
        _CHECKS[name] = (scene, VARY.RobotCheck(scene))
    return _CHECKS[name]


@pytest.fixture(params=sorted(SCENES))
def instance(request):
    return (request.param, *checked(request.param))


def test_variations_rest_and_touch_nothing(instance):
    name, scene, robot = instance
    by = {o.name: o for o in scene.objects}
    supports = VARY.find_supports(scene)
    movable = {o.name for o in scene.objects if o.movable}
    assert set(supports) == movable              # every movable object stands on something
    start_pairs = robot.pairs({})
    if name in ("hanoi3", "nonmono", "kitchen"):
        assert start_pairs == []           # these files start valid (docs/benchmarks.md)
    for seed in SEEDS:
        new = VARY.vary(scene, seed, robot=robot)
        assert new and set(new) <= movable
        poses = {o.name: frame(new.get(o.name, o.pose)) for o in scene.objects}
        for obj, sup in supports.items():
            T0, T = frame(by[obj].pose), poses[obj]
            assert abs(T[2, 3] - T0[2, 3]) < 1e-9                       # same height
            assert abs(T[2, 2] - T0[2, 2]) < 1e-9                       # still upright
            b = by[sup].support
            local = np.linalg.inv(poses[sup]) @ T[:, 3]
            local0 = np.linalg.inv(frame(by[sup].pose)) @ T0[:, 3]
            assert np.allclose(local[2], local0[2])
            if sup in movable:                                          # a stack: rigid
                assert np.allclose(np.linalg.inv(poses[sup]) @ T,
                                   np.linalg.inv(frame(by[sup].pose)) @ T0, atol=1e-9)
            else:
                assert all(b.lower[i] - 1e-9 <= local[i] <= b.upper[i] + 1e-9
                           for i in range(2)), (name, seed, obj, local)
        pairs = robot.pairs({n: poses[n] for n in movable})
        loose = [(a, b) for a, b, _ in pairs if {a, b} & movable]
        assert loose == [], (name, seed, loose)
        # what collided at the start without a movable object (the suite's own slips) is all
        assert {(a, b) for a, b, _ in pairs} <= {(a, b) for a, b, _ in start_pairs}
        assert VARY.vary(scene, seed, robot=robot) == new                # deterministic


def test_clutters_overlapping_sticks_are_separated():
    # the file writes two pairs of sticks at one place each; the reader already moves the later
    # of each pair (W517), so no two sticks overlap at the start, nor after a variation
    _, robot = checked("clutter")
    start = {frozenset((a, b)) for a, b, _ in robot.pairs({})}
    assert frozenset(("stick_blue7", "stick_red11")) not in start
    assert frozenset(("stick_red9", "stick_red10")) not in start


def run_vary(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(LAGRIFFOUL / "vary.py"), *map(str, args)],
                          capture_output=True, text=True, cwd="/")


def test_the_command_writes_a_runnable_variant(tmp_path):
    out1, out2 = tmp_path / "a", tmp_path / "b"
    r = run_vary(LAGRIFFOUL / "blocks-C", "--seed", 7, "-o", out1)
    assert r.returncode == 0, r.stderr
    assert run_vary(LAGRIFFOUL / "blocks-C", "--seed", 7, "-o", out2).returncode == 0
    for f in ("run.toml", "blocksworldC.xml"):
        assert (out1 / f).read_text().replace(str(out1), "X") == \
            (out2 / f).read_text().replace(str(out2), "X")                # same seed, same files
    other = tmp_path / "c"
    assert run_vary(LAGRIFFOUL / "blocks-C", "--seed", 8, "-o", other).returncode == 0
    assert (other / "blocksworldC.xml").read_text() != (out1 / "blocksworldC.xml").read_text()
    # only <pose> values changed
    original = (DATA / "problem2" / "blocksworld_xml" / "blocksworldC.xml").read_text()
    strip = re.compile(r"<pose>[^<]*</pose>")
    varied = (out1 / "blocksworldC.xml").read_text()
    assert strip.sub("<pose/>", varied) == strip.sub("<pose/>", original)
    assert varied != original
    # every path absolute; all but the coordinator's semantics module exist
    data = tomllib.loads((out1 / "run.toml").read_text())
    for key, value in data["problem"].items():
        assert value.startswith("/"), key
        assert key == "semantics" or (out1 / value).exists(), key
    assert data["problem"]["scene"] == str(out1 / "blocksworldC.xml")
    assert data["names"] == tomllib.loads((LAGRIFFOUL / "blocks-C" / "run.toml").read_text())[
        "names"]
    # the variant loads with its names, from another directory
    text = (out1 / "run.toml").read_text()
    runnable = tmp_path / "elsewhere" / "run.toml"
    runnable.parent.mkdir()
    runnable.write_text("\n".join(line for line in text.splitlines()
                                  if not line.startswith("semantics")) + "\n")
    scene = load_config_scene(load_config(runnable))
    assert scene.object("a") is not None and scene.object("block_a") is None


def test_bad_instances_are_reported(tmp_path):
    r = run_vary(tmp_path, "--seed", 0, "-o", tmp_path / "out")
    assert r.returncode == 1 and "cannot read" in r.stderr and "Traceback" not in r.stderr
    (tmp_path / "run.toml").write_text("[problem]\ndomain = 'd.pddl'\n")
    r = run_vary(tmp_path, "--seed", 0, "-o", tmp_path / "out")
    assert r.returncode == 1 and "scene" in r.stderr and "Traceback" not in r.stderr
