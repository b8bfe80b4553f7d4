"""The user cache directory and the content-addressed artifact cache.

``$TMPC_CACHE_DIR``, else ``~/.cache/tmpc``. Below it:

* ``jax/`` — XLA's persistent compilation cache;
* ``exports/`` — serialized kernels by (sources, kernel, versions), reused by ``tmpc compile``;
* ``runs/`` — artifacts compiled for ``tmpc run CONFIG``, named by :func:`source_key`: the digests
  of every file the run reads (configuration, domain, problem, scene, Lua predicates, allowed
  pairs, URDF, SRDF, meshes) with tmpc's code digest, the JAX version and the compile options. An unchanged
  problem is compiled once; a changed byte anywhere compiles anew;
* ``artifacts/`` — artifacts extracted for running, by manifest digest;
* ``collision/`` — the collision first pass's sphere covers and pair tables, by robot, and
  collision meshes as arrays (with their convex hulls), by file contents;
* ``robots/`` — parsed URDFs (:func:`robot_tree`), so a warm run imports no URDF parser;
* ``viewer/`` — the validator's reads of URDFs and the viewer's decoded visual meshes, so a warm
  `tmpc run --html` or `tmpc view` imports neither yourdfpy nor trimesh;
* ``aot/`` — the collision pass built ahead of time into an extension module
  (:mod:`tmpc.compiler.aot`), so a warm run imports no numba; a failed build's reason;
* ``numba/`` — numba's machine-code cache (:mod:`tmpc.compiler.numbacfg`).

Every file is written atomically (temporary file, then rename), so concurrent runs never see a
partial artifact; two runs compiling the same problem at once both write a complete one and the
last rename wins.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import shutil
from dataclasses import dataclass
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from tmpc.lang.diagnostics import SceneError
from tmpc.lang.fileio import atomic_write_text
from tmpc.lang.world import (
    KinematicTree,
    example_robot_data_dir,
    find_file,
    find_srdf,
    load_urdf,
    tree_from_data,
    tree_to_data,
)

#: the sub-directories `tmpc cache info` reports and `tmpc cache clear` empties
PARTS = {"runs": "artifacts compiled for `tmpc run CONFIG`",
         "artifacts": "artifacts extracted for running",
         "exports": "serialized kernels reused by `tmpc compile`",
         "collision": "collision meshes, sphere covers and pair tables of robots",
         "robots": "parsed URDFs",
         "viewer": "the validator's URDF reads and the viewer's decoded meshes",
         "jax": "XLA's persistent compilation cache",
         "aot": ("the collision checker's kinematics and first pass compiled ahead of time for "
                 "this machine (or why the build failed)"),
         "numba": "numba's machine code (A*'s LM-cut; the collision pass without `aot`)"}


def cache_root() -> Path:
    return Path(os.environ.get("TMPC_CACHE_DIR") or os.path.join(Path.home(), ".cache", "tmpc"))


def package_version(pkg: str) -> str:
    """The installed version of a distribution (``unknown`` when it is not installed)."""
    try:
        return version(pkg)
    except PackageNotFoundError:
        return "unknown"


@lru_cache(maxsize=1)
def code_digest() -> str:
    """The digest of tmpc's own code and data files (and its version): cached artifacts and
    kernels made by other code are never reused, even under the same version number (a
    development checkout)."""
    h = hashlib.sha256(package_version("tmpc").encode())
    for pkg in ("lang", "compiler", "runtime", "stdlib"):
        for base in sorted(Path(p) for p in importlib.import_module(f"tmpc.{pkg}").__path__):
            for f in sorted(base.rglob("*")):
                if f.suffix in (".py", ".lark", ".tmpc", ".lua", ".js") and f.is_file():
                    h.update(f.relative_to(base).as_posix().encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:24]


def robot_tree(ref, base: Path, strict_meshes: bool = True) -> KinematicTree:
    """:func:`tmpc.lang.world.load_urdf` through the cache: a URDF parsed once is read back as
    JSON (importing yourdfpy, and the trimesh it imports, would dominate a warm run's setup).
    The key is the URDF's path and contents, the mesh search path and tmpc's code; the entry
    says whether every mesh was found (``strict_meshes`` then needs no parse either). An entry
    whose meshes are no longer there, or that cannot be read, is parsed again; errors come from
    the parse."""
    path = find_file(str(ref), Path(base))
    try:
        data = path.resolve().read_bytes() if path is not None else None
    except OSError:
        data = None
    if data is None:                      # the parser says what is wrong
        return load_urdf(ref, base, strict_meshes)
    entry = urdf_entry("robots", path.resolve(), data)
    try:
        got = json.loads(entry.read_text("utf-8"))
        tree, complete = tree_from_data(got["tree"]), got["complete"] is True
        if all(g.shape.mesh is None or Path(g.shape.mesh).is_file()
               for lk in tree.links for g in lk.collision):
            return load_urdf(ref, base, True) if strict_meshes and not complete else tree
    except (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError):
        pass
    try:
        tree, complete = load_urdf(ref, base, True), True
    except SceneError:
        if strict_meshes:
            raise
        tree, complete = load_urdf(ref, base, False), False     # raises if not about meshes
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(entry, json.dumps({"tree": tree_to_data(tree), "complete": complete}))
    except OSError:
        pass                              # a read-only cache is fine: just slower
    return tree


def urdf_entry(part: str, path: Path, data: bytes, *extra: str, prefix: str = "") -> Path:
    """The cache file (JSON) of a read of the URDF at ``path`` (contents ``data``): keyed by the
    path and contents, the mesh search path (where its mesh URIs resolve), tmpc's code and
    ``extra``."""
    h = hashlib.sha256(json.dumps([str(path), code_digest(),
                                   os.environ.get("TMPC_MESH_PATH", ""),
                                   os.environ.get("ROS_PACKAGE_PATH", ""),
                                   str(example_robot_data_dir()), *extra]).encode())
    h.update(hashlib.sha256(data).digest())
    return cache_root() / part / f"{prefix}{h.hexdigest()[:32]}.json"


def source_files(world) -> list[Path]:
    """Every file a run of ``world`` reads: the sources loaded (configuration, PDDL, scene), the
    Lua predicates, the allowed-collision list, the robot's URDF and SRDF, and every mesh."""
    files = {Path(p) for p in world.files if not str(p).startswith("<")}
    cfg, scene = world.config, world.scene
    if cfg is not None:
        files.update(Path(p) for p in (cfg.semantics, cfg.allowed_collisions) if p)
    if scene.robot is not None:
        tree = robot_tree(scene.robot.urdf, Path(scene.path).parent, strict_meshes=False)
        files.add(Path(tree.path))
        srdf = find_srdf(Path(tree.path))
        if srdf is not None:
            files.add(Path(srdf))
        files.update(Path(g.shape.mesh) for link in tree.links for g in link.collision
                     if g.shape.mesh is not None)
    for obj in scene.objects:
        if obj.shape.mesh is not None:
            files.add(Path(obj.shape.mesh))
    return sorted(f for f in files if f.is_file())


def source_key(world, options) -> str:
    """The cache key of a run of ``world``: what its program and scene mean, the contents of
    its other files, tmpc and JAX, the options. The domain, problem and scene count by meaning
    (their parsed, span-free form), so an edit of comments or layout reuses the artifact: a run
    reads its program from the files and only the kernels, lifted functions of that meaning,
    from the artifact."""
    h = hashlib.sha256()
    by_meaning = _meaning_keyed(world)
    for f in source_files(world):
        if f.resolve() in by_meaning:
            continue
        h.update(str(f.resolve()).encode() + b"\0" + hashlib.sha256(f.read_bytes()).digest())
    if by_meaning:
        prog = world.program
        h.update(repr((prog.domain, prog.problem, prog.modules, world.scene)).encode())
    h.update(json.dumps([code_digest(), package_version("jax"), repr(options)]).encode())
    return h.hexdigest()[:32]


def _meaning_keyed(world) -> set[Path]:
    """The files :func:`source_key` hashes by meaning: the checked program's sources and the
    scene file (none for a world without a program)."""
    if world.program is None or world.config is None:
        return set()
    return {Path(p).resolve() for p in (world.config.domain, world.config.problem,
                                        world.scene.path) if p}


def run_artifact(key: str) -> Path:
    return cache_root() / "runs" / f"{key}.tmpa"


@dataclass(frozen=True)
class PartInfo:
    name: str
    path: Path
    files: int
    bytes: int
    what: str


def cache_info() -> list[PartInfo]:
    """What the cache holds, per part."""
    out = []
    for name, what in PARTS.items():
        path = cache_root() / name
        n = size = 0
        if path.is_dir():
            for p in path.rglob("*"):
                if p.is_file():
                    n += 1
                    size += p.stat().st_size
        out.append(PartInfo(name, path, n, size, what))
    return out


def clear_cache(parts: list[str] | None = None) -> list[PartInfo]:
    """Empty the given parts (all by default); returns what was removed."""
    removed = []
    for info in cache_info():
        if parts and info.name not in parts:
            continue
        if info.path.is_dir():
            shutil.rmtree(info.path, ignore_errors=True)
            removed.append(info)
    return removed
