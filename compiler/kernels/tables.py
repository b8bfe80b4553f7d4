"""Static world tables a kernel closes over: entity ids, shapes, support regions, type domains.

Entities are numbered robot frames first (``0 .. F-1``, the order of ``RobotModel.frames``), then
scene objects (``F .. F+M-1``, scene order). A name resolves case-insensitively to a frame (link
or joint name) or an object. The dynamic part of the state (configuration, object poses, which
objects are held) is a kernel *input*; these tables are constants.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tmpc.compiler.meshes import mesh_arrays
from tmpc.compiler.robot import RobotModel
from tmpc.compiler.scene_data import SCENE_VECTORS, scene_vectors
from tmpc.lang.world import Scene, dispatch_shape


@dataclass(frozen=True, eq=False)
class KernelTables:
    model: RobotModel | None
    scene: Scene
    #: entity names in id order
    names: tuple[str, ...]
    #: name (lower case) -> entity id (frames also under their joint names)
    ids: dict[str, int]
    n_frames: int
    #: (E, 3) half-extents (0 for frames and shapeless objects)
    extents: np.ndarray
    #: (E, 2, 3) support box in the entity's own frame (lower, upper); NaN where none
    support_local: np.ndarray
    #: PDDL type (lower case) -> entity ids of the problem's objects of that type
    domains: dict[str, tuple[int, ...]] = field(default_factory=dict)
    #: :data:`SCENE_VECTORS` name -> (E, 3) per-entity vectors (NaN where the scene gives none)
    scene_vectors: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_objects(self) -> int:
        return len(self.names) - self.n_frames

    def entity(self, name: str) -> int | None:
        return self.ids.get(name.lower())


def _mesh_extent(shape) -> tuple[float, float, float]:
    if shape.mesh is not None and shape.mesh.is_file():
        v = mesh_arrays(shape.mesh, shape.scale, "a scene object")["vertices"]
        return tuple(float(x) for x in (v.max(0) - v.min(0)) / 2)
    return (0.0, 0.0, 0.0)


#: half-extents of a shape's box, per kind
_EXTENT = {
    "box": lambda shape: tuple(shape.size),
    "sphere": lambda shape: (shape.radius,) * 3,
    "cylinder": lambda shape: (shape.radius, shape.radius, shape.length / 2),
    "mesh": _mesh_extent,
}


def _extent(shape) -> tuple[float, float, float]:
    if shape is None:
        return (0.0, 0.0, 0.0)
    return dispatch_shape(_EXTENT, shape, "an object's extent")(shape)


def build_tables(scene: Scene, model: RobotModel | None, scope=None) -> KernelTables:
    """Tables for ``scene`` and ``model``; ``scope`` (a checked program's) gives type domains."""
    frames = tuple(model.frames) if model is not None else ()
    names = frames + tuple(o.name for o in scene.objects)
    ids: dict[str, int] = {}
    for i, n in enumerate(names):
        ids.setdefault(n.lower(), i)
    if model is not None:
        for alias, i in model.frame_index.items():
            ids.setdefault(alias.lower(), i)
    E = len(names)
    extents = np.zeros((E, 3))
    support = np.full((E, 2, 3), np.nan)
    vectors = {k: np.full((E, 3), np.nan) for k in SCENE_VECTORS}
    for k, o in enumerate(scene.objects):
        i = len(frames) + k
        extents[i] = _extent(o.shape)
        if o.support is not None:
            support[i, 0], support[i, 1] = o.support.lower, o.support.upper
        for key, v in scene_vectors(o).items():
            vectors[key][i] = v
    domains: dict[str, tuple[int, ...]] = {}
    if scope is not None:
        for type_key in scope.types.parents:
            members = [ids[info.name.key] for info in scope.objects.values()
                       if info.name.key in ids and scope.compatible(info.types, (type_key,))]
            domains[type_key] = tuple(sorted(set(members)))
    return KernelTables(model, scene, names, ids, len(frames), extents, support, domains,
                        vectors)
