"""Why no plan (issue S): five problems made infeasible on purpose, each explanation names its
culprit predicate (or colliding pair) and object. Each is a bundled example with one thing
moved or added, planned for a few seconds; the report is what `tmpc run --explain` writes.

The infeasible cases run the command in this process (:func:`tmpc.runtime.cli.main.main`: the
same exit code, stderr and report); the solved one runs it in a fresh interpreter, as a user
does."""

from __future__ import annotations

import json
import shutil

import pytest

from tests.support import EXAMPLES, run_tmpc


def _copy(tmp_path, example: str):
    d = tmp_path / example
    shutil.copytree(EXAMPLES / example, d)
    return d


def _edit_scene(d, edit):
    data = json.loads((d / "scene.json").read_text())
    edit({o["name"]: o for o in data["objects"]}, data)
    (d / "scene.json").write_text(json.dumps(data, indent=1))


def _far_cube(objs, _):
    objs["red_cube"]["pose"]["translation"] = [1.3, 0.0, 0.425]


def _far_tray(objs, _):
    objs["tray"]["pose"]["translation"] = [1.3, -0.3, 0.405]


def _lid(objs, data):
    # a slab 3 cm over the tray: a 5 cm cube cannot rest there
    data["objects"].append({"name": "lid", "pose": {"translation": [0.45, -0.3, 0.44],
                                                    "rotation": [0, 0, 0, 1]},
                            "shape": {"type": "box", "half_extents": [0.12, 0.12, 0.005]}})


def _big_cube(objs, _):
    objs["red_cube"]["shape"]["half_extents"] = [0.1, 0.1, 0.1]
    objs["red_cube"]["pose"]["translation"] = [0.68, -0.1, 0.5]


def _high_support(objs, _):
    # b's support region floats 30 cm above it: nothing can rest on b
    objs["b"]["support"] = {"lower": [-0.02, -0.02, 0.3], "upper": [0.02, 0.02, 0.38]}


#: name -> (example, config, scene edit, what the first culprits must name)
CASES = {
    "cube out of reach": ("tabletop", "tabletop.toml", _far_cube,
                          {"predicate": "reach", "object": "red_cube"}),
    "tray out of reach": ("tabletop", "tabletop.toml", _far_tray,
                          {"object": "tray"}),
    "no room under a lid": ("tabletop", "tabletop.toml", _lid, {"collides": "lid"}),
    "cube too big to grasp": ("tabletop", "tabletop.toml", _big_cube,
                              {"collides": "red_cube"}),
    "nothing rests on b": ("tower", "tower.toml", _high_support,
                           {"predicate": "on", "object": "b"}),
}


def _names(culprit: dict, want: dict) -> bool:
    if "collides" in want:
        return culprit["kind"] == "collides" and any(
            want["collides"] in pair for pair in culprit["collisions"])
    if "predicate" in want and culprit.get("predicate") != want["predicate"]:
        return False
    objects = culprit.get("objects", []) + [culprit.get("atom", "")]
    return any(want["object"] in str(o) for o in objects) or want["object"] in \
        culprit["message"]


@pytest.mark.parametrize("case", sorted(CASES))
def test_an_infeasible_problem_is_explained(tmp_path, case, capsys):
    from tmpc.runtime.cli.main import main
    example, config, edit, want = CASES[case]
    d = _copy(tmp_path, example)
    _edit_scene(d, edit)
    out = tmp_path / "why.json"
    code = main(["run", str(d / config), "-q", "--time-limit", "4", "--explain", str(out)])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "why no plan:" in err
    report = json.loads(out.read_text())
    assert report["status"] == "partial"
    top = report["culprits"][:3]
    assert any(_names(c, want) for c in top), json.dumps(top, indent=1)


def test_a_solved_run_writes_a_short_report(tmp_path):
    out = tmp_path / "why.json"
    run = run_tmpc("run", EXAMPLES / "tabletop" / "tabletop.toml", "-q", "--explain", out)
    assert run.returncode == 0, run.stderr
    assert json.loads(out.read_text()) == {"status": "solved", "summary": "solved",
                                           "culprits": []}
