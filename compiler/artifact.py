"""The artifact: one self-contained, versioned file (`tmpc compile -o x.tmpa`), and opening it.

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

Writing it is :mod:`tmpc.compiler.export`'s; this module only reads, and imports no JAX, kernel
or grounding code (opening an artifact for the validator or the viewer stays light).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import warnings
import zipfile
from pathlib import Path

from tmpc.compiler.bank import KernelBank
from tmpc.compiler.cache import cache_root, package_version
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.inputs import load_world

FORMAT = "tmpc-artifact/1"
MAGIC_MEMBER = "manifest.json"


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


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
    for name, expected in manifest.get("members", {}).items():
        try:
            data = z.read(name)
        except (KeyError, zipfile.BadZipFile, OSError):
            raise _bad(path, f"member {name} is missing or damaged") from None
        if digest(data) != expected:
            raise _bad(path, f"member {name} does not match its digest (modified or damaged)")
    return manifest, z


def extract(path: str | Path) -> tuple[dict, Path]:
    """Check and extract an artifact's data files; returns (manifest, the run.toml path)."""
    manifest, z = read_manifest(path)
    key = digest(json.dumps(manifest, sort_keys=True).encode())[:24]
    root = cache_root() / "artifacts" / key
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


def open_world(path: str | Path, with_program: bool = True):
    """Any input a command takes: a compiled artifact (checked, extracted, and its extraction
    loaded; ``world.artifact`` = (path, manifest)), else a scene or run configuration."""
    if is_artifact(path):
        manifest, run = extract(path)
        world = load_world(run, with_program)
        world.artifact = (Path(path), manifest)
        return world
    return load_world(path, with_program)


def is_artifact(path: str | Path) -> bool:
    p = Path(path)
    if p.suffix.lower() == ".tmpa":
        return True
    try:
        with open(p, "rb") as f:
            return f.read(4) == b"PK\x03\x04" and zipfile.is_zipfile(p)
    except OSError:
        return False


def load_bank(path: str | Path, manifest: dict) -> KernelBank:
    """The artifact's exported kernels as a :class:`KernelBank` (deserialized on first use). A
    different JAX version cannot be trusted to read them: an empty bank, with a warning naming
    the kernels that will be traced from the embedded sources instead."""
    section = manifest.get("bank") or {}
    entries = section.get("kernels") or {}
    if manifest.get("jax") != package_version("jax"):
        if entries:
            warnings.warn(f"{path}: kernels exported by JAX {manifest.get('jax')}, this is JAX "
                          f"{package_version('jax')}: tracing {', '.join(sorted(entries))} "
                          "from the artifact's sources instead", stacklevel=2)
        return KernelBank()
    _, z = read_manifest(path)
    exported = {key: z.read(member) for key, member in entries.items() if member}
    return KernelBank.load(exported, section.get("skipped", {}), str(path))
