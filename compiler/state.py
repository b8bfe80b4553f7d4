"""The continuous and symbolic state shared by the compiler and the runtime, and its JSON form.

A :class:`WorldState` is a robot configuration ``q`` (layout of :class:`RobotModel`), the world
poses of free objects, the objects held by robot frames (kinematic ``link`` effects: the object
keeps the pose it had relative to the frame at the moment of the grasp) and the true discrete
atoms. State JSON (docs/design.md §8, planet/tmit-star field names)::

    {"joints": {name: value}, "base_pose": {"translation": [x, y, z], "rotation": [x, y, z, w]},
     "object_poses": {name: {"translation": [..], "rotation": [..]}},
     "mode": {"atoms": ["(holding r_gripper_tool_frame stick1)", ...],
              "held": {"stick1": "r_gripper_tool_frame"}}}

Missing fields default to the initial state. ``joints`` lists every movable joint, continuous
ones included (planet's output lost those).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from tmpc.compiler.robot import RobotModel, base_yaw, homogeneous, make_fk
from tmpc.compiler.rotations import pose_matrix, quat_from_matrix
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.world import Pose, Scene


@dataclass(frozen=True, eq=False)
class WorldState:
    q: np.ndarray                                    # (n,)
    #: world poses (4x4) of objects that are not held
    poses: dict[str, np.ndarray]
    #: held object -> (robot frame name, T_frame_object 4x4)
    held: dict[str, tuple[str, np.ndarray]] = field(default_factory=dict)
    atoms: frozenset[str] = frozenset()


def initial_state(scene: Scene, model: RobotModel | None) -> WorldState:
    """The scene's start: objects with a ``parent`` are placed relative to it; an object whose
    parent chain ends at the robot (its name, a link or a joint) starts held by that frame."""
    q = model.default_q.copy() if model is not None else np.zeros(0)
    by_name = {o.name.lower(): o for o in scene.objects}
    robot_name = scene.robot.name.lower() if scene.robot is not None else None
    poses: dict[str, np.ndarray] = {}
    held: dict[str, tuple[str, np.ndarray]] = {}
    for o in scene.objects:
        T, anchor = pose_matrix(o.pose), o.parent
        seen = {o.name.lower()}
        while anchor is not None and anchor.lower() in by_name and anchor.lower() not in seen:
            parent = by_name[anchor.lower()]
            seen.add(anchor.lower())
            T, anchor = pose_matrix(parent.pose) @ T, parent.parent
        if anchor is None:
            poses[o.name] = T
        elif model is not None and anchor.lower() == robot_name:
            held[o.name] = (model.tree.root, T)
        elif model is not None and model.frame(anchor) is not None:
            held[o.name] = (anchor, T)
        else:
            poses[o.name] = T      # the loaders reject unknown parents; be lenient here
    return WorldState(q, poses, held)


def world_poses(state: WorldState, model: RobotModel | None, frames=None) -> dict[str, np.ndarray]:
    """World pose of every object; held objects follow their frame (``frames``: FK output at
    ``state.q`` as :class:`tmpc.compiler.robot.Frames`, computed if needed)."""
    out = dict(state.poses)
    if state.held:
        if frames is None:
            frames = make_fk(model)(state.q)
        T = homogeneous(frames)
        for obj, (frame, T_frame_obj) in state.held.items():
            out[obj] = T[model.frame(frame)] @ T_frame_obj
    return out


def grasp(state: WorldState, model: RobotModel, frame: str, obj: str, frames) -> WorldState:
    """Attach ``obj`` to ``frame`` keeping its current world pose (a kinematic `link`)."""
    T_world_frame = homogeneous(frames)[model.frame(frame)]
    T_world_obj = world_poses(state, model, frames)[obj]
    held = dict(state.held)
    held[obj] = (frame, np.linalg.inv(T_world_frame) @ T_world_obj)
    poses = {k: v for k, v in state.poses.items() if k != obj}
    return replace(state, poses=poses, held=held)


def release(state: WorldState, model: RobotModel, obj: str, frames) -> WorldState:
    """Detach ``obj`` where it is now (a kinematic `unlink`)."""
    pose = world_poses(state, model, frames)[obj]
    held = {k: v for k, v in state.held.items() if k != obj}
    return replace(state, poses={**state.poses, obj: pose}, held=held)


# ---------------------------------------------------------------------------------------------
# JSON


def _matrix_to_json(T: np.ndarray) -> dict:
    return {"translation": [float(v) for v in T[:3, 3]],
            "rotation": quat_from_matrix(T[:3, :3]).tolist()}


def state_to_json(state: WorldState, model: RobotModel | None, frames=None) -> dict:
    out: dict = {"joints": {}, "object_poses": {}}
    if model is not None:
        joints = dict(zip(model.q_names, (float(v) for v in state.q)))
        joints.update(model.fixed)
        out["joints"] = {k: v for k, v in joints.items() if k not in ("base_x", "base_y",
                                                                     "base_yaw")}
        if frames is None:
            frames = make_fk(model)(state.q)
        out["base_pose"] = _matrix_to_json(homogeneous(frames)[model.frame(model.tree.root)])
    for name, T in sorted(world_poses(state, model, frames).items()):
        out["object_poses"][name] = _matrix_to_json(T)
    if state.atoms or state.held:
        out["mode"] = {"atoms": sorted(state.atoms),
                       "held": {o: f for o, (f, _) in sorted(state.held.items())}}
    return out


def _bad(msg: str, pointer: str, path: str, hint: str | None = None) -> InputError:
    return InputError(error("E580", f"{path}: {pointer}: {msg}", None, hint))


def _vec(v, n: int, pointer: str, path: str) -> tuple[float, ...]:
    if not isinstance(v, list) or len(v) != n or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        raise _bad(f"expected a list of {n} numbers, found {v!r}", pointer, path)
    return tuple(float(x) for x in v)


def _pose(v, pointer: str, path: str) -> np.ndarray:
    if not isinstance(v, dict):
        raise _bad("expected {\"translation\": [x, y, z], \"rotation\": [x, y, z, w]}", pointer,
                   path)
    t = _vec(v.get("translation", [0, 0, 0]), 3, pointer + "/translation", path)
    r = _vec(v.get("rotation", [0, 0, 0, 1]), 4, pointer + "/rotation", path)
    norm = math.sqrt(sum(x * x for x in r))
    if abs(norm - 1.0) > 1e-3:
        raise _bad(f"the rotation quaternion has norm {norm:.4f}, not 1", pointer + "/rotation",
                   path, "quaternions are [x, y, z, w] with unit norm")
    return pose_matrix(Pose(t, tuple(x / norm for x in r)))


def state_from_json(data, scene: Scene, model: RobotModel | None, base: WorldState,
                    path: str = "<state>") -> WorldState:
    """Read a state JSON value over ``base`` (missing fields keep ``base``'s values)."""
    if not isinstance(data, dict):
        raise _bad("a state is a JSON object", "/", path)
    unknown = set(data) - {"joints", "base_pose", "object_poses", "mode", "action"}
    if unknown:
        raise _bad(f"unknown field(s) {sorted(unknown)}", "/", path,
                   "fields are joints, base_pose, object_poses, mode")
    q = base.q.copy()
    names = {n: i for i, n in enumerate(model.q_names)} if model is not None else {}
    for name, value in (data.get("joints") or {}).items():
        if model is None or (name not in names and name not in model.fixed):
            raise _bad(f"unknown joint `{name}`", f"/joints/{name}", path)
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise _bad(f"joint value must be a number, found {value!r}", f"/joints/{name}", path)
        if name in names:
            q[names[name]] = float(value)
    if "base_pose" in data and model is not None and model.mobile_base:
        T = _pose(data["base_pose"], "/base_pose", path)
        q[0], q[1] = T[0, 3], T[1, 3]
        q[2] = base_yaw(Pose(tuple(T[:3, 3]), tuple(quat_from_matrix(T[:3, :3]).tolist())))
    poses = dict(base.poses)
    held = dict(base.held)
    for name, value in (data.get("object_poses") or {}).items():
        if scene.object(name) is None:
            raise _bad(f"unknown object `{name}`", f"/object_poses/{name}", path)
        if name not in held:
            poses[scene.object(name).name] = _pose(value, f"/object_poses/{name}", path)
    atoms = base.atoms
    mode = data.get("mode")
    if mode is not None and not isinstance(mode, dict):
        raise _bad("`mode` is {\"atoms\": [...], \"held\": {object: frame}}", "/mode", path)
    if isinstance(mode, dict):
        atoms = frozenset(str(a) for a in mode.get("atoms", sorted(atoms)))
        new_held = mode.get("held") or {}
        if new_held:
            T = homogeneous(make_fk(model)(q))
        for obj, frame in new_held.items():
            if scene.object(obj) is None:
                raise _bad(f"unknown object `{obj}`", f"/mode/held/{obj}", path)
            if model is None or model.frame(str(frame)) is None:
                raise _bad(f"unknown robot frame `{frame}`", f"/mode/held/{obj}", path)
            obj = scene.object(obj).name
            T_world_obj = poses.pop(obj, None)
            if T_world_obj is None:
                continue   # already held
            held[obj] = (str(frame), np.linalg.inv(T[model.frame(str(frame))]) @ T_world_obj)
    return WorldState(q, poses, held, atoms)
