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
