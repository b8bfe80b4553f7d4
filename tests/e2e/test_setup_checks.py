"""`tmpc check` reports every error `tmpc run`'s setup raises, with the same code at the same
place (issue S), and `run` finds them before compiling anything. Each case breaks a copy of
examples/tower the way a new user did; :data:`~tmpc.runtime.setup_checks.SETUP_CODES` must all
have a case here."""

from __future__ import annotations

import json
import re
import shutil

import pytest

from tests.support import EXAMPLES, run_tmpc, tmpc_here
from tmpc.runtime.setup_checks import SETUP_CODES


def _scene(edit):
    def apply(d):
        data = json.loads((d / "scene.json").read_text())
        edit(data)
        (d / "scene.json").write_text(json.dumps(data, indent=1))
    return apply


def _text(name, old, new):
    def apply(d):
        text = (d / name).read_text()
        assert old in text
        (d / name).write_text(text.replace(old, new))
    return apply


def _both(*edits):
    def apply(d):
        for e in edits:
            e(d)
    return apply


def _set(path, value):
    def edit(data):
        *head, last = path
        for k in head:
            data = data[k]
        if value is None:
            del data[last]
        else:
            data[last] = value
    return edit


#: code -> (how to break the tower, where the error must point: (file, line, col) or None)
CASES = {
    "E821": (_scene(_set(["robot"], None)), None),
    # a misspelt gripper frame: at the object's own declaration
    "E822": (_both(_text("problem.pddl", "panda_hand_tcp - gripper", "panda_hand_tc - gripper"),
                   _text("problem.pddl", "(free panda_hand_tcp)", "(free panda_hand_tc)")),
             ("problem.pddl", 4, 13)),
    # the bench without a support region: at the predicate that reads it
    "E581": (_scene(_set(["objects", 0, "support"], None)), ("domain.pddl", 13, 6)),
    # cube a marked static while `pick` can hold it: at the action
    "E566": (_scene(_set(["objects", 1, "movable"], False)), ("domain.pddl", 14, 12)),
    # a goal atom no action adds
    "E824": (_both(_text("domain.pddl", "(free ?g - gripper)",
                         "(free ?g - gripper) (painted ?c - cube)"),
                   _text("problem.pddl", "(on a bench))", "(on a bench) (painted a))")),
             ("problem.pddl", 7, 46)),
    # a goal atom over two static surfaces, false in the scene
    "E834": (_both(_text("domain.pddl", "(free ?g - gripper)",
                         "(free ?g - gripper) (above ?s - surface ?t - surface "
                         ":semantics (> (z ?s) (z ?t)))"),
                   _text("problem.pddl", "bench - surface", "bench shelf - surface"),
                   _text("problem.pddl", "(on a bench))", "(on a bench) (above bench shelf))"),
                   _scene(lambda data: data["objects"].append({
                       "name": "shelf", "pose": {"translation": [0.0, 0.8, 1.0],
                                                 "rotation": [0, 0, 0, 1]},
                       "shape": {"type": "box", "half_extents": [0.2, 0.1, 0.02]},
                       "support": {"lower": [-0.15, -0.08, 0.02], "upper": [0.15, 0.08, 0.1]}}))),
             ("problem.pddl", 7, 46)),
    "E829": (_scene(_set(["robot", "joints", "panda_joint4"], 0.5)), None),
    # b put inside a
    "E823": (_scene(_set(["objects", 2, "pose", "translation"], [0.46, 0.2, 0.425])), None),
}


def test_every_setup_error_has_a_case():
    assert set(CASES) == set(SETUP_CODES)


def _broken(tmp_path, code):
    d = tmp_path / code
    shutil.copytree(EXAMPLES / "tower", d)
    CASES[code][0](d)
    return d


def _located(out: str, code: str):
    """(file name, line, col) of the first ``PATH:L:C: error[CODE]`` line, else None."""
    m = re.search(rf"^(\S+?):(\d+):(\d+): error\[{code}\]", out, re.M)
    return None if m is None else (m.group(1).rsplit("/", 1)[-1], int(m.group(2)),
                                   int(m.group(3)))


@pytest.mark.parametrize("code", sorted(CASES))
def test_check_reports_what_run_rejects_at_the_same_place(tmp_path, code):
    d = _broken(tmp_path, code)
    # both commands in this process (tmpc_here: exit code and output as a process's); the
    # unbroken tower's check below runs in a fresh interpreter
    check = tmpc_here("check", d / "tower.toml")
    assert check.returncode == 1, check.stderr
    assert f"error[{code}]" in check.stderr + check.stdout, check.stderr
    assert check.stderr.count("error[") == 1, check.stderr      # that error alone
    where = CASES[code][1]
    if where is not None:
        assert _located(check.stderr + check.stdout, code) == where, check.stderr
    run = tmpc_here("run", d / "tower.toml", "-q", "--time-limit", "5")
    assert run.returncode == 1, run.stderr
    assert f"error[{code}]" in run.stderr, run.stderr
    if where is not None:
        assert _located(run.stderr, code) == where, run.stderr
    # run found it before compiling: nothing was compiled for it
    assert "compiling kernels" not in run.stderr


def test_the_unbroken_tower_checks_clean():
    out = run_tmpc("check", EXAMPLES / "tower" / "tower.toml")
    assert out.returncode == 0, out.stderr
