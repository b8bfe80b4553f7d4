"""The artifact: one self-contained, versioned file (`tmpc compile -o x.tmpa`).

A zip archive with

* ``manifest.json`` — format and versions (tmpc, JAX), the digest of every member, the program
  summary (predicates, actions), the configuration layout, kernel options and kernel list;
* ``src/`` — the checked domain and problem, the Lua predicate file, a normalized native scene
  (``scene.json``) whose robot URDF and meshes are members named by content hash (``blobs/``),
  with every URDF mesh reference rewritten to its blob, and a run manifest (``run.toml``) tying
  them together;
* ``kernels/*.jaxexport`` — the lifted condition kernels serialized with ``jax.export``, batched
  over a symbolic number of (configuration, arguments) pairs. A kernel that calls a Lua predicate
  on the host (one tracing could not capture, docs/lua.md) cannot be serialized: its manifest
  entry has no ``member`` and says why (``skipped``); it is rebuilt from ``src/`` when loaded.

Loading never executes code from the file (no pickle; kernels are StableHLO run by JAX): it checks
the manifest and every member's SHA-256, extracts the data files to a cache directory named by the
artifact's digest, and loads the world from there, so a run needs none of the original files.
A kernel serialized by another JAX version is rebuilt from the embedded sources. Writing is
atomic (temporary file, then rename).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import shutil
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_bytes
from tmpc.lang.robot import find_file

FORMAT = "tmpc-artifact/1"
MAGIC_MEMBER = "manifest.json"


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _version(pkg: str) -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(pkg)
    except PackageNotFoundError:
        return "unknown"


# ---------------------------------------------------------------------------------------------
# writing


@dataclass
class _Members:
    files: dict[str, bytes] = field(default_factory=dict)

    def add(self, name: str, data: bytes) -> str:
        self.files[name] = data
        return name

    def blob(self, data: bytes, suffix: str) -> str:
        return self.add(f"blobs/{_sha(data)[:32]}{suffix.lower()}", data)


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

    from tmpc.lang.robot import find_srdf
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
    if shape.kind == "box":
        return {"type": "box", "half_extents": list(shape.size)}
    if shape.kind == "sphere":
        return {"type": "sphere", "radius": shape.radius}
    if shape.kind == "cylinder":
        return {"type": "cylinder", "radius": shape.radius, "length": shape.length}
    if shape.mesh is None or not Path(shape.mesh).is_file():
        return None                      # an unresolved legacy mesh: no geometry in the artifact
    name = members.blob(Path(shape.mesh).read_bytes(), Path(shape.mesh).suffix)
    return {"type": "mesh", "file": "../" + name, "scale": list(shape.scale),
            "convex": shape.convex}


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
        objects.append(obj)
    # Legacy blocklists name links some URDFs lack (their planners skipped those); the native
    # scene format is strict, so only pairs naming real things are carried over.
    known = {o.name.lower() for o in scene.objects}
    if scene.robot is not None:
        from tmpc.lang.robot import load_urdf
        tree = load_urdf(scene.robot.urdf, Path(scene.path).parent, strict_meshes=False)
        known |= {scene.robot.name.lower()} | {lk.name.lower() for lk in tree.links} | \
            {j.name.lower() for j in tree.joints}
    pairs = [list(p) for p in (*scene.allowed_collisions, *allowed)
             if p[0].lower() in known and p[1].lower() in known]
    return {"format": "tmpc-scene/1", "bounds": [list(b) for b in scene.bounds],
            "robot": robot, "objects": objects, "allowed_collisions": pairs}


def _export_kernel(compiled, formula) -> bytes:
    from jax import export
    from .jaxcfg import configured
    jax = configured()
    jnp = jax.numpy
    kernel, _ = compiled.kernels(formula)
    world = compiled.world
    n = world.model.dof if world.model is not None else 0
    M, k = world.n_objects, len(formula.params)
    b = export.symbolic_shape("b")[0]
    batched = jax.jit(jax.vmap(kernel, in_axes=(0, None, None, 0)))
    exp = export.export(batched)(
        jax.ShapeDtypeStruct((b, n), jnp.float64), jax.ShapeDtypeStruct((M, 4, 4), jnp.float64),
        jax.ShapeDtypeStruct((M,), jnp.int64), jax.ShapeDtypeStruct((b, k), jnp.int64))
    return bytes(exp.serialize())


def _cached_export(compiled, formula, kind: str, sources: str) -> bytes:
    """Exported kernels are cached by (sources, formula, tmpc and JAX versions): recompiling an
    unchanged problem reuses them (exporting traces and lowers every kernel, which dominates)."""
    from .ir import show
    from .jaxcfg import cache_dir
    key = _sha(json.dumps([sources, kind, formula.name, show(formula.body),
                           _version("tmpc"), _version("jax"), repr(compiled.options)]).encode())
    path = cache_dir().parent / "exports" / f"{key}.jaxexport"
    if path.is_file():
        return path.read_bytes()
    data = _export_kernel(compiled, formula)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, data)
    except OSError:
        pass          # a read-only cache: fine, just slower next time
    return data


def build_artifact(world, out: str | Path) -> dict:
    """Compile ``world`` (a :class:`tmpc.runtime.world.World` with a program) into ``out``."""
    from .compile import CompiledProgram
    from .jaxgen import has_lua_calls
    from tmpc.lang import ast as A
    members = _Members()
    cfg, prog = world.config, world.program
    src = {"domain": members.add("src/domain.pddl", Path(cfg.domain).read_bytes()),
           "problem": members.add("src/problem.pddl", Path(cfg.problem).read_bytes())}
    if cfg.semantics is not None:
        src["semantics"] = members.add("src/predicates.lua", Path(cfg.semantics).read_bytes())
    scene = normalized_scene(members, world.scene, world.allowed_pairs())
    members.add("src/scene.json", json.dumps(scene, indent=1).encode())
    run = ['[problem]', 'domain = "domain.pddl"', 'problem = "problem.pddl"',
           'scene = "scene.json"']
    if "semantics" in src:
        run.append('semantics = "predicates.lua"')
    members.add("src/run.toml", ("\n".join(run) + "\n").encode())
    compiled = CompiledProgram(prog, world.scene, world.model,
                               external=_external(world))
    kernels = []
    for decl in prog.domain.predicates:
        if decl.kind is A.Kind.GEOMETRIC and (decl.semantics is not None or
                                              decl.name.key in compiled.external):
            kernels.append(("predicate", compiled.predicate(decl.name.text)))
    for act in prog.domain.actions:
        kernels.append(("action", compiled.action(act.name.text)))
    entries = []
    sources = _sha(json.dumps({k: _sha(v) for k, v in sorted(members.files.items())}).encode())
    for kind, formula in kernels:
        entry = {"kind": kind, "name": formula.name,
                 "params": [p.name.text for p in formula.params]}
        if has_lua_calls(formula.body):
            entry.update(member=None, skipped="calls a Lua predicate on the host (tracing could "
                         "not capture it); jax.export cannot serialize host callbacks, so the "
                         "kernel is rebuilt from src/ when loaded")
        else:
            entry["member"] = members.add(f"kernels/{kind}-{formula.name.lower()}.jaxexport",
                                          _cached_export(compiled, formula, kind, sources))
        entries.append(entry)
    smt = _smt_section(members, prog)
    model = world.model
    manifest = {
        "format": FORMAT, "tmpc": _version("tmpc"), "jax": _version("jax"),
        "domain": prog.domain.name.text, "problem": prog.problem.name.text if prog.problem else None,
        "options": {"tol": compiled.options.tol, "and_mode": compiled.options.and_mode},
        "layout": {"q": list(model.q_names) if model else [],
                   "lower": [float(v) for v in model.lower] if model else [],
                   "upper": [float(v) for v in model.upper] if model else [],
                   "entities": list(compiled.world.names)},
        "kernels": entries,
        "smt": smt,
        "members": {name: _sha(data) for name, data in sorted(members.files.items())},
    }
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr(MAGIC_MEMBER, json.dumps(manifest, indent=1))
        for name, data in sorted(members.files.items()):
            z.writestr(name, data)
    atomic_write_bytes(out, buf.getvalue())
    return manifest


def _smt_section(members: _Members, prog) -> dict:
    """The task planner's step encoding as SMT-LIB2 templates (compiler/smt.py, geometric mode:
    blocker variables included), one member per template; a problem too large to ground says why
    instead of failing the artifact."""
    from .ground import GroundingError, ground
    from .smt import smtlib_templates
    try:
        templates = smtlib_templates(ground(prog), geometric=True)
    except GroundingError as exc:
        return {"templates": None, "skipped": exc.diagnostics[0].message}
    return {"templates": {name: members.add(f"smt/{name}.smt2", text.encode("utf-8"))
                          for name, text in sorted(templates.items())}}


def _external(world) -> dict:
    from tmpc.runtime.sample_command import load_external
    return load_external(world)


# ---------------------------------------------------------------------------------------------
# reading


def _bad(path, msg: str, hint: str | None = None) -> InputError:
    return InputError(error("E590", f"{path}: {msg}", None, hint))


def read_manifest(path: str | Path) -> tuple[dict, zipfile.ZipFile]:
    """Open an artifact and check its manifest and every member's digest."""
    try:
        z = zipfile.ZipFile(path)
    except FileNotFoundError:
        raise InputError(error("E010", f"no such file: {path}", None)) from None
    except (zipfile.BadZipFile, OSError) as exc:
        raise _bad(path, f"not a tmpc artifact (not a readable zip archive: {exc})",
                   "rebuild it with `tmpc compile`; a truncated copy looks like this") from None
    try:
        manifest = json.loads(z.read(MAGIC_MEMBER))
    except KeyError:
        raise _bad(path, "not a tmpc artifact (no manifest.json)") from None
    except (json.JSONDecodeError, zipfile.BadZipFile, OSError) as exc:
        raise _bad(path, f"damaged manifest: {exc}") from None
    fmt = manifest.get("format") if isinstance(manifest, dict) else None
    if fmt != FORMAT:
        raise _bad(path, f"artifact format {fmt!r}, this tmpc reads {FORMAT!r}",
                   "recompile it with this version of tmpc")
    for name, digest in manifest.get("members", {}).items():
        try:
            data = z.read(name)
        except (KeyError, zipfile.BadZipFile, OSError):
            raise _bad(path, f"member {name} is missing or damaged") from None
        if _sha(data) != digest:
            raise _bad(path, f"member {name} does not match its digest (modified or damaged)")
    return manifest, z


def extract(path: str | Path) -> tuple[dict, Path]:
    """Check and extract an artifact's data files; returns (manifest, the run.toml path)."""
    manifest, z = read_manifest(path)
    digest = _sha(json.dumps(manifest, sort_keys=True).encode())[:24]
    from .jaxcfg import cache_dir
    root = cache_dir().parent / "artifacts" / digest
    if not (root / "src" / "run.toml").is_file():
        root.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=root.parent, prefix=".extract-"))
        try:
            for name in manifest["members"]:
                target = (tmp / name).resolve()
                if not str(target).startswith(str(tmp.resolve()) + os.sep):
                    raise _bad(path, f"member {name} escapes the archive")
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(z.read(name))
            os.replace(tmp, root) if not root.exists() else shutil.rmtree(tmp)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    return manifest, root / "src" / "run.toml"


def is_artifact(path: str | Path) -> bool:
    p = Path(path)
    if p.suffix.lower() == ".tmpa":
        return True
    try:
        with open(p, "rb") as f:
            return f.read(4) == b"PK\x03\x04" and zipfile.is_zipfile(p)
    except OSError:
        return False


def exported_kernels(path: str | Path, manifest: dict) -> dict[tuple[str, str], object]:
    """Deserialized kernels by (kind, lower-case name), or {} when JAX's version differs (the
    caller rebuilds them from the sources)."""
    if manifest.get("jax") != _version("jax"):
        return {}
    from jax import export
    _, z = read_manifest(path)
    out = {}
    for k in manifest.get("kernels", []):
        if not k.get("member"):
            continue                # not serializable (calls Lua on the host): rebuild it
        exp = export.deserialize(bytearray(z.read(k["member"])))
        out[(k["kind"], k["name"].lower())] = exp.call
    return out
