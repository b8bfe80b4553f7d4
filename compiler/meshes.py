"""Mesh files as arrays (scaled vertices, faces and their convex hull), kept in the user cache.

Loading a mesh needs trimesh, whose import alone costs ~0.5 s (it brings scipy); the arrays of a
mesh loaded once are read back from ``<cache>/collision/mesh-<key>.npz``, keyed by the file's
contents, the scale and tmpc's code, with ``allow_pickle=False``; written atomically. A file
that cannot be read is rebuilt: the data is always recomputable.
"""

from __future__ import annotations

import hashlib
import io
import zipfile
from pathlib import Path

import numpy as np

from tmpc.compiler.cache import cache_root, code_digest
from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.fileio import atomic_write_bytes

FIELDS = ("vertices", "faces", "hull_vertices", "hull_faces")


def mesh_arrays(path: Path, scale=(1.0, 1.0, 1.0), owner: str = "") -> dict[str, np.ndarray]:
    """The arrays of the mesh file ``path`` at ``scale`` (:data:`FIELDS`). Raises E565 when it
    cannot be read."""
    scale = tuple(float(v) for v in scale)
    try:
        h = hashlib.sha256(Path(path).read_bytes())
    except FileNotFoundError:
        raise SceneError(error("E565", f"collision mesh `{path}` of {owner or 'an object'} cannot "
                               "be loaded (no such file)", None,
                               "collision checks need the mesh: put it there, or set "
                               "TMPC_MESH_PATH to directories that hold it (searched by relative "
                               "path and by file name); `tmpc check` on the configuration lists "
                               "every missing mesh")) from None
    except OSError as exc:
        raise _unreadable(path, owner, exc.strerror or exc) from None
    h.update(repr((scale, code_digest())).encode())
    file = cache_root() / "collision" / f"mesh-{h.hexdigest()[:24]}.npz"
    try:
        with np.load(file, allow_pickle=False) as data:
            arrays = {k: data[k] for k in FIELDS}
        return arrays
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError):
        pass
    arrays = _read_mesh(path, scale, owner)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(file, buf.getvalue())
    except OSError:
        pass                              # a read-only cache is fine: just slower
    return arrays


def _read_mesh(path: Path, scale, owner: str) -> dict[str, np.ndarray]:
    import trimesh
    try:
        mesh = trimesh.load(str(path), force="mesh")
        ok = len(mesh.faces) > 0
    except Exception as exc:  # trimesh raises many kinds for unreadable files
        ok, mesh = False, exc
    if not ok:
        raise _unreadable(path, owner, mesh if isinstance(mesh, Exception) else "no triangles")
    v = np.asarray(mesh.vertices, float) * np.asarray(scale)
    try:
        hull = trimesh.Trimesh(v, np.asarray(mesh.faces), process=False).convex_hull
        hull_v, hull_f = np.asarray(hull.vertices, float), np.asarray(hull.faces, np.int64)
    except Exception:  # noqa: BLE001 - qhull's errors: a flat mesh has no 3-D hull
        hull_v, hull_f = _flat_hull(v)
        if hull_v is None:
            raise _unreadable(path, owner, "its triangles have no area") from None
    return {"vertices": v, "faces": np.asarray(mesh.faces, np.int64),
            "hull_vertices": hull_v, "hull_faces": hull_f}


def _flat_hull(v: np.ndarray):
    """The convex hull of points in a plane (a flat mesh: a plate, one triangle): the 2-D hull
    in that plane as a fan of triangles, vertices ``(k, 3)`` and faces ``(k - 2, 3)``; None
    when the points are on a line."""
    from scipy.spatial import ConvexHull
    c = v.mean(axis=0)
    _, sv, vt = np.linalg.svd(v - c, full_matrices=False)
    if len(sv) < 2 or sv[1] <= 1e-12 * max(sv[0], 1.0):
        return None, None
    uv = (v - c) @ vt[:2].T
    ring = v[ConvexHull(uv).vertices]
    faces = np.array([[0, i, i + 1] for i in range(1, len(ring) - 1)], np.int64)
    return ring, faces


def _unreadable(path: Path, owner: str, why) -> SceneError:
    return SceneError(error("E565", f"collision mesh `{path}` of {owner or 'an object'} cannot "
                            f"be loaded ({why})", None, "use an STL/OBJ/PLY file with triangles"))

