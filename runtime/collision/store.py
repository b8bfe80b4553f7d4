"""The first pass's precomputed geometry, kept in the user cache between runs.

Most of building a :class:`tmpc.runtime.collision.first_pass.FirstPass` is sphere covers of
every link mesh (subdivision, clustering) and the pair tables of link pairs (fcl GJK distances
on a grid of one or two joints). Both depend only on the mesh contents and the
robot's kinematics, not on the problem, so they are stored in ``<cache>/collision/<key>.npz``:

* covers by the digest of the mesh's vertices and faces (and the cover parameters);
* pair tables by the robot key (URDF and SRDF contents, configuration layout and bounds, the
  table parameters, the tmpc version) and the two geometries' stable names (link, index).

The file holds arrays only and is read with ``allow_pickle=False``; it is written atomically. A
file that cannot be read is ignored (and rebuilt): the data is always recomputable.
"""

from __future__ import annotations

import hashlib
import io
import zipfile
from pathlib import Path

import numpy as np

from tmpc.compiler.cache import cache_root, code_digest
from tmpc.lang.fileio import atomic_write_bytes
from tmpc.lang.world import find_srdf

#: the PairTable fields stored, in order
TABLE_FIELDS = ("cols", "lo", "step", "n", "wrap", "rate", "dist")


class FirstPassStore:
    """Arrays by name, loaded from and saved to one file of the cache."""

    def __init__(self, key: str):
        self.path = cache_root() / "collision" / f"{key}.npz"
        self._dirty = False
        #: the arrays by name, then field (the file's ``name/field`` split at its last slash),
        #: so a lookup does not scan every key (a batch plan makes ~30 lookups)
        self._names: dict[str, dict[str, np.ndarray]] = {}
        for k, v in _read(self.path).items():
            name, _, field = k.rpartition("/")
            self._names.setdefault(name, {})[field] = v

    def get(self, name: str) -> dict[str, np.ndarray] | None:
        """The arrays stored under ``name/`` (None if absent)."""
        found = self._names.get(name)
        return dict(found) if found else None

    def put(self, name: str, arrays: dict[str, np.ndarray]) -> None:
        self._names.setdefault(name, {}).update((k, np.asarray(v)) for k, v in arrays.items())
        self._dirty = True

    def save(self) -> None:
        """Write the file if anything was added (a read-only cache is fine: just slower)."""
        if not self._dirty:
            return
        buf = io.BytesIO()
        np.savez(buf, **{f"{name}/{k}": v for name, fields in self._names.items()
                         for k, v in fields.items()})
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(self.path, buf.getvalue())
            self._dirty = False
        except OSError:
            pass


def _read(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError):
        return {}


def mesh_key(vertices: np.ndarray, faces: np.ndarray, *params) -> str:
    h = hashlib.sha256(np.ascontiguousarray(vertices, float).tobytes())
    h.update(np.ascontiguousarray(faces, np.int64).tobytes())
    h.update(repr(params).encode())
    return h.hexdigest()[:24]


def robot_key(model, *params) -> str:
    """The key of everything that depends on the robot alone (see the module docstring)."""
    h = hashlib.sha256(Path(model.tree.path).read_bytes())
    srdf = find_srdf(Path(model.tree.path))
    if srdf is not None:
        h.update(Path(srdf).read_bytes())
    h.update(repr((tuple(model.q_names), tuple(map(float, model.lower)),
                   tuple(map(float, model.upper)), params, code_digest())).encode())
    return h.hexdigest()[:24]
