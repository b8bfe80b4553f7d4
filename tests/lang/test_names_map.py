"""A native run manifest's `[names]`: the scene's objects called by their PDDL names (the
Lagriffoul suite's PDDL says `a` and `red-tray` where its XML says `block_a` and `red_tray`),
and the map's errors, each at its entry."""

from __future__ import annotations

from pathlib import Path

from tests.support import EXAMPLES, pos_of, raises, where
from tmpc.lang.world import LoadReport, load_config, load_config_scene

DATA = EXAMPLES / "lagriffoul" / "data" / "problem2"
NAMES = {"a": "block_a", "b": "block_b", "c": "block_c", "red-tray": "red_tray",
         "blue-tray": "blue_tray"}


def manifest(tmp_path: Path, names: dict[str, str] | str) -> Path:
    body = names if isinstance(names, str) else \
        "".join(f'{k} = "{v}"\n' for k, v in names.items())
    p = tmp_path / "run.toml"
    p.write_text(f"""[problem]
domain = "{DATA / 'blocksworld.pddl'}"
problem = "{DATA / 'blocksworld_pb_C.pddl'}"
scene = "{DATA / 'blocksworld_xml' / 'blocksworldC.xml'}"
mesh_dir = "{DATA / 'blocksworld_meshes'}"

[names]
{body}""")
    return p


def test_objects_take_their_pddl_names(tmp_path):
    config = load_config(manifest(tmp_path, NAMES))
    assert config.names == tuple(NAMES.items())
    scene = load_config_scene(config)
    names = [o.name for o in scene.objects]
    assert names == ["blue-tray", "red-tray", "a", "b", "c", "table", "table_ceiling"]
    assert scene.object("block_a") is None and scene.object("a").movable


def test_attachments_follow_the_names(tmp_path):
    hanoi = EXAMPLES / "lagriffoul" / "data" / "problem1"
    p = tmp_path / "run.toml"
    p.write_text(f"""[problem]
domain = "{hanoi / 'hanoi.pddl'}"
problem = "{hanoi / 'hanoi_pb_3.pddl'}"
scene = "{hanoi / 'hanoi_xml' / 'hanoi3.xml'}"

[names]
d1 = "disc1"
d2 = "disc2"
""")
    scene = load_config_scene(load_config(p))
    assert scene.object("d2").attachments == ("d1",)
    assert scene.object("disc3").attachments == ("d2",)


def test_a_scene_name_the_scene_lacks(tmp_path):
    p = manifest(tmp_path, {**NAMES, "a": "blokc_a"})
    diag, files = raises("E524", load_config_scene, load_config(p))
    assert where(diag, files) == pos_of(p.read_text(), '"blokc_a"')
    assert "did you mean `block_a`" in diag.hint


def test_two_pddl_names_for_one_object(tmp_path):
    p = manifest(tmp_path, 'a = "block_a"\naa = "Block_A"\n')
    diag, files = raises("E525", load_config, p)
    assert where(diag, files) == pos_of(p.read_text(), '"Block_A"')
    assert diag.related and "two PDDL names" in diag.message


def test_pddl_names_equal_but_for_case(tmp_path):
    p = manifest(tmp_path, 'a = "block_a"\nA = "block_b"\n')
    diag, files = raises("E525", load_config, p)
    assert where(diag, files) == pos_of(p.read_text(), 'A = ')


def test_a_pddl_name_another_object_keeps(tmp_path):
    p = manifest(tmp_path, 'table_ceiling = "block_a"\n')
    diag, files = raises("E525", load_config_scene, load_config(p))
    assert where(diag, files) == pos_of(p.read_text(), '"block_a"')
    assert '"table_ceiling"' in diag.message
    # a swap is no clash: after renaming every name is still unique
    swap = manifest(tmp_path, 'table = "table_ceiling"\ntable_ceiling = "table"\n')
    scene = load_config_scene(load_config(swap))
    assert scene.object("table").pose.translation[2] == 0.33


def test_a_name_that_is_no_string_or_no_pddl_name(tmp_path):
    raises("E506", load_config, manifest(tmp_path, "a = 3\n"))
    raises("E518", load_config, manifest(tmp_path, '"a b" = "block_a"\n'))


def test_the_world_and_check_use_the_names(tmp_path):
    from tmpc.lang.inputs import load_world
    world = load_world(manifest(tmp_path, NAMES), with_program=False)
    assert world.scene.object("red-tray") is not None
    report = LoadReport()
    load_config_scene(load_config(manifest(tmp_path, NAMES)), report=report)
    assert not [w for w in report.warnings if w.code.startswith("E")]
