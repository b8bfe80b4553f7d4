"""Write a random variation of a Lagriffoul-suite instance: the same files, the initial poses of
the loose objects perturbed, every object still resting on its support and collision-free.

    python examples/lagriffoul/vary.py examples/lagriffoul/<instance> --seed S -o OUT_DIR

reads ``<instance>/run.toml`` (its ``[problem]`` paths, relative to it: ``domain``, ``problem``,
``scene``, ``mesh_dir``, ``semantics``, ...; ``[names]`` and the other tables are copied as they
are) and writes ``OUT_DIR/<scene>.xml`` (the scene's text with only ``<pose>`` values changed) and
``OUT_DIR/run.toml`` (every path absolute, the scene the new one), so ``tmpc run OUT_DIR/run.toml``
works from any directory. The same seed writes the same files.

What varies (docs/benchmarks.md, "Random variations"): each movable object whose support is a
fixed object (its `<attachments>` parent, else the object whose support region it stands on)
moves within that region, up to ``--shift`` metres (default 0.05), and turns about the vertical
by any angle; on a point region (a Hanoi peg, a Non-Monotonic target, a radish's spot) it only
turns. What rests on a movable object (a stack) moves with it. Heights never change. A placement
is kept only when the moved objects' convex hulls (as tmpc's exact collision check sees meshes)
touch nothing they did not rest on at the start, and the robot, in its initial configuration,
touches none of them (tmpc's own collision check; ``--no-robot-check`` skips it).
"""

from __future__ import annotations

import argparse
import math
import os
import random
import re
import sys
import tempfile
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tmpc.lang.diagnostics import TmpcError
from tmpc.lang.source import SourceFile
from tmpc.lang.world import LoadReport, Pose, load_scene, matrix_from_quat, quat_from_matrix
from tmpc.lang.world.loaders import parse_xml

#: [problem] keys holding paths (made absolute in the written run.toml)
PATH_KEYS = ("domain", "problem", "scene", "mesh_dir", "semantics", "allowed_collisions")
TRIES = 60


class VaryError(Exception):
    """An instance vary.py cannot read or vary (the message says why)."""


# ---------------------------------------------------------------------------------------------
# the instance


@dataclass
class Instance:
    run_toml: Path
    problem: dict
    scene_path: Path
    mesh_dir: Path | None


def read_instance(path: Path) -> Instance:
    run_toml = path / "run.toml" if path.is_dir() else path
    try:
        data = tomllib.loads(run_toml.read_text(encoding="utf-8"))
    except OSError as exc:
        raise VaryError(f"cannot read {run_toml}: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise VaryError(f"{run_toml}: malformed TOML: {exc}") from None
    problem = data.get("problem")
    if not isinstance(problem, dict) or not isinstance(problem.get("scene"), str):
        raise VaryError(f"{run_toml}: no [problem] scene = \"...\"")
    base = run_toml.parent
    mesh_dir = base / problem["mesh_dir"] if isinstance(problem.get("mesh_dir"), str) else None
    return Instance(run_toml, problem, (base / problem["scene"]).resolve(),
                    mesh_dir.resolve() if mesh_dir else None)


# ---------------------------------------------------------------------------------------------
# geometry


def matrix(pose: Pose) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = np.array(matrix_from_quat(pose.rotation))
    T[:3, 3] = pose.translation
    return T


def pose_of(T: np.ndarray) -> Pose:
    return Pose(tuple(float(v) for v in T[:3, 3]), quat_from_matrix(T[:3, :3].tolist()))


class Hulls:
    """Each object's mesh as the convex hull fcl checks (cached per mesh file)."""

    def __init__(self):
        self.cache: dict[str, object] = {}

    def geometry(self, obj):
        import fcl
        import trimesh
        key = str(obj.shape.mesh)
        if key not in self.cache:
            m = trimesh.load(obj.shape.mesh, force="mesh")
            m.apply_scale(obj.shape.scale)
            h = m.convex_hull
            faces = np.hstack([np.full((len(h.faces), 1), 3), h.faces]).ravel()
            self.cache[key] = fcl.Convex(np.asarray(h.vertices, float), len(h.faces), faces)
        return self.cache[key]


def collide(hulls: Hulls, a, Ta: np.ndarray, b, Tb: np.ndarray) -> bool:
    import fcl
    oa = fcl.CollisionObject(hulls.geometry(a), fcl.Transform(Ta[:3, :3], Ta[:3, 3]))
    ob = fcl.CollisionObject(hulls.geometry(b), fcl.Transform(Tb[:3, :3], Tb[:3, 3]))
    return fcl.collide(oa, ob, fcl.CollisionRequest(), fcl.CollisionResult()) > 0


# ---------------------------------------------------------------------------------------------
# supports


def find_supports(scene) -> dict[str, str]:
    """object -> the object it rests on: its `<attachments>` parent, else the object with a
    support region under it (its origin within the region, 2 cm around, its bottom within 2 cm
    of the region's height; the nearest in height)."""
    parent = {c: o.name for o in scene.objects for c in o.attachments}
    out: dict[str, str] = {}
    for x in scene.objects:
        if not x.movable:
            continue
        if x.name in parent:
            out[x.name] = parent[x.name]
            continue
        best = None
        for s in scene.objects:
            if s is x or s.support is None:
                continue
            local = np.linalg.inv(matrix(s.pose)) @ np.append(x.pose.translation, 1.0)
            b = s.support
            inside = all(b.lower[i] - 0.02 <= local[i] <= b.upper[i] + 0.02 for i in range(2))
            dz = local[2] - b.upper[2]
            if inside and -0.02 <= dz <= 0.02 and (best is None or abs(dz) < best[0]):
                best = (abs(dz), s.name)
        if best is not None:
            out[x.name] = best[1]
    return out


# ---------------------------------------------------------------------------------------------
# the variation


def vary(scene, seed: int, shift: float = 0.05, robot: RobotCheck | None = None,
         log=lambda msg: None) -> dict[str, Pose]:
    """New world poses for the objects that move (a dict name -> Pose), deterministic in
    ``seed``; ``robot``: also keep the robot's initial configuration clear of them."""
    rng = random.Random(seed)
    by = {o.name: o for o in scene.objects}
    support = find_supports(scene)
    children: dict[str, list[str]] = {}
    for c, p in support.items():
        children.setdefault(p, []).append(c)

    def group(root: str) -> list[str]:
        out, todo = [], [root]
        while todo:
            n = todo.pop()
            out.append(n)
            todo += [c for c in sorted(children.get(n, [])) if by[c].movable]
        return out

    roots = sorted(n for n, p in support.items() if not by[p].movable)
    poses = {o.name: matrix(o.pose) for o in scene.objects}
    start = dict(poses)
    hulls = Hulls()
    # contacts of the start that stay allowed: an object and what it rests on (or a stack)
    resting = {frozenset((c, p)) for c, p in support.items()}
    ancestors: dict[str, set[str]] = {}
    for n in by:
        seen, cur = set(), n
        while cur in support and cur not in seen:
            seen.add(cur)
            cur = support[cur]
            ancestors.setdefault(n, set()).add(cur)
    allowed = {frozenset((a, b)) for a in by for b in ancestors.get(a, ())} | resting

    def clear(moved: list[str], candidate: dict[str, np.ndarray]) -> bool:
        for a in moved:
            for b in by:
                if b in moved or frozenset((a, b)) in allowed:
                    continue
                if collide(hulls, by[a], candidate[a], by[b], poses[b]):
                    return False
        return True

    def place(root: str, reach: float) -> bool:
        s = by[support[root]]
        Ts = poses[s.name]
        box = s.support
        point = all(box.upper[i] - box.lower[i] < 1e-9 for i in range(2))
        members = group(root)
        local0 = np.linalg.inv(Ts) @ start[root][:, 3]
        for _ in range(TRIES):
            yaw = rng.uniform(-math.pi, math.pi)
            if point:
                dx = dy = 0.0
            else:
                r, a = reach * math.sqrt(rng.random()), rng.uniform(-math.pi, math.pi)
                dx, dy = r * math.cos(a), r * math.sin(a)
            x, y = local0[0] + dx, local0[1] + dy
            if not point and not (box.lower[0] <= x <= box.upper[0]
                                  and box.lower[1] <= y <= box.upper[1]):
                continue
            # turn about the support's normal through the root's origin, then shift
            c, si = math.cos(yaw), math.sin(yaw)
            Rn = Ts[:3, :3] @ np.array([[c, -si, 0], [si, c, 0], [0, 0, 1]]) @ Ts[:3, :3].T
            M = np.eye(4)
            M[:3, :3] = Rn
            origin = start[root][:3, 3]
            M[:3, 3] = origin - Rn @ origin + Ts[:3, :3] @ np.array([dx, dy, 0.0])
            candidate = {m: M @ start[m] for m in members}
            if clear(members, candidate):
                poses.update(candidate)
                return True
        return False

    for root in roots:
        members = group(root)
        if not (place(root, shift) or place(root, 4 * shift) or place(root, 100.0)):
            # nothing found: the start, if it touches nothing the moves made
            poses.update({m: start[m] for m in members})
            if not clear(members, poses):
                raise VaryError(f"no collision-free pose for `{root}` on `{support[root]}` "
                                f"within {TRIES * 3} tries (seed {seed})")
            log(f"vary: `{root}` keeps its start (no other free pose found)")
    if robot is not None:
        for round_ in range(4):
            hit = robot.contacts(poses)
            hit = {r for r in roots if set(group(r)) & hit}
            if not hit:
                break
            if round_ == 3:
                raise VaryError(f"the robot touches {', '.join(sorted(hit))} however they "
                                f"are placed (seed {seed})")
            for r in sorted(hit):
                poses.update({m: start[m] for m in group(r)})
                place(r, shift) or place(r, 4 * shift)
    return {n: pose_of(T) for n, T in poses.items() if not np.allclose(T, start[n])}


class RobotCheck:
    """The robot, in its initial configuration, against the objects at given poses: tmpc's own
    collision check (the world compiled once)."""

    def __init__(self, scene):
        from tmpc.compiler.compile import compile_world
        from tmpc.compiler.state import initial_state
        from tmpc.lang.inputs import World
        from tmpc.runtime.collision import collision_world
        world = World(scene)
        compiled = compile_world(world)
        self.start = initial_state(scene, compiled.model)
        self.world = collision_world(world, compiled)
        self.links = set(compiled.model.frames) if compiled.model is not None else set()

    def pairs(self, poses: dict[str, np.ndarray]) -> list[tuple[str, str, float]]:
        """Every colliding pair with the objects at ``poses`` (4x4, world)."""
        placed = {n: poses.get(n, T) for n, T in self.start.poses.items()}
        return list(self.world.check(self.start.q, poses=placed, attached=self.start.held).pairs)

    def contacts(self, poses: dict[str, np.ndarray]) -> set[str]:
        """The objects the robot touches."""
        out = set()
        for a, b, _ in self.pairs(poses):
            if (a in self.links) != (b in self.links):
                out.add(b if a in self.links else a)
        return out


# ---------------------------------------------------------------------------------------------
# writing


def pose_text(pose: Pose) -> str:
    T = matrix(pose)
    rows = [f"{T[i, 0]:.6f} {T[i, 1]:.6f} {T[i, 2]:.6f} {T[i, 3]:.6f}" for i in range(3)]
    return " ".join(rows).replace("-0.000000", "0.000000")


def varied_xml(scene_path: Path, new: dict[str, Pose]) -> str:
    """The scene's text with the `<pose>` of each object in ``new`` replaced (nothing else)."""
    source = SourceFile.read(scene_path)
    root = parse_xml(source, LoadReport())
    edits = []
    objects = root.child("objects")
    for node in objects.all("obj") if objects is not None else []:
        name, pose = node.child("name"), node.child("pose")
        if name is not None and name.text in new and pose is not None and pose.content:
            edits.append((pose.content, pose_text(new[name.text])))
    text = source.text
    for (start, end), value in sorted(edits, reverse=True):
        text = text[:start] + value + text[end:]
    return text


def varied_toml(inst: Instance, scene_out: Path, mesh_dir: Path | None, seed: int) -> str:
    """run.toml with every [problem] path absolute, the scene the varied one, and a mesh_dir
    when the original had none (the copied scene is no longer beside its meshes)."""
    base = inst.run_toml.parent
    lines = [f"# a variation of {inst.run_toml} (examples/lagriffoul/vary.py --seed {seed})"]
    table = ""
    seen = set()
    key_re = re.compile(r"^(\s*)([A-Za-z_][A-Za-z0-9_-]*)(\s*=\s*)(.*)$")
    for line in inst.run_toml.read_text(encoding="utf-8").splitlines():
        head = re.match(r"^\s*\[\s*([^\]]+?)\s*\]", line)
        if head:
            if table == "problem" and mesh_dir is not None and "mesh_dir" not in seen:
                at = len(lines)
                while at > 0 and not lines[at - 1].strip():
                    at -= 1                       # after the table's last key, not its gap
                lines.insert(at, f"mesh_dir = {toml_string(str(mesh_dir))}")
                seen.add("mesh_dir")
            table = head.group(1)
        m = key_re.match(line)
        if table == "problem" and m and m.group(2) in PATH_KEYS and \
                isinstance(inst.problem.get(m.group(2)), str):
            key = m.group(2)
            seen.add(key)
            value = scene_out if key == "scene" else (base / inst.problem[key]).resolve()
            line = f"{m.group(1)}{key}{m.group(3)}{toml_string(str(value))}"
        lines.append(line)
    if table == "problem" and mesh_dir is not None and "mesh_dir" not in seen:
        lines.append(f"mesh_dir = {toml_string(str(mesh_dir))}")
    return "\n".join(lines) + "\n"


def toml_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="vary.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("instance", type=Path, help="an instance folder (with run.toml) or a run.toml")
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("-o", "--output", type=Path, required=True, help="the folder to write")
    ap.add_argument("--shift", type=float, default=0.05,
                    help="largest move within a support region, metres (default 0.05)")
    ap.add_argument("--no-robot-check", action="store_true",
                    help="do not check the robot's initial configuration against the moves")
    args = ap.parse_args(argv)
    try:
        inst = read_instance(args.instance)
        scene = load_scene(inst.scene_path, mesh_dir=inst.mesh_dir)
        robot = None if args.no_robot_check or scene.robot is None else RobotCheck(scene)
        new = vary(scene, args.seed, args.shift, robot, log=lambda m: print(m, file=sys.stderr))
        out = args.output.resolve()
        scene_out = out / inst.scene_path.name
        meshes = {Path(o.shape.mesh).parent for o in scene.objects if o.shape and o.shape.mesh}
        mesh_dir = inst.mesh_dir or (meshes.pop() if len(meshes) == 1 else None)
        write_atomic(scene_out, varied_xml(inst.scene_path, new))
        write_atomic(out / "run.toml", varied_toml(inst, scene_out, mesh_dir, args.seed))
    except (VaryError, TmpcError) as exc:
        print(f"vary.py: {exc}", file=sys.stderr)
        return 1
    print(f"{out / 'run.toml'}: {len(new)} objects moved")
    return 0


if __name__ == "__main__":
    sys.exit(main())
