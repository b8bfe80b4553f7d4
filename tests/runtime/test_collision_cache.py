"""Collision meshes kept in the user cache as arrays (tmpc.compiler.meshes, through
tmpc.runtime.collision.geometry): read back equal without the mesh loader, rebuilt when
damaged, keyed by the file's contents."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.support import raises


def _no_load(*a, **k):
    raise AssertionError("the mesh file was loaded")


def _write_cube(path: Path) -> None:
    import trimesh
    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(path)


def test_mesh_arrays_are_read_back_without_the_loader(tmp_path, monkeypatch):
    from tmpc.compiler import meshes
    from tmpc.runtime.collision import geometry
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(geometry, "_MESHES", {})
    mesh = tmp_path / "cube.stl"
    _write_cube(mesh)
    first = geometry.load_mesh(mesh, (2.0, 1.0, 1.0), "cube")
    assert np.ptp(first.vertices, axis=0) == pytest.approx([0.2, 0.1, 0.1])
    assert len(first.hull_faces) == 12
    monkeypatch.setattr(geometry, "_MESHES", {})
    monkeypatch.setattr(meshes, "_read_mesh", _no_load)
    again = geometry.load_mesh(mesh, (2.0, 1.0, 1.0), "cube")
    for name in ("vertices", "faces", "hull_vertices", "hull_faces"):
        assert np.array_equal(getattr(again, name), getattr(first, name))
    # a damaged entry is rebuilt; a changed file is a different entry
    monkeypatch.undo()
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(geometry, "_MESHES", {})
    for entry in (tmp_path / "cache" / "collision").glob("mesh-*.npz"):
        entry.write_bytes(b"garbage")
    assert np.array_equal(geometry.load_mesh(mesh, (2.0, 1.0, 1.0)).vertices, first.vertices)
    mesh.write_bytes(b"solid nothing\nendsolid nothing\n")
    monkeypatch.setattr(geometry, "_MESHES", {})
    raises("E565", geometry.load_mesh, mesh, (2.0, 1.0, 1.0), "cube")


def test_a_missing_mesh_names_the_mesh_path_in_its_hint(tmp_path, monkeypatch):
    """At run time a missing mesh is E565 with the hint a user can act on ($TMPC_MESH_PATH), not
    "use an STL/OBJ/PLY file with triangles" (L 4)."""
    from tmpc.runtime.collision import geometry
    monkeypatch.setattr(geometry, "_MESHES", {})
    d, _ = raises("E565", geometry.load_mesh, tmp_path / "gone.obj", (1.0, 1.0, 1.0), "block")
    assert "no such file" in d.message and "TMPC_MESH_PATH" in d.hint


@pytest.mark.parametrize("name, text", [
    ("cube.stl", None), ("cube.obj", None), ("cube.ply", None),
    ("empty.obj", ""), ("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
    ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ("words.stl", "not a mesh"), ("hollow.stl", "solid nothing\nendsolid nothing\n"),
    ("short.ply", "ply\nformat ascii 1.0\nelement vertex 0\nelement face 0\nend_header\n"),
])
def test_checks_look_at_a_mesh_as_the_loader_reads_it(tmp_path, name, text):
    """`tmpc check`'s cheap look at a mesh (lang, no mesh library) fails exactly the files
    trimesh cannot load with triangles, which the run's E565 rejects."""
    import trimesh

    from tmpc.lang.world.files import mesh_defect
    path = tmp_path / name
    if text is None:
        trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(path)
    else:
        path.write_text(text)
    try:
        loads = len(trimesh.load(str(path), force="mesh").faces) > 0
    except Exception:
        loads = False
    assert (mesh_defect(path) is None) == loads


def test_a_mesh_bounding_ball_is_kept_in_the_first_pass_store(tmp_path, monkeypatch):
    """A mesh's bounding ball is computed once and read back from the store by the next run,
    equal, and it contains every vertex."""
    import trimesh
    from tmpc.runtime.collision import spheres
    from tmpc.runtime.collision.store import FirstPassStore
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path))
    m = trimesh.creation.icosphere(subdivisions=2, radius=0.2)
    mesh = type("Mesh", (), {"vertices": np.asarray(m.vertices) + [0.3, 0, 0.1],
                             "faces": np.asarray(m.faces)})()
    shape = type("Shape", (), {"kind": "mesh"})()
    store = FirstPassStore("ball-test")
    c, r = spheres.ball(shape, mesh, store)
    assert np.linalg.norm(mesh.vertices - c, axis=1).max() <= r
    store.save()
    monkeypatch.setattr(spheres, "bounding_ball", _no_load)
    c2, r2 = spheres.ball(shape, mesh, FirstPassStore("ball-test"))
    assert np.array_equal(c, c2) and r == r2
    with pytest.raises(AssertionError):          # without a store it is computed each time
        spheres.ball(shape, mesh)
