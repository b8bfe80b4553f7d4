"""Writing an artifact (`tmpc compile -o x.tmpa`): the checked sources, the normalized scene with
the robot and meshes by content hash, the lifted kernels serialized with ``jax.export``, and the
SMT step templates; see :mod:`tmpc.compiler.artifact` for the format and for reading it."""

from __future__ import annotations

import io
import json
import re
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from tmpc.compiler.artifact import (
    FORMAT,
    MAGIC_MEMBER,
    digest,
    is_artifact,
    open_world,
    read_manifest,
)
from tmpc.compiler.cache import (
    cache_root,
    code_digest,
    package_version,
    robot_tree,
    run_artifact,
    source_key,
)
from tmpc.compiler.compile import compile_world
from tmpc.compiler.ground import GroundingError, ground
from tmpc.compiler.kernels import Options
from tmpc.compiler.smt import smtlib_templates
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_bytes
from tmpc.lang.inputs import load_world
from tmpc.lang.world import dispatch_shape, extras_json, find_file, find_srdf


@dataclass
class _Members:
    files: dict[str, bytes] = field(default_factory=dict)

    def add(self, name: str, data: bytes) -> str:
        self.files[name] = data
        return name

    def blob(self, data: bytes, suffix: str) -> str:
        return self.add(f"blobs/{digest(data)[:32]}{suffix.lower()}", data)


_FILENAME = re.compile(r'filename\s*=\s*"([^"]+)"')


def _pack_urdf(members: _Members, urdf: Path) -> str:
    """Store the URDF with each mesh reference rewritten to a blob (relative to src/)."""
    text = urdf.read_text(encoding="utf-8")

    def repl(m: re.Match) -> str:
        found = find_file(m.group(1), urdf.parent)
        if found is None:
            return m.group(0)           # textures etc. that are absent: left as they were
        name = members.blob(found.read_bytes(), found.suffix)
        return f'filename="{Path(name).name}"'   # the URDF is a blob too: same directory

    name = members.blob(_FILENAME.sub(repl, text).encode("utf-8"), ".urdf")
    # the robot's SRDF (self-collision pairs to skip) travels beside it, where the collision
    # checker looks for it (`<stem>.srdf`); without it, e.g. the PR2's finger tips collide
    srdf = find_srdf(urdf)
    if srdf is not None:
        members.add(str(Path(name).with_suffix(".srdf")), srdf.read_bytes())
    return name


def _shape_json(members: _Members, shape) -> dict | None:
    if shape is None:
        return None
    return dispatch_shape(_SHAPE_JSON, shape, "the artifact's scene JSON")(members, shape)


def _mesh_json(members: _Members, shape) -> dict | None:
    if shape.mesh is None or not Path(shape.mesh).is_file():
        return None                      # an unresolved legacy mesh: no geometry in the artifact
    name = members.blob(Path(shape.mesh).read_bytes(), Path(shape.mesh).suffix)
    return {"type": "mesh", "file": "../" + name, "scale": list(shape.scale),
            "convex": shape.convex}


#: a shape as native JSON (docs/world.md), per kind
_SHAPE_JSON = {
    "box": lambda members, shape: {"type": "box", "half_extents": list(shape.size)},
    "sphere": lambda members, shape: {"type": "sphere", "radius": shape.radius},
    "cylinder": lambda members, shape: {"type": "cylinder", "radius": shape.radius,
                                        "length": shape.length},
    "mesh": _mesh_json,
}


def normalized_scene(members: _Members, scene, allowed: tuple) -> dict:
    """The scene as native JSON (docs/world.md), files replaced by blobs."""
    robot = None
    if scene.robot is not None:
        r = scene.robot
        robot = {"urdf": "../" + _pack_urdf(members, Path(r.urdf)), "name": r.name,
                 "base_pose": {"translation": list(r.base_pose.translation),
                               "rotation": list(r.base_pose.rotation)},
                 "mobile_base": r.mobile_base, "joints": dict(r.joint_values)}
        if r.controllable is not None:
            robot["controllable"] = list(r.controllable)
    objects = []
    for o in scene.objects:
        obj = {"name": o.name, "pose": {"translation": list(o.pose.translation),
                                        "rotation": list(o.pose.rotation)},
               "movable": o.movable}
        shape = _shape_json(members, o.shape)
        if shape is not None:
            obj["shape"] = shape
        if o.support is not None:
            obj["support"] = {"lower": list(o.support.lower), "upper": list(o.support.upper)}
        if o.parent is not None:
            obj["parent"] = o.parent
        obj.update(extras_json(o))
        objects.append(obj)
    # Legacy blocklists name links some URDFs lack (their planners skipped those); the native
    # scene format is strict, so only pairs naming real things are carried over.
    known = {o.name.lower() for o in scene.objects}
    if scene.robot is not None:
        tree = robot_tree(scene.robot.urdf, Path(scene.path).parent, strict_meshes=False)
        known |= {scene.robot.name.lower()} | {lk.name.lower() for lk in tree.links} | \
            {j.name.lower() for j in tree.joints}
    pairs = [list(p) for p in (*scene.allowed_collisions, *allowed)
             if p[0].lower() in known and p[1].lower() in known]
    return {"format": "tmpc-scene/1", "bounds": [list(b) for b in scene.bounds],
            "robot": robot, "objects": objects, "allowed_collisions": pairs}


def _kernel_sources(members: _Members, scene: dict) -> str:
    """What the kernels are compiled from: every member, the scene without the start poses of
    its movable objects (a kernel reads them as inputs), so variations of a problem's start
    (examples/lagriffoul/vary.py) share their compiled kernels."""
    files = {k: digest(v) for k, v in sorted(members.files.items())}
    files["src/scene.json"] = digest(json.dumps(
        dict(scene, objects=[{k: v for k, v in o.items() if not (k == "pose" and o["movable"])}
                             for o in scene["objects"]]), sort_keys=True).encode())
    return digest(json.dumps(files).encode())


def _cached(sources: str, options) -> Callable[[str, tuple, Callable[[], bytes]], bytes]:
    """Exported kernels are cached by (sources, key, spec, tmpc and JAX versions, options):
    recompiling an unchanged problem reuses them (exporting traces and lowers every kernel,
    which dominates compile time)."""
    def cached(key: str, spec: tuple, make) -> bytes:
        name = digest(json.dumps([sources, key, repr(spec), code_digest(),
                                  package_version("jax"), repr(options)]).encode())
        path = cache_root() / "exports" / f"{name}.jaxexport"
        if path.is_file():
            return path.read_bytes()
        data = make()
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(path, data)
        except OSError:
            pass          # a read-only cache: fine, just slower next time
        return data
    return cached


def build_artifact(world, out: str | Path, register=None, run_only: bool = False,
                   progress=None) -> dict:
    """Compile ``world`` (a :class:`tmpc.lang.inputs.World` with a program) into ``out``: every
    kernel :meth:`tmpc.compiler.compile.CompiledProgram.register_kernels` names, plus those ``register(world,
    compiled)`` adds (the runtime's), exported; ``run_only``: only what planning calls (the run
    cache's artifacts). ``progress(phase, done, total, detail)``: told each phase, and each
    kernel as it is exported (the slow part). Returns the manifest."""
    progress = progress or _quiet
    progress("compiling the program", 0, 0, "")
    members = _Members()
    cfg, prog = world.config, world.program
    src = {"domain": members.add("src/domain.pddl", Path(cfg.domain).read_bytes()),
           "problem": members.add("src/problem.pddl", Path(cfg.problem).read_bytes())}
    if cfg.semantics is not None:
        src["semantics"] = members.add("src/predicates.lua", Path(cfg.semantics).read_bytes())
    if cfg.module is not None:
        src["module"] = members.add("src/semantics.tmpc", Path(cfg.module).read_bytes())
    scene = normalized_scene(members, world.scene, world.allowed_pairs())
    members.add("src/scene.json", json.dumps(scene, indent=1).encode())
    run = ['[problem]', 'domain = "domain.pddl"', 'problem = "problem.pddl"',
           'scene = "scene.json"']
    if "semantics" in src:
        run.append('semantics = "predicates.lua"')
    if "module" in src:
        run.append('semantics = "semantics.tmpc"')
    members.add("src/run.toml", ("\n".join(run) + "\n").encode())
    compiled = compile_world(world)
    compiled.register_kernels(run_only)
    if register is not None:
        register(world, compiled)          # what the runtime adds (the collision checker's)
    sources = _kernel_sources(members, scene)
    exported, skipped = compiled.bank.export(
        _cached(sources, compiled.options),
        lambda i, n, key: progress("compiling kernels", i, n, kernel_label(key)))
    progress("writing the artifact", 0, 0, "")
    entries = {key: members.add(f"kernels/{_member_name(key)}.jaxexport", data)
               for key, data in sorted(exported.items())}
    entries.update({key: None for key in skipped})
    lua = sorted(k for k in compiled.external) if cfg.semantics is not None else []
    smt = _smt_section(members, prog)
    model = compiled.model
    manifest = {
        "format": FORMAT, "tmpc": package_version("tmpc"), "jax": package_version("jax"),
        "domain": prog.domain.name.text,
        "problem": prog.problem.name.text if prog.problem else None,
        "options": {"tol": compiled.options.tol, "and_mode": compiled.options.and_mode},
        "layout": {"q": list(model.q_names) if model else [],
                   "lower": [float(v) for v in model.lower] if model else [],
                   "upper": [float(v) for v in model.upper] if model else [],
                   "entities": list(compiled.tables.names)},
        "bank": {"kernels": entries, "skipped": skipped},
        "lua_predicates": lua,
        "smt": smt,
        "members": {name: digest(data) for name, data in sorted(members.files.items())},
        "sizes": {name: len(data) for name, data in sorted(members.files.items())},
    }
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        _write(z, MAGIC_MEMBER, json.dumps(manifest, indent=1).encode())
        for name, data in sorted(members.files.items()):
            _write(z, name, data)
    try:
        atomic_write_bytes(out, buf.getvalue())
    except OSError as exc:
        raise InputError(error("E592", f"cannot write {out}: {exc.strerror or exc}", None,
                               "give -o a path in an existing, writable folder")) from None
    return manifest


def _quiet(phase: str, done: int, total: int, detail: str) -> None:
    """No progress report."""


def kernel_label(key: str) -> str:
    """A bank key as a user reads it: ``proj/action/pick@16`` -> ``projector pick``."""
    kind, _, rest = key.partition("/")
    name = rest.rpartition("/")[2].partition("@")[0] if rest else ""
    what = {"cond": "condition", "proj": "projector", "fk": "kinematics", "grad": "gradient"}
    return f"{what.get(kind, kind)} {name}".strip() if kind != "fk" else "kinematics"


def _write(z: zipfile.ZipFile, name: str, data: bytes) -> None:
    """One member with a fixed timestamp: the same input compiles to the same bytes (the
    artifact cache is content-addressed)."""
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    z.writestr(info, data)


def _member_name(key: str) -> str:
    """A kernel key as a file name (``proj/action/pickup`` -> ``proj-action-pickup``)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", key)


def _smt_section(members: _Members, prog) -> dict:
    """The task planner's step encoding as SMT-LIB2 templates (compiler/smt/encode.py, geometric
    mode: blocker variables included), one member per template; a problem too large to ground
    says why instead of failing the artifact."""
    try:
        templates = smtlib_templates(ground(prog), geometric=True)
    except GroundingError as exc:
        return {"templates": None, "skipped": exc.diagnostics[0].message}
    return {"templates": {name: members.add(f"smt/{name}.smt2", text.encode("utf-8"))
                          for name, text in sorted(templates.items())}}


def open_for_run(path, register=None, on_compile=None, progress=None, before_compile=None):
    """The world ``tmpc run`` plans in, and how its kernels were had: an artifact as it is
    (``"artifact"``); a run configuration through the artifact cache (:mod:`tmpc.compiler.cache`):
    ``"cache"`` when an artifact of exactly these sources is there, else ``"compiled"`` after
    compiling one into the cache (``on_compile(path)`` is called first: it takes a while;
    ``progress`` as :func:`build_artifact`'s). A damaged cache entry is compiled again, with a
    warning. ``before_compile(world)`` is called before compiling (it may raise: a run's setup
    errors are found before the compile's seconds are spent)."""
    if is_artifact(path):
        return open_world(path), "artifact"
    world = load_world(path)
    if world.program is None or world.program.problem is None:
        return world, "sources"        # nothing to compile: the planner's checks say why
    art = run_artifact(source_key(world, Options()))
    if art.is_file():
        try:
            manifest, _ = read_manifest(art)
            world.artifact = (art, manifest)
            return world, "cache"
        except InputError as exc:
            warnings.warn(f"the cached artifact {art} is damaged ({exc.diagnostics[0].message}); "
                          "compiling it again", stacklevel=2)
            art.unlink(missing_ok=True)
    if before_compile is not None:
        before_compile(world)
    art.parent.mkdir(parents=True, exist_ok=True)
    if on_compile is not None:
        on_compile(art)
    build_artifact(world, art, register, run_only=True, progress=progress)
    return world, "compiled"
