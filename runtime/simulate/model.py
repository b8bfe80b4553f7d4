"""The MuJoCo model of a world: the robot from its URDF (meshes MuJoCo cannot read converted to
STL in the tmpc cache) with a position actuator on every joint and, for a mobile base, planar
x/y/yaw joints; the scene's objects as boxes, spheres, cylinders or meshes, each movable one
with a weld for its grasps (docs/physics.md)."""

from __future__ import annotations

import hashlib
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tmpc.compiler.cache import cache_root
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.world import find_file
from tmpc.runtime.timing import BASE_JOINTS, urdf_path
from tmpc.runtime.validate import quat_from_matrix

#: mesh formats MuJoCo reads itself
READABLE = (".stl", ".obj", ".msh")
#: kg/m³ of a movable object (about wood's; a plan says nothing about masses)
DENSITY = 600.0
#: friction of every contact (sliding, torsional, rolling)
FRICTION = (1.0, 0.01, 0.001)
#: s: the physics step
TIMESTEP = 0.002
#: Hz: each joint's position loop is a critically damped oscillator of this natural frequency
#: at the inertia the joint sees in the plan's first configuration (:func:`set_gains`)
TRACKING_HZ = 20.0
#: kg·m² (kg for a prismatic joint): the rotor inertia given to joints whose URDF has none
ARMATURE = 0.1
#: the grasp weld's stiffness (time constant s, damping ratio): as stiff as the time step allows
#: (MuJoCo's default 0.02 s let a held stick sag 3 mm and catch a table's edge)
WELD_SOLREF = (2 * TIMESTEP, 1.0)
# contact bits (contype, conaffinity): the robot touches the scene's objects but not itself nor
# the floor (its base is carried by its actuators); an object in a grasp touches everything
# but the robot (the plan's grasp has no fingers: see docs/physics.md)
ROBOT_BITS = (2, 1)
SCENE_BITS = (1, 1)
FLOOR_BITS = (8, 1)
GRASPED_BITS = (4, 9)


def fail(message: str, hint: str | None = None) -> InputError:
    return InputError(error("E833", message, None, hint))


def readable_mesh(path: Path) -> Path:
    """``path`` itself when MuJoCo reads its format, else an STL copy (trimesh) in the cache,
    written atomically (a temporary file renamed into place)."""
    if path.suffix.lower() in READABLE:
        return path
    key = hashlib.sha256(str(path.resolve()).encode() + path.read_bytes()).hexdigest()[:16]
    out = cache_root() / "simulate" / "meshes" / f"{path.stem}-{key}.stl"
    if not out.exists():
        import trimesh
        mesh = trimesh.load(str(path), force="mesh")
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_name(f"{out.stem}.{os.getpid()}.tmp.stl")
        mesh.export(str(tmp))
        tmp.replace(out)
    return out


def robot_xml(world) -> str:
    """The URDF's text for MuJoCo: visuals dropped, mesh references made absolute and readable,
    fixed links kept as bodies (plans name frames on them)."""
    path = urdf_path(world)
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"<visual\b.*?</visual>", "", text, flags=re.S)

    def mesh(m):
        found = find_file(m.group(2), path.parent)
        if found is None:
            raise fail(f"the robot's mesh {m.group(2)} cannot be found")
        return f'{m.group(1)}"{readable_mesh(found)}"'
    text = re.sub(r'(<mesh\s[^>]*filename=)"([^"]+)"', mesh, text)
    extra = ('<mujoco><compiler discardvisual="true" strippath="false" fusestatic="false" '
             'balanceinertia="true"/></mujoco>')
    return re.sub(r"(<robot\b[^>]*>)", r"\1" + extra, text, count=1)


def mimics(world) -> dict[str, tuple[str, float, float]]:
    """The URDF's mimic joints: name -> (master, multiplier, offset)."""
    out = {}
    for j in ET.parse(urdf_path(world)).getroot().iter("joint"):
        m = j.find("mimic")
        if m is not None:
            out[j.get("name")] = (m.get("joint"), float(m.get("multiplier", 1.0)),
                                  float(m.get("offset", 0.0)))
    return out


def joint_children(world) -> dict[str, str]:
    """The URDF's joints: name -> child link (a plan may name a frame by its joint)."""
    return {j.get("name"): j.find("child").get("link")
            for j in ET.parse(urdf_path(world)).getroot().iter("joint")
            if j.find("child") is not None}


def quat_wxyz(T: np.ndarray) -> list[float]:
    x, y, z, w = quat_from_matrix(T[:3, :3])
    return [float(w), float(x), float(y), float(z)]


@dataclass
class SimModel:
    """A compiled model and the names the replay needs."""

    model: object
    root: str
    movable: list[str]
    joints: list[str] = field(default_factory=list)      # actuated, in actuator order
    welds: dict[str, int] = field(default_factory=dict)  # object -> equality id
    mobile: bool = False


def build_model(world, start_objects: dict[str, np.ndarray], base: np.ndarray | None,
                mobile: bool = False) -> SimModel:
    """The model at the plan's first state. ``start_objects``: each object's world pose;
    ``base``: the robot's root pose; ``mobile``: the base moves (planar joints
    :data:`~tmpc.runtime.timing.BASE_JOINTS` x, y (m) and yaw (rad), in the world frame)."""
    import mujoco
    try:
        spec = mujoco.MjSpec.from_string(robot_xml(world))
    except Exception as exc:          # MuJoCo's own message names the part it could not read
        raise fail(f"MuJoCo cannot load the robot's URDF: {exc}") from None
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    root = spec.worldbody.first_body()
    for b in spec.bodies:
        if b.name != "world":
            b.gravcomp = 1.0
    for g in spec.geoms:
        g.contype, g.conaffinity = ROBOT_BITS
    if mobile:
        root.pos = [0.0, 0.0, float(base[2, 3]) if base is not None else 0.0]
        root.quat = [1.0, 0.0, 0.0, 0.0]
        for name, kind, axis in zip(BASE_JOINTS, ("slide", "slide", "hinge"),
                                    ([1, 0, 0], [0, 1, 0], [0, 0, 1])):
            root.add_joint(name=name, type=getattr(mujoco.mjtJoint, f"mjJNT_{kind.upper()}"),
                           axis=axis)
    elif base is not None:
        root.pos = base[:3, 3].tolist()
        root.quat = quat_wxyz(base)
    joints = []
    for j in spec.joints:
        if j.type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            if j.armature <= 0:
                j.armature = ARMATURE
            joints.append(j.name)
            spec.add_actuator(name=f"act:{j.name}", target=j.name,
                              trntype=mujoco.mjtTrn.mjTRN_JOINT,
                              gaintype=mujoco.mjtGain.mjGAIN_FIXED,
                              biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                              gainprm=[1.0] + [0.0] * 9, biasprm=[0.0, -1.0] + [0.0] * 8)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], name="floor",
                            contype=FLOOR_BITS[0], conaffinity=FLOOR_BITS[1])
    movable = []
    for o in world.scene.objects:
        T = start_objects.get(o.name)
        if T is None or o.shape is None:
            continue
        body = spec.worldbody.add_body(name=f"obj:{o.name}", pos=T[:3, 3].tolist(),
                                       quat=quat_wxyz(T))
        if o.movable:
            body.add_freejoint()
            movable.append(o.name)
            spec.add_equality(name=f"weld:{o.name}", type=mujoco.mjtEq.mjEQ_WELD,
                              objtype=mujoco.mjtObj.mjOBJ_BODY, name1=root.name,
                              name2=f"obj:{o.name}", active=False, solref=list(WELD_SOLREF))
        add_shape(spec, body, o, world)
    try:
        model = spec.compile()
    except Exception as exc:
        raise fail(f"MuJoCo cannot build the scene: {exc}") from None
    welds = {o: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"weld:{o}")
             for o in movable}
    return SimModel(model, root.name, movable, joints, welds, mobile)


def set_gains(sim: SimModel, data) -> np.ndarray:
    """Give each joint's actuator its gains at ``data``'s configuration: kp = m ω², kv = 2 m ω
    (ω = 2π :data:`TRACKING_HZ`, m the joint's diagonal entry of the mass matrix, armature
    included). Returns kv / kp per actuator: the actuator's target is ``q + (kv/kp) v + a/ω²``
    for a reference position q, velocity v and acceleration a, so it pulls with
    kp (q - q_now) + kv (v - v_now) + m a (the diagonal part of the inertial feed-forward)."""
    import mujoco
    model = sim.model
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    w = 2 * np.pi * TRACKING_HZ
    lead = np.zeros(model.nu)
    for i in range(model.nu):
        dof = model.jnt_dofadr[model.actuator_trnid[i, 0]]
        m = max(M[dof, dof], 1e-6)
        kp, kv = m * w * w, 2 * m * w
        model.actuator_gainprm[i, 0] = kp
        model.actuator_biasprm[i, 1:3] = (-kp, -kv)
        lead[i] = kv / kp
    return lead


def add_shape(spec, body, obj, world) -> None:
    import mujoco
    s = obj.shape
    kw = {"name": f"geom:{obj.name}", "density": DENSITY, "friction": list(FRICTION),
          "condim": 4, "contype": SCENE_BITS[0], "conaffinity": SCENE_BITS[1]}
    if s.kind == "box":
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX,
                      size=[max(float(v), 1e-4) for v in s.size], **kw)
    elif s.kind == "sphere":
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[s.radius, 0, 0], **kw)
    elif s.kind == "cylinder":
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[s.radius, s.length / 2, 0],
                      **kw)
    elif s.kind == "mesh":
        mesh_path = find_file(str(s.mesh), Path(world.scene.path).parent)
        if mesh_path is None:
            raise fail(f"the mesh {s.mesh} of {obj.name} cannot be found")
        name = f"mesh:{obj.name}"
        spec.add_mesh(name=name, file=str(readable_mesh(mesh_path)),
                      scale=[float(v) for v in s.scale])
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, **kw)
    else:
        raise fail(f"{obj.name}: a {s.kind} shape has no MuJoCo counterpart here")
