"""Scene loading: JSON with positions, the three scene formats, their errors, the CSV loader,
and every legacy scene of tests/fixtures/legacy."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import FIXTURES, LEGACY, pos_of, raises, where
from tmpc.lang.diagnostics import SceneError, Severity
from tmpc.lang.jsonpos import parse_json, pointer
from tmpc.lang.source import SourceFile
from tmpc.lang.world.loaders import (
    SCENE_LOADERS,
    LoadReport,
    box_to_object_frame,
    load_allowed_pairs,
    load_scene,
    quat_from_matrix,
)
from tmpc.lang.world.scene import Box, Pose

SCENES = FIXTURES / "scenes"
NATIVE = SCENES / "native" / "scene.json"
TMIT = SCENES / "tmit" / "problems" / "demo" / "scenes" / "demo_scene.json"
PLANET = SCENES / "planet" / "demo" / "demo.xml"
S2 = math.sqrt(0.5)


# --------------------------------------------------------------------------------------------
# helpers


def check_error(code: str, path: Path, needle: str, nth: int = 0, **kwargs):
    """Load ``path``: one ``code`` error naming the file, placed where ``needle`` is written."""
    diag, files = raises(code, load_scene, path, **kwargs)
    assert path.name in diag.message
    assert where(diag, files) == pos_of(path.read_text(), needle, nth), diag.message
    return diag


def native_text(**changes) -> str:
    """The native fixture as text, objects/robot edited by ``changes`` (dict merges)."""
    data = json.loads(NATIVE.read_text())
    for key, value in changes.items():
        data[key] = value
    return json.dumps(data, indent=2)


def write_native(tmp_path: Path, text: str, name: str = "scene.json") -> Path:
    """A scene file beside copies of the fixture's URDF and mesh."""
    (tmp_path / "meshes").mkdir(exist_ok=True)
    (tmp_path / "arm2.urdf").write_text((SCENES / "native" / "arm2.urdf").read_text())
    (tmp_path / "meshes" / "wedge.obj").write_text(
        (SCENES / "native" / "meshes" / "wedge.obj").read_text())
    p = tmp_path / name
    p.write_text(text)
    return p


def one_object(**fields) -> dict:
    obj = {"name": "thing", "pose": {"translation": [0, 0, 0], "rotation": [0, 0, 0, 1]},
           "shape": {"type": "box", "half_extents": [0.1, 0.1, 0.1]}}
    obj.update(fields)
    return obj


def close(a, b, tol=1e-6) -> bool:
    return all(abs(x - y) <= tol for x, y in zip(a, b, strict=True))


# --------------------------------------------------------------------------------------------
# jsonpos


def test_json_values_match_json_loads():
    docs = ['{"a": [1, 2.5, -3e2, true, false, null], "b": {"c": "x\\u00e9\\n"}}', "[]", "{}",
            '"just a string"', "0", '[[[[]]]]', '{"": 1, "a/b": 2, "m~n": 3}']
    for text in docs:
        assert parse_json(SourceFile("t.json", text)).value == json.loads(text)


def test_json_pointer_spans():
    text = '{\n  "objects": [\n    {"name": "a", "pose": {"rotation": [0, 0, 0, 1]}}\n  ],\n' \
           '  "a/b": {"m~n": 7}\n}'
    doc = parse_json(SourceFile("t.json", text))
    src = doc.source
    span = doc.spans["/objects/0/pose/rotation"]
    assert text[span.start:span.end] == "[0, 0, 0, 1]"
    assert src.line_col(span.start) == (3, 40)
    assert text[doc.spans["/objects/0/pose/rotation/3"].start] == "1"
    assert text[doc.key_spans["/objects/0/name"].start:doc.key_spans["/objects/0/name"].end] \
        == '"name"'
    assert pointer("a/b", "m~n") == "/a~1b/m~0n"
    assert doc.value["a/b"]["m~n"] == 7
    assert text[doc.spans["/a~1b/m~0n"].start] == "7"
    assert doc.span("/objects/0/missing/deeper") == doc.spans["/objects/0"]


@pytest.mark.parametrize("text, line, col, words", [
    ('{\n  "a": 1,\n}', 3, 1, "comma before a closing bracket"),
    ('{\n  "a": 1\n  "b": 2\n}', 3, 3, "a `,` is missing"),
    ('{"a": "abc\n}', 1, 7, "unterminated"),
    ('{"a": 1, "a": 2}', 1, 10, "given twice"),
    ("", 1, 1, "empty"),
    ('{"a": "x\\qy"}', 1, 9, "escape"),
    ("{'a': 1}", 1, 2, "double quotes"),
    ('{"a": NaN}', 1, 7, "NaN"),
    ('{"a": [1, 2}', 1, 12, "brackets do not match"),
    ('{"a": [1, 2]', 1, 13, "missing"),
    ('{"a": 1} // note', 1, 10, "comments"),
])
def test_json_syntax_errors(text, line, col, words):
    diag, files = raises("E500", parse_json, SourceFile("dir/bad.json", text))
    assert "bad.json" in diag.message
    assert where(diag, files) == (line, col)
    assert words in diag.message + (diag.hint or "")


def test_json_deep_nesting_does_not_recurse():
    text = "[" * 3000 + "]" * 3000
    doc = parse_json(SourceFile("deep.json", text))
    assert len(doc.spans) == 3000


# --------------------------------------------------------------------------------------------
# the three formats: fixtures load with the right values


def test_registry_names_match_scene_format():
    for fmt, path in (("tmpc-json", NATIVE), ("tmit-star-json", TMIT), ("planet-xml", PLANET)):
        assert fmt in SCENE_LOADERS
        assert load_scene(path).format == fmt
        assert load_scene(path, fmt=fmt).format == fmt
    assert set(SCENE_LOADERS) == {"tmpc-json", "tmit-star-json", "planet-xml"}


def test_native_fixture():
    report = LoadReport()
    s = load_scene(NATIVE, report=report)
    assert report.warnings == []
    assert s.bounds == ((-2.0, 2.0), (-2.0, 2.0), (0.0, 2.0))
    r = s.robot
    assert r.name == "arm2" and r.urdf == SCENES / "native" / "arm2.urdf" and not r.mobile_base
    assert r.joint_values == (("shoulder", 0.5), ("elbow", -0.25))
    assert r.controllable == ("shoulder", "elbow")
    bench = s.object("BENCH")
    assert close(bench.pose.rotation, (0, 0, S2, S2))
    assert bench.shape.kind == "box" and bench.shape.size == (0.6, 0.3, 0.4)
    assert bench.support == Box((-0.55, -0.25, 0.4), (0.55, 0.25, 0.45))
    assert not bench.movable
    assert s.object("crate").pose.rotation == (0, 0, 0, 1) and s.object("crate").movable
    assert s.object("ball").shape.radius == 0.03
    can = s.object("can")
    assert (can.shape.kind, can.shape.radius, can.shape.length, can.parent) == \
        ("cylinder", 0.03, 0.12, "fore")
    wedge = s.object("wedge").shape
    assert wedge.mesh == SCENES / "native" / "meshes" / "wedge.obj"
    assert wedge.scale == (0.5, 0.5, 0.5) and wedge.convex
    assert s.object("label").shape is None and s.object("label").parent == "crate"
    assert s.allowed_collisions == (("bench", "base_link"), ("crate", "label"))
    assert s.object("ball").origin.line == pos_of(NATIVE.read_text(), '"name": "ball"')[0] - 1


def test_tmit_fixture():
    report = LoadReport()
    s = load_scene(TMIT, report=report)
    assert report.warnings == []
    r = s.robot
    assert r.mobile_base and r.controllable is None and r.name == "arm2"
    assert r.urdf == SCENES / "tmit" / "models" / "arm2.urdf"      # found 3 levels up
    assert close(r.base_pose.translation, (0.5, -0.5, 0.0))
    assert close(r.base_pose.rotation, (0, 0, S2, S2))             # yaw pi/2
    assert r.joint_values == (("shoulder", 0.3), ("elbow", 0.0))
    desk = s.object("desk")
    assert not desk.movable and desk.shape.size == (0.6, 0.3, 0.35)
    # world-aligned x +-0.25, y +-0.55 under a quarter turn -> object frame x +-0.55, y +-0.25
    assert desk.support == Box((-0.55, -0.25, 0.35), (0.55, 0.25, 0.4))
    cube = s.object("cube_1")
    assert cube.movable and cube.shape.kind == "mesh" and cube.shape.scale == (1.0, 1.0, 2.0)
    assert cube.shape.convex and cube.shape.mesh == SCENES / "tmit" / "models" / "block.obj"
    lid = s.object("lid")
    assert lid.parent == "cube_1" and not lid.shape.convex
    assert lid.pose.rotation == (1.0, 0.0, 0.0, 0.0)    # as written: 180 degrees about x


def test_planet_fixture_poses_against_hand_computed_quaternions():
    s = load_scene(PLANET)
    slab = s.object("slab1")
    # R = [[0,-1,0],[1,0,0],[0,0,1]]: a quarter turn about z -> (0, 0, sin 45, cos 45)
    assert close(slab.pose.translation, (1.5, 0.0, 0.0))
    assert close(slab.pose.rotation, (0, 0, S2, S2))
    assert slab.support == Box((-0.5, -0.2, 0.4), (0.5, 0.2, 0.4))
    # 60 degrees about x, matrix written to 3 decimals: (sin 30, 0, 0, cos 30) within 1e-4
    peg1 = s.object("peg1")
    assert close(peg1.pose.rotation, (0.5, 0.0, 0.0, math.sqrt(3) / 2), 1e-4)
    assert close(peg1.pose.translation, (1.4, 0.1, 0.45)) and peg1.movable
    # half a turn about z -> (0, 0, 1, 0)
    assert close(s.object("peg2").pose.rotation, (0, 0, 1, 0))
    assert slab.shape.mesh == SCENES / "planet" / "demo" / "block.obj" and not slab.shape.convex
    r = s.robot
    assert r.name == "arm" and not r.mobile_base
    assert close(r.base_pose.translation, (0.1, 0.2, 0.0))
    assert r.controllable == ("shoulder", "elbow")
    assert r.joint_values == (("shoulder", 0.5), ("elbow", -0.25))     # &#45; is a minus
    assert s.bounds == ((-2.0, 2.0), (-2.0, 2.0), (0.0, 1.5))
    assert s.object("peg1").origin.line == pos_of(PLANET.read_text(), "<obj>", 1)[0]


def test_quaternion_from_matrix_and_object_frame_boxes():
    for q in [(0, 0, 0, 1), (0, 0, S2, S2), (S2, 0, 0, S2), (0.5, 0.5, 0.5, 0.5),
              (0.1, -0.3, 0.5, math.sqrt(1 - 0.35))]:
        from tmpc.lang.world.loaders import matrix_from_quat
        back = quat_from_matrix(matrix_from_quat(q))
        assert close(back, q) or close(back, tuple(-c for c in q))
    box, exact = box_to_object_frame((1.0, 0.0, 0.0, 0.0), (-1, -2, 0.5), (1, 2, 0.7))
    assert exact and box == Box((-1, -2, -0.7), (1, 2, -0.5))     # 180 deg about x flips y, z
    box, exact = box_to_object_frame((0, 0, math.sin(math.pi / 8), math.cos(math.pi / 8)),
                                     (-1, -1, 0), (1, 1, 0))
    assert not exact and close(box.upper, (math.sqrt(2), math.sqrt(2), 0))


# --------------------------------------------------------------------------------------------
# native scene errors: code, file name, line:column


def test_unknown_key_with_did_you_mean(tmp_path):
    text = NATIVE.read_text().replace('"movable": true,\n      "shape": {"type": "sphere"',
                                      '"moveable": true,\n      "shape": {"type": "sphere"')
    d = check_error("E504", write_native(tmp_path, text), '"moveable"')
    assert "`movable`" in d.hint


def test_wrong_type(tmp_path):
    text = NATIVE.read_text().replace('"radius": 0.03}', '"radius": "small"}')
    d = check_error("E506", write_native(tmp_path, text), '"small"')
    assert "/objects/2/shape/radius" in d.message and "number" in d.message


def test_wrong_length(tmp_path):
    text = NATIVE.read_text().replace("[1.0, 0.1, 0.85]", "[1.0, 0.1]")
    d = check_error("E507", write_native(tmp_path, text), "[1.0, 0.1]")
    assert "3 numbers" in d.message


def test_quaternion_not_unit(tmp_path):
    text = NATIVE.read_text().replace('[0.9, -0.1, 0.83], "rotation": [0.0, 0.0, 0.0, 1.0]',
                                      '[0.9, -0.1, 0.83], "rotation": [0.0, 0.0, 0.0, 2.0]')
    d = check_error("E508", write_native(tmp_path, text), "[0.0, 0.0, 0.0, 2.0]")
    assert "norm 2" in d.message and "x, y, z, w" in d.hint


def test_quaternion_within_tolerance_is_normalised(tmp_path):
    text = NATIVE.read_text().replace('[0.9, -0.1, 0.83], "rotation": [0.0, 0.0, 0.0, 1.0]',
                                      '[0.9, -0.1, 0.83], "rotation": [0.0, 0.0, 0.0, 1.0008]')
    assert load_scene(write_native(tmp_path, text)).object("ball").pose.rotation == (0, 0, 0, 1)


def test_duplicate_object_names(tmp_path):
    text = NATIVE.read_text().replace('"name": "ball"', '"name": "Crate"')
    d = check_error("E510", write_native(tmp_path, text), '"Crate"')
    assert d.related and "first used" in d.related[0].label


def test_support_lower_above_upper(tmp_path):
    text = NATIVE.read_text().replace('"upper": [0.55, 0.25, 0.45]', '"upper": [0.55, 0.25, 0.3]')
    d = check_error("E511", write_native(tmp_path, text), "0.3]")
    assert "upper z" in d.message


def test_empty_bounds(tmp_path):
    text = NATIVE.read_text().replace("[0.0, 2.0]]", "[2.0, 0.0]]")
    check_error("E511", write_native(tmp_path, text), "[2.0, 0.0]")


def test_negative_size(tmp_path):
    text = NATIVE.read_text().replace('"length": 0.12', '"length": -0.12')
    d = check_error("E512", write_native(tmp_path, text), "-0.12")
    assert "positive" in d.message


def test_unknown_parent(tmp_path):
    text = NATIVE.read_text().replace('"parent": "crate"', '"parent": "crat"')
    d = check_error("E513", write_native(tmp_path, text), '"crat"')
    assert "`crate`" in d.hint


def test_parent_loop(tmp_path):
    text = NATIVE.read_text().replace('"movable": true,\n      "shape": {"type": "box", '
                                      '"half_extents": [0.05',
                                      '"movable": true, "parent": "label",\n      "shape": '
                                      '{"type": "box", "half_extents": [0.05')
    d = check_error("E513", write_native(tmp_path, text), '"label"')
    assert "loop" in d.message and "crate -> label -> crate" in d.message


def test_missing_mesh_strict_lenient_and_fallback(tmp_path):
    text = NATIVE.read_text().replace("meshes/wedge.obj", "meshes/gone.obj")
    path = write_native(tmp_path, text)
    d = check_error("E514", path, '"meshes/gone.obj"')
    assert "gone.obj" in d.hint                        # where it looked
    report = LoadReport()
    s = load_scene(path, strict_meshes=False, report=report)
    assert [w.code for w in report.warnings] == ["W501"]
    assert report.warnings[0].severity is Severity.WARNING
    assert s.object("wedge").shape.mesh == tmp_path / "meshes" / "gone.obj"
    extra = tmp_path / "elsewhere"
    extra.mkdir()
    (extra / "gone.obj").write_text("v 0 0 0\n")
    s = load_scene(path, mesh_fallback_dirs=[extra])
    assert s.object("wedge").shape.mesh == extra / "gone.obj"


def test_missing_urdf(tmp_path):
    text = NATIVE.read_text().replace('"urdf": "arm2.urdf"', '"urdf": "robots/arm3.urdf"')
    d = check_error("E560", write_native(tmp_path, text), '"robots/arm3.urdf"')
    assert str(tmp_path / "robots" / "arm3.urdf") in d.hint


def test_malformed_urdf(tmp_path):
    path = write_native(tmp_path, NATIVE.read_text())
    (tmp_path / "arm2.urdf").write_text('<robot name="x">\n  <link name="a">\n</robot>\n')
    d, files = raises("E561", load_scene, path)
    assert "arm2.urdf" in d.message and where(d, files) == (3, 1)


def test_unknown_joint_and_fixed_controllable(tmp_path):
    text = NATIVE.read_text().replace('"elbow": -0.25', '"elbo": -0.25')
    d = check_error("E564", write_native(tmp_path, text), '"elbo"')
    assert "`elbow`" in d.hint
    urdf = (SCENES / "native" / "arm2.urdf").read_text().replace(
        '<joint name="elbow" type="revolute">', '<joint name="elbow" type="fixed">')
    path = write_native(tmp_path, NATIVE.read_text())
    (tmp_path / "arm2.urdf").write_text(urdf)
    d = check_error("E564", path, '"elbow"', 1)
    assert "fixed or mimic" in d.message


def test_unknown_shape_type(tmp_path):
    text = NATIVE.read_text().replace('"type": "sphere"', '"type": "sphre"')
    d = check_error("E517", write_native(tmp_path, text), '"sphre"')
    assert "`sphere`" in d.hint


def test_missing_required_key(tmp_path):
    text = native_text(objects=[{"name": "x", "shape": None}], allowed_collisions=[])
    d = check_error("E505", write_native(tmp_path, text), '{\n      "name": "x"')
    assert '"pose"' in d.message


def test_bad_name_and_unknown_collision_pair(tmp_path):
    text = native_text(objects=[one_object(name="two words")], allowed_collisions=[])
    check_error("E518", write_native(tmp_path, text), '"two words"')
    text = native_text(objects=[one_object()], allowed_collisions=[["thing", "uper"]])
    d = check_error("E513", write_native(tmp_path, text), '[\n      "thing"')
    assert "`upper`" in d.hint


def test_allowed_collisions_from_csv(tmp_path):
    (tmp_path / "pairs.csv").write_text("thing, upper\n")
    text = native_text(objects=[one_object()], allowed_collisions="pairs.csv")
    assert load_scene(write_native(tmp_path, text)).allowed_collisions == (("thing", "upper"),)


def test_unknown_format_version_and_undetectable(tmp_path):
    text = NATIVE.read_text().replace('"tmpc-scene/1"', '"tmpc-scene/9"')
    check_error("E519", write_native(tmp_path, text), '"tmpc-scene/9"')
    check_error("E503", write_native(tmp_path, '{"bounds": []}'), "{")
    d, _ = raises("E503", load_scene, NATIVE, fmt="tmit-json")
    assert "tmit-star-json" in d.hint


def test_independent_errors_are_reported_together(tmp_path):
    text = native_text(objects=[one_object(name="a", shape={"type": "sphere", "radius": -1}),
                                one_object(name="b", pose={"translation": [0, 0]})],
                       allowed_collisions=[])
    with pytest.raises(SceneError) as info:
        load_scene(write_native(tmp_path, text))
    assert [d.code for d in info.value.diagnostics] == ["E512", "E507"]


def test_unreadable_scene_files(tmp_path):
    d, _ = raises("E010", load_scene, tmp_path / "nope.json")
    assert "nope.json" in d.message
    (tmp_path / "latin1.json").write_bytes(b'{"format": "caf\xe9"}')
    raises("E011", load_scene, tmp_path / "latin1.json")


# --------------------------------------------------------------------------------------------
# tmit-star errors and warnings


def tmit_copy(tmp_path: Path, text: str) -> Path:
    """A tmit-star-like tree: <root>/models/..., <root>/problems/x/scenes/scene.json."""
    (tmp_path / "models").mkdir(parents=True)
    for f in ("arm2.urdf", "block.obj"):
        (tmp_path / "models" / f).write_text((SCENES / "tmit" / "models" / f).read_text())
    d = tmp_path / "problems" / "x" / "scenes"
    d.mkdir(parents=True)
    (d / "scene.json").write_text(text)
    return d / "scene.json"


def test_tmit_unknown_keys_warn_and_missing_urdf_lists_places(tmp_path):
    text = TMIT.read_text().replace('"hide_name": true', '"hide_nam": true')
    report = LoadReport()
    load_scene(tmit_copy(tmp_path, text), report=report)
    assert [w.code for w in report.warnings] == ["W500"]
    assert "`hide_name`" not in (report.warnings[0].hint or "")    # ignored keys are not offered
    text = TMIT.read_text().replace("models/arm2.urdf", "models/pr2.urdf")
    path = tmit_copy(tmp_path / "b", text)
    d = check_error("E560", path, '"models/pr2.urdf"')
    assert str(tmp_path / "b" / "models" / "pr2.urdf") in d.hint
    assert str(path.parent / "models" / "pr2.urdf") in d.hint


def test_tmit_shape_errors(tmp_path):
    text = TMIT.read_text().replace('{"type": "box", "extents": [0.02', '{"type": "sphere", '
                                    '"extents": [0.02')
    check_error("E517", tmit_copy(tmp_path, text), '"sphere"')
    text = TMIT.read_text().replace('"shape": {"type": "box", "extents": [0.02, 0.02, 0.05]}, ', '')
    d = check_error("E505", tmit_copy(tmp_path / "b", text), '{"name": "peg_1"')
    assert "geometry" in d.message
    text = TMIT.read_text().replace('"translation": [0.5, -0.5]', '"translation": [0.5, -0.5, 0]')
    check_error("E507", tmit_copy(tmp_path / "c", text), "[0.5, -0.5, 0]")


def test_tmit_missing_mesh_and_unknown_joint(tmp_path):
    text = TMIT.read_text().replace('"elbow": 0.0', '"wrist": 0.0')
    path = tmit_copy(tmp_path, text)
    (tmp_path / "models" / "block.obj").unlink()
    check_error("E514", path, '"models/block.obj"')
    report = LoadReport()
    s = load_scene(path, strict_meshes=False, report=report)
    assert sorted(w.code for w in report.warnings) == ["W501", "W501", "W502"]
    assert s.robot.joint_values == (("shoulder", 0.3),)        # the unknown joint is dropped
    assert s.object("cube_1").shape.mesh == tmp_path / "models" / "block.obj"


def test_tmit_rotated_surface_is_approximated_with_warning(tmp_path):
    text = TMIT.read_text().replace('"rotation": [0.0, 0.0, 0.7071068, 0.7071068]},\n   "shape"',
                                    '"rotation": [0.0, 0.0, 0.3826834, 0.9238795]},\n   "shape"')
    report = LoadReport()
    load_scene(tmit_copy(tmp_path, text), report=report)
    assert [w.code for w in report.warnings] == ["W504"]


# --------------------------------------------------------------------------------------------
# planet XML errors


def planet_copy(tmp_path: Path, text: str) -> Path:
    (tmp_path / "models").mkdir(parents=True)
    (tmp_path / "models" / "arm2.urdf").write_text((SCENES / "planet" / "models" /
                                                    "arm2.urdf").read_text())
    (tmp_path / "demo").mkdir()
    (tmp_path / "demo" / "block.obj").write_text("v 0 0 0\n")
    (tmp_path / "demo" / "demo.xml").write_text(text)
    return tmp_path / "demo" / "demo.xml"


def test_planet_malformed_xml(tmp_path):
    text = PLANET.read_text().replace("</moveable>\n      <grasps>", "</moveabl>\n      <grasps>")
    d = check_error("E501", planet_copy(tmp_path, text), "</moveabl>", **{})
    assert "malformed XML" in d.message


def test_planet_pose_errors(tmp_path):
    text = PLANET.read_text().replace("-1 0 0 -1.0 0 -1 0 0.5 0 0 1 0.45", "-1 0 0 -1.0 0 -1 0 0.5")
    d = check_error("E507", planet_copy(tmp_path, text), "-1 0 0 -1.0 0 -1 0 0.5")
    assert '<obj> "peg2" <pose>' in d.message and "found 8" in d.message
    text = PLANET.read_text().replace("-1 0 0 -1.0 0 -1 0 0.5 0 0 1 0.45",
                                      "-1 0 0 -1.0 0 -1 0 0.5 0 0 2 0.45")
    d = check_error("E509", planet_copy(tmp_path / "b", text), "-1 0 0 -1.0")
    assert "not a rotation" in d.message
    # a `nan` among twelve numbers: said as such (it once read "needs 12 or 16, found 12")
    text = PLANET.read_text().replace("-1 0 0 -1.0 0 -1 0 0.5 0 0 1 0.45",
                                      "-1 0 0 -1.0 0 -1 0 0.5 0 0 1 nan")
    d = check_error("E507", planet_copy(tmp_path / "n", text), "-1 0 0 -1.0 0 -1 0 0.5 0 0 1 nan")
    assert "needs finite numbers, found 'nan'" in d.message
    text = PLANET.read_text().replace("-1 0 0 -1.0 0 -1 0 0.5 0 0 1 0.45",
                                      "-1 0 0 -1.0 0 1 0 0.5 0 0 1 0.45")
    d = check_error("E509", planet_copy(tmp_path / "c", text), "-1 0 0 -1.0")
    assert "reflection" in d.message
    text = PLANET.read_text().replace("1 0 0 0.1 0 1", "1 0 0 x 0 1")
    check_error("E506", planet_copy(tmp_path / "d", text), "1 0 0 x 0 1")


def test_planet_structure_errors(tmp_path):
    text = PLANET.read_text().replace("<name>peg2</name>", "")
    d = check_error("E505", planet_copy(tmp_path, text), "<obj>", 2)
    assert "<name>" in d.message
    text = PLANET.read_text().replace("<moveable>true</moveable>\n    </obj>",
                                      "<moveable>yes</moveable>\n    </obj>")
    check_error("E506", planet_copy(tmp_path / "b", text), "yes")
    text = PLANET.read_text().replace('<joint name="elbow">', '<joint name="elbw">')
    d = check_error("E564", planet_copy(tmp_path / "c", text), '<joint name="elbw">')
    assert "`elbow`" in d.hint
    text = PLANET.read_text().replace("<xmin>-0.5</xmin><xmax>0.5</xmax>",
                                      "<xmin>0.5</xmin><xmax>-0.5</xmax>")
    check_error("E511", planet_copy(tmp_path / "d", text), "-0.5</xmax>")
    text = PLANET.read_text().replace("<urdf>models/arm2.urdf</urdf>", "<urdf>models/x.urdf</urdf>")
    check_error("E560", planet_copy(tmp_path / "e", text), "models/x.urdf")


def test_planet_mesh_dir_and_missing_bounds(tmp_path):
    text = PLANET.read_text()
    start, end = text.index("<workspace_bounds>"), text.index("</workspace_bounds>")
    path = planet_copy(tmp_path, text[:start] + text[end + len("</workspace_bounds>"):])
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "block.obj").write_text("v 0 0 0\n")
    report = LoadReport()
    s = load_scene(path, mesh_dir=meshes, report=report)
    assert s.object("slab1").shape.mesh == meshes / "block.obj"
    assert [w.code for w in report.warnings] == ["W505"]
    assert s.bounds[2][0] == 0.0 and s.bounds[0] == (-3.0, 3.5)
    (meshes / "block.obj").unlink()
    d = check_error("E514", path, "block.obj", mesh_dir=meshes)
    assert str(meshes / "block.obj") in d.hint


# --------------------------------------------------------------------------------------------
# allowed-collision CSV


def test_allowed_pairs_csv(tmp_path):
    p = tmp_path / "pairs.csv"
    p.write_text("# robot link / object pairs\nbase_link, bench\nupper,fore\n\n fore , can\n"
                 "fore,upper\n")
    assert load_allowed_pairs(p) == (("base_link", "bench"), ("upper", "fore"), ("fore", "can"))
    p.write_text("a,b\nb , a\n\n# note\nc,d,e\n")
    d, files = raises("E516", load_allowed_pairs, p)
    assert "pairs.csv" in d.message and "line 5" in d.message
    assert where(d, files) == (5, 1)


# --------------------------------------------------------------------------------------------
# import weight and the real legacy files


def test_loaders_do_not_import_heavy_modules():
    code = ("import sys, tmpc.lang.world.loaders, tmpc.lang.jsonpos\n"
            "print(sorted(m for m in ('numpy', 'jax', 'z3', 'lxml', 'yourdfpy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


PR2 = "package://example-robot-data/robots/pr2_description/urdf/pr2.urdf"


def test_every_legacy_scene_loads():
    """Every legacy scene of tests/fixtures/legacy (planet XML beside its PDDL, tmit-star JSON in
    <task>/scenes/, laid out as the two repositories lay theirs out) loads; their meshes are not
    shipped, so the only warnings are W501."""
    planet = sorted((LEGACY / "planet").glob("*/*.xml"))
    tmit = sorted((LEGACY / "tmit-star").glob("*/scenes/*.json"))
    warnings = LoadReport()
    for f in planet:
        s = load_scene(f, mesh_dir=f.parent, strict_meshes=False, report=warnings)
        assert s.format == "planet-xml" and s.robot.name == "pr2" and s.robot.mobile_base
        assert s.objects
    for f in tmit:
        s = load_scene(f, strict_meshes=False, report=warnings)
        assert s.format == "tmit-star-json" and s.robot.mobile_base and s.objects
    assert warnings.warnings and {w.code for w in warnings.warnings} == {"W501"}
    assert (len(planet), len(tmit)) == (3, 3)

    # planet: mixtable is R = [[0,-1,0],[1,0,0],[0,0,1]] at (1.6, 0, 0); red1 unrotated
    c1 = load_scene(LEGACY / "planet" / "two-table-sort" / "scene_1.xml", strict_meshes=False)
    mix = c1.object("mixtable")
    assert close(mix.pose.rotation, (0, 0, S2, S2)) and close(mix.pose.translation, (1.6, 0, 0))
    assert mix.support == Box((-0.6, -0.3, 0.72), (0.6, 0.3, 0.72))
    assert c1.object("red1").pose == Pose((1.5, 0.1, 0.82), (0, 0, 0, 1))
    assert not mix.movable and c1.object("red1").movable
    assert dict(c1.robot.joint_values)["torso_lift_joint"] == 0.1        # from <torso>
    assert dict(c1.robot.joint_values)["l_elbow_flex_joint"] == -2.0
    # tmit-star's bin-picking work table is the same table (same pose) with its top written
    # world-aligned (x +-0.3, y +-0.6); in the object frame it is planet's sssp
    t1 = load_scene(LEGACY / "tmit-star" / "bin-picking" / "scenes" / "pb_1_initial_scene.json",
                    strict_meshes=False)
    table = t1.object("work_table")
    assert close(table.pose.rotation, mix.pose.rotation, 1e-6)
    assert close(table.pose.translation, mix.pose.translation)
    assert close(table.support.lower, mix.support.lower) and close(table.support.upper,
                                                                   mix.support.upper)
    assert dict(t1.robot.joint_values)["torso_lift_joint"] == 0.1


def test_legacy_meshes_from_a_fallback_dir(tmp_path):
    for name in ("table.obj", "bolt.obj", "bracket.obj", "cylinder_red.obj", "cylinder_green.obj"):
        (tmp_path / name).write_text("v 0 0 0\n")
    s = load_scene(LEGACY / "tmit-star" / "bin-picking" / "scenes" / "pb_1_initial_scene.json",
                   mesh_fallback_dirs=[tmp_path])               # "models/table.obj": by name
    assert s.object("work_table").shape.mesh == tmp_path / "table.obj"
    assert s.object("bracket_A").shape.mesh == tmp_path / "bracket.obj"
    s = load_scene(LEGACY / "planet" / "two-table-sort" / "scene_1.xml",
                   mesh_dir=tmp_path / "no-such-dir", mesh_fallback_dirs=[tmp_path])
    assert s.object("mixtable").shape.mesh == tmp_path / "table.obj"
    assert s.object("green2").shape.mesh == tmp_path / "cylinder_green.obj"


def test_legacy_collision_lists():
    from tmpc.lang.world import load_urdf
    links = {link.name for link in load_urdf(PR2).links}
    files = sorted(LEGACY.glob("*/models/*.csv"))
    assert [f.parent.parent.name for f in files] == ["planet", "tmit-star"]
    for f in files:
        pairs = load_allowed_pairs(f)
        assert pairs and all(a and b for a, b in pairs)
        assert {name for pair in pairs for name in pair} <= links, f


# --------------------------------------------------------------------------------------------
# robustness: any value swapped for any other kind is a SceneError (never a crash)

_SWAPS = [None, True, -1, 0.0, "x", [], {}, [1, 2, 3], {"type": "box"}]


def _swapped(data, ptr_parts, value):
    data = json.loads(json.dumps(data))
    cur = data
    for p in ptr_parts[:-1]:
        cur = cur[p]
    cur[ptr_parts[-1]] = value
    return data


def _pointers(value, parts=()):
    yield parts
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _pointers(v, parts + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _pointers(v, parts + (i,))


@pytest.mark.parametrize("fixture", [NATIVE, TMIT], ids=["native", "tmit-star"])
def test_swapping_any_value_never_crashes(tmp_path, fixture):
    if fixture == NATIVE:
        path = write_native(tmp_path, "")
    else:
        path = tmit_copy(tmp_path, "")
    data = json.loads(fixture.read_text())
    outcomes = {"ok": 0, "error": 0}
    for i, parts in enumerate(list(_pointers(data))[1:]):
        for value in (_SWAPS[i % len(_SWAPS)], _SWAPS[(i + 4) % len(_SWAPS)]):  # 2 kinds each
            path.write_text(json.dumps(_swapped(data, parts, value), indent=1))
            try:
                load_scene(path, strict_meshes=False)
                outcomes["ok"] += 1
            except SceneError as exc:
                assert exc.diagnostics and all(d.code.startswith(("E5", "W5")) for d in
                                               exc.diagnostics), exc
                assert all(d.span is not None for d in exc.diagnostics), exc
                outcomes["error"] += 1
    assert outcomes["error"] > outcomes["ok"] > 0


def test_cutting_the_planet_xml_anywhere_never_crashes(tmp_path):
    text = PLANET.read_text()
    path = planet_copy(tmp_path, text)
    for cut in range(0, len(text), 7):
        for variant in (text[:cut], text[:cut] + text[cut + 7:]):
            path.write_text(variant)
            try:
                load_scene(path, strict_meshes=False)
            except SceneError as exc:
                assert all(d.code.startswith(("E5", "W5")) for d in exc.diagnostics), exc


def test_xml_positions_count_characters_not_bytes(tmp_path):
    text = PLANET.read_text().replace("<problem>", "<!-- café, Größe, 机器人 -->\n<problem>")
    text = text.replace("-1 0 0 -1.0 0 -1 0 0.5 0 0 1 0.45", "-1 0 0 -1.0 0 -1 0 0.5")
    check_error("E507", planet_copy(tmp_path, text), "-1 0 0 -1.0 0 -1 0 0.5")


def test_a_position_kilometres_away_is_an_error_at_its_object(tmp_path):
    """An object at x = 1e308 was accepted, and the planner wandered for its whole time limit."""
    text = NATIVE.read_text().replace('"translation": [1.0, 0.0, 0.4]',
                                      '"translation": [1e308, 0.0, 0.4]')
    p = write_native(tmp_path, text)
    diag, files = raises("E520", load_scene, p)
    assert "is 1e+308 m from the origin" in diag.message and p.name in diag.message
    line, _ = where(diag, files)
    assert abs(line - pos_of(text, "1e308")[0]) <= 3, diag.message
