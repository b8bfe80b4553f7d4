"""The MuJoCo model of a world: the robot from its URDF (meshes MuJoCo cannot read converted to
STL in the tmpc cache), the scene's objects as boxes, spheres, cylinders or meshes."""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import numpy as np

from tmpc.compiler.cache import cache_root
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.world import find_file
from tmpc.runtime.timing import urdf_path
from tmpc.runtime.validate import quat_from_matrix

#: mesh formats MuJoCo reads itself
READABLE = (".stl", ".obj", ".msh")
#: kg/m³ of a movable object (about wood's; a plan says nothing about masses)
DENSITY = 600.0


def fail(message: str, hint: str | None = None) -> InputError:
    return InputError(error("E833", message, None, hint))


def readable_mesh(path: Path) -> Path:
    """``path`` itself when MuJoCo reads its format, else an STL copy (trimesh) in the cache."""
    if path.suffix.lower() in READABLE:
        return path
    key = hashlib.sha256(str(path.resolve()).encode() + path.read_bytes()).hexdigest()[:16]
    out = cache_root() / "simulate" / "meshes" / f"{path.stem}-{key}.stl"
    if not out.exists():
        import trimesh
        mesh = trimesh.load(str(path), force="mesh")
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_suffix(".tmp.stl")
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


def quat_wxyz(T: np.ndarray) -> list[float]:
    x, y, z, w = quat_from_matrix(T[:3, :3])
    return [float(w), float(x), float(y), float(z)]


def build_model(world, start_objects: dict[str, np.ndarray], base: np.ndarray | None):
    """(MjModel, the robot's root body name, movable object names). ``start_objects``: each
    object's world pose at the plan's first state; ``base``: the robot's root pose."""
    import mujoco
    try:
        spec = mujoco.MjSpec.from_string(robot_xml(world))
    except Exception as exc:          # MuJoCo's own message names the part it could not read
        raise fail(f"MuJoCo cannot load the robot's URDF: {exc}") from None
    spec.option.timestep = 0.002
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    root = spec.worldbody.first_body()
    if base is not None:
        root.pos = base[:3, 3].tolist()
        root.quat = quat_wxyz(base)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], name="floor")
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
        add_shape(spec, body, o, world)
    try:
        return spec.compile(), root.name, movable
    except Exception as exc:
        raise fail(f"MuJoCo cannot build the scene: {exc}") from None


def add_shape(spec, body, obj, world) -> None:
    import mujoco
    s = obj.shape
    kw = {"name": f"geom:{obj.name}", "density": DENSITY, "friction": [1.0, 0.01, 0.001],
          "condim": 4}
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
