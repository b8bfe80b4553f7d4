"""The world as the inputs describe it: scenes, objects, shapes, the robot, run configurations.

Plain frozen dataclasses (no numpy); every value carries the place it came from (:class:`Origin`:
a file plus a line/column or a JSON path) so a later stage can point at it. Loaders for the three
scene formats and the two legacy run configurations live in :mod:`tmpc.lang.world.loaders` and return
these types. Conventions (docs/world.md): metres and radians; quaternions are **xyzw**; a box
shape has **half**-extents; support regions are boxes in the object's own frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, TypeVar

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]   # x, y, z, w


@dataclass(frozen=True, slots=True)
class Origin:
    """Where a value was written: a file and a line:column (or 0:0) and/or a JSON path/XML path."""

    path: str
    line: int = 0
    column: int = 0
    pointer: str = ""

    def __str__(self) -> str:
        where = self.path
        if self.line:
            where += f":{self.line}:{self.column or 1}"
        if self.pointer:
            where += f" ({self.pointer})"
        return where


_NO_ORIGIN = dict(compare=False, repr=False, default=None)


@dataclass(frozen=True, slots=True)
class Pose:
    """A rigid transform: translation and unit quaternion (xyzw)."""

    translation: Vec3 = (0.0, 0.0, 0.0)
    rotation: Quat = (0.0, 0.0, 0.0, 1.0)

    @staticmethod
    def from_xyz_yaw(x: float, y: float, z: float, yaw: float) -> "Pose":
        return Pose((x, y, z), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)))


@dataclass(frozen=True, slots=True)
class Shape:
    """Collision/visual geometry of an object.

    ``kind``: ``box`` (``size`` = half-extents), ``sphere`` (``radius``), ``cylinder`` (``radius``,
    ``length`` along z, centred), ``mesh`` (``mesh`` path, ``scale`` per axis; ``convex`` says the
    mesh may be treated as convex).
    """

    kind: str
    size: Vec3 = (0.0, 0.0, 0.0)
    radius: float = 0.0
    length: float = 0.0
    mesh: Path | None = None
    scale: Vec3 = (1.0, 1.0, 1.0)
    convex: bool = False


#: the kinds of :class:`Shape`
SHAPE_KINDS = ("box", "sphere", "cylinder", "mesh")

_Case = TypeVar("_Case", bound=Callable)


class ShapeKindError(ValueError):
    """A shape kind that a dispatch table has no case for."""


def dispatch_shape(table: Mapping[str, _Case], shape: "Shape | str", what: str) -> _Case:
    """The case of ``table`` for a shape's kind (``shape``: a :class:`Shape`, or a kind such as
    a URDF geometry's ``kind``). Each module keeps its own table of per-kind functions; a kind
    the table lacks raises :class:`ShapeKindError` naming ``what``, the kind and the kinds the
    table has."""
    kind = shape if isinstance(shape, str) else shape.kind
    case = table.get(kind)
    if case is None:
        raise ShapeKindError(f"{what}: no case for shape kind `{kind}` (this table has "
                             f"{', '.join(table) or 'none'})")
    return case


@dataclass(frozen=True, slots=True)
class Box:
    """Axis-aligned box ``[lower, upper]``."""

    lower: Vec3
    upper: Vec3


@dataclass(frozen=True, slots=True)
class GraspSet:
    """A set of grasps of an object (Lagriffoul XML ``<grasps>``): ``template`` is a frame of the
    gripper's tool in the object's frame (object -> tool). A continuous set (``<gc>``) is every
    rotation of the template about ``axis`` (a unit vector in the object's frame, through its
    origin); a discrete one (``<gf>``) is the template alone (``axis`` None). ``kind`` is the
    ``type`` attribute as written, lower case (``side``, ``top``; ``""`` when absent)."""

    kind: str
    template: Pose
    axis: Vec3 | None = None
    origin: Origin | None = field(**_NO_ORIGIN)


@dataclass(frozen=True, slots=True)
class StablePose:
    """A set of stable orientations of an object (Lagriffoul XML ``<sop>``): the rotation
    ``template`` (the object's orientation resting on a horizontal surface) turned by any angle
    about ``axis`` (a unit vector, world frame once placed), with the object's origin
    ``distance`` above the support surface."""

    template: Quat
    axis: Vec3
    distance: float
    origin: Origin | None = field(**_NO_ORIGIN)


@dataclass(frozen=True, slots=True)
class SceneObject:
    name: str
    pose: Pose
    movable: bool = False
    shape: Shape | None = None
    #: support region (stable placement box) in the object's frame; its presence makes a surface
    support: Box | None = None
    #: the object's pose is relative to this object/robot frame (None: the world)
    parent: str | None = None
    origin: Origin | None = field(**_NO_ORIGIN)
    #: how it can be grasped (Lagriffoul XML ``<grasps>``); empty: not said
    grasps: tuple[GraspSet, ...] = ()
    #: its stable orientations (Lagriffoul XML ``<sop>``); empty: not said
    stable_poses: tuple[StablePose, ...] = ()
    #: the objects initially resting on it (Lagriffoul XML ``<attachments>``); their poses are
    #: still in the world frame (``parent`` stays None)
    attachments: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class RobotSpec:
    urdf: Path
    #: base pose in the world; with ``mobile_base`` the planner moves it in x, y, yaw
    base_pose: Pose = Pose()
    mobile_base: bool = False
    #: initial joint values by joint name (others: 0, clipped into limits)
    joint_values: tuple[tuple[str, float], ...] = ()
    #: joints the planner moves, in order (None: every non-fixed, non-mimic joint)
    controllable: tuple[str, ...] | None = None
    name: str = "robot"
    origin: Origin | None = field(**_NO_ORIGIN)


@dataclass(frozen=True, slots=True)
class Scene:
    path: str
    #: workspace bounds ((xlo, xhi), (ylo, yhi), (zlo, zhi))
    bounds: tuple[tuple[float, float], tuple[float, float], tuple[float, float]]
    robot: RobotSpec | None
    objects: tuple[SceneObject, ...] = ()
    #: pairs of robot link (or joint) / object names whose collisions are ignored
    allowed_collisions: tuple[tuple[str, str], ...] = ()
    #: "tmpc-json" | "tmit-star-json" | "planet-xml"
    format: str = "tmpc-json"

    def object(self, name: str) -> SceneObject | None:
        key = name.lower()
        for o in self.objects:
            if o.name.lower() == key:
                return o
        return None


@dataclass(frozen=True, slots=True)
class RunConfig:
    """A run configuration: what to plan and with which parameters.

    Read from a native manifest TOML, a planet run TOML or a tmit-star problem-spec JSON; every
    path is absolute (resolved against the config file's directory, then the working directory).
    """

    path: str
    domain: Path
    problem: Path
    scene: Path
    #: Lua predicate file (legacy), if any
    semantics: Path | None = None
    #: extra allowed-collision CSV (planet blacklist / tmit-star blocklist)
    allowed_collisions: Path | None = None
    #: mesh directory for planet XML `<geom>` paths
    mesh_dir: Path | None = None
    #: planner parameters by name (coin_bias, gd_tries, min_steps, ...)
    params: tuple[tuple[str, object], ...] = ()
    time_limit: float | None = None
    output: Path | None = None
    #: "tmpc-toml" | "planet-toml" | "tmit-star-json"
    format: str = "tmpc-toml"
    #: a native semantics module (``semantics = "x.tmpc"``): meanings for a classical domain
    module: Path | None = None
    #: the manifest's ``[robot] mobile_base``: overrides the scene's (None: the scene's)
    mobile_base: bool | None = None
    #: the native manifest's ``[names]``: (PDDL name, scene name) pairs, in file order; the scene
    #: loaded for this configuration calls each scene object by its PDDL name
    names: tuple[tuple[str, str], ...] = ()
    #: the native manifest's ``[planner] name``: the planner ``tmpc run`` uses without
    #: ``--planner`` (None: the default); the runtime checks the name (E826)
    planner: str | None = None


#: the penetration depth (m) the legacy planners ignored, by run-configuration format
LEGACY_TOLERANCES: dict[str, float] = {"planet-toml": 0.021, "tmit-star-json": 0.029}


def collision_tolerance(config: RunConfig | None) -> float:
    """The default penetration tolerance (m), for the planner and the validator alike: the
    configuration's ``collision_tolerance`` parameter; else the legacy planner's for a legacy
    configuration (planet 0.021 m for a planet TOML, tmit-star 0.029 m for a tmit-star spec);
    else 0 (also without a configuration)."""
    if config is None:
        return 0.0
    params = dict(config.params)
    if "collision_tolerance" in params:
        return float(params["collision_tolerance"])
    return LEGACY_TOLERANCES.get(config.format, 0.0)
