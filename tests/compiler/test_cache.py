"""The user cache's parsed URDFs (tmpc.compiler.cache.robot_tree): read back equal to a fresh
parse, used instead of the parser, rebuilt when damaged, and never hiding a missing mesh from a
strict load."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support import raises
from tmpc.lang.world import load_urdf, tree_from_data, tree_to_data

PR2 = "package://example-robot-data/robots/pr2_description/urdf/pr2.urdf"
PANDA = "package://example-robot-data/robots/panda_description/urdf/panda.urdf"


def _no_parse(*a, **k):
    raise AssertionError("the URDF was parsed")


@pytest.mark.parametrize("ref", [PR2, PANDA])
def test_a_tree_survives_its_data_exactly(ref):
    tree = load_urdf(ref)
    assert tree_from_data(tree_to_data(tree)) == tree
    with pytest.raises(ValueError):
        tree_from_data({**tree_to_data(tree), "format": "other/1"})


def test_robot_tree_parses_once_and_rebuilds_a_damaged_entry(tmp_path, monkeypatch):
    import tmpc.compiler.cache as cache
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path / "cache"))
    first = cache.robot_tree(PR2, Path.cwd())
    assert first == load_urdf(PR2)
    (entry,) = (tmp_path / "cache" / "robots").iterdir()
    with monkeypatch.context() as m:
        m.setattr(cache, "load_urdf", _no_parse)
        assert cache.robot_tree(PR2, Path.cwd()) == first
        assert cache.robot_tree(PR2, Path.cwd(), strict_meshes=False) == first
    entry.write_text("{not json")
    assert cache.robot_tree(PR2, Path.cwd()) == first          # parsed again, rewritten
    with monkeypatch.context() as m:
        m.setattr(cache, "load_urdf", _no_parse)
        assert cache.robot_tree(PR2, Path.cwd()) == first


def test_a_missing_mesh_is_not_hidden_by_the_cache(tmp_path, monkeypatch):
    """A URDF whose mesh is missing: the lenient load (cached) drops it, a strict load still
    raises E562, from the cache as from the parser; the mesh restored, strict loads work."""
    import tmpc.compiler.cache as cache
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path / "cache"))
    d = tmp_path / "robot"
    d.mkdir()
    _write_cube(d / "cube.stl")
    (d / "r.urdf").write_text(
        '<robot name="r"><link name="base"><collision><geometry><mesh filename="cube.stl"/>'
        '</geometry></collision></link><link name="tip"><collision><geometry>'
        '<mesh filename="gone.stl"/></geometry></collision></link>'
        '<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        '</robot>')
    lenient = cache.robot_tree(d / "r.urdf", d, strict_meshes=False)
    assert [len(lk.collision) for lk in lenient.links] == [1, 0]
    raises("E562", cache.robot_tree, d / "r.urdf", d, strict_meshes=True)
    with monkeypatch.context() as m:
        m.setattr(cache, "load_urdf", _no_parse)
        assert cache.robot_tree(d / "r.urdf", d, strict_meshes=False) == lenient
    _write_cube(d / "gone.stl")          # same URDF bytes: the entry says it was incomplete
    full = cache.robot_tree(d / "r.urdf", d, strict_meshes=True)
    assert [len(lk.collision) for lk in full.links] == [1, 1]


def _write_cube(path: Path) -> None:
    import trimesh
    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(path)
