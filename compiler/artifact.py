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
the manifest's structure and every member's size and SHA-256 while decompressing it as a stream
(capped by the size the manifest records and by hard limits, so a zip bomb is refused before it
costs memory), extracts the data files to a cache directory named by the
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
import zlib
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


#: hard caps on what reading an artifact may decompress (a zip bomb stops here, not in RAM)
MAX_MEMBER = 512 << 20
MAX_TOTAL = 2 << 30
MAX_MANIFEST = 16 << 20
_CHUNK = 1 << 20
#: what damaged zip data raises while it is decompressed (NotImplementedError: a compression
#: method zipfile does not support)
_DAMAGED = (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, NotImplementedError,
            RuntimeError)


def read_manifest(path: str | Path) -> tuple[dict, zipfile.ZipFile]:
    """Open an artifact, check its manifest's structure and every member's size and digest
    (streamed: nothing larger than the manifest says, or than :data:`MAX_MEMBER`, is
    decompressed). Every problem is an E590 naming what is wrong."""
    z = _open_zip(path)
    try:
        z.getinfo(MAGIC_MEMBER)
    except KeyError:
        raise _bad(path, "not a tmpc artifact (no manifest.json)") from None
    raw = _stream(path, z, MAGIC_MEMBER, MAX_MANIFEST)
    try:
        manifest = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise _bad(path, f"damaged manifest: {exc}") from None
    check_manifest(path, manifest)
    total = 0
    for name, expected in manifest["members"].items():
        total += len(member(path, z, manifest, name))
        if total > MAX_TOTAL:
            raise _bad(path, f"members add up to more than {MAX_TOTAL >> 20} MiB")
    return manifest, z


def _open_zip(path) -> zipfile.ZipFile:
    try:
        return zipfile.ZipFile(path)
    except FileNotFoundError:
        raise InputError(error("E010", f"no such file: {path}", None)) from None
    except _DAMAGED as exc:
        raise _bad(path, f"not a tmpc artifact (not a readable zip archive: {exc})",
                   "rebuild it with `tmpc compile`; a truncated copy looks like this") from None


def member(path, z: zipfile.ZipFile, manifest: dict, name: str) -> bytes:
    """One member's bytes, streamed under its size cap and checked against its digest."""
    expected = manifest["members"].get(name)
    if expected is None:
        raise _bad(path, f"member {name} is not in the manifest")
    size = manifest.get("sizes", {}).get(name)
    data = _stream(path, z, name, MAX_MEMBER if size is None else size, size is not None)
    if size is not None and len(data) != size:
        raise _bad(path, f"member {name} has {len(data)} bytes, the manifest says {size} "
                   "(modified or damaged)")
    if digest(data) != expected:
        raise _bad(path, f"member {name} does not match its digest (modified or damaged)")
    return data


def _stream(path, z: zipfile.ZipFile, name: str, cap: int, recorded: bool = False) -> bytes:
    """A member's bytes, decompressed in chunks and refused as soon as they pass ``cap`` (the
    size the manifest records, ``recorded``, or a hard limit)."""
    try:
        info = z.getinfo(name)
    except KeyError:
        raise _bad(path, f"member {name} is missing") from None
    limit = f"the {cap} the manifest records (modified or damaged)" if recorded else \
        f"the {cap} a member may have"
    if info.file_size > cap:
        raise _bad(path, f"member {name} would decompress to {info.file_size} bytes, more than "
                   f"{limit}", "rebuild it with `tmpc compile`")
    out, n = [], 0
    try:
        with z.open(info) as f:
            while chunk := f.read(_CHUNK):
                n += len(chunk)
                if n > cap:
                    raise _bad(path, f"member {name} decompresses to more than {limit}")
                out.append(chunk)
    except _DAMAGED as exc:
        raise _bad(path, f"member {name} is damaged ({type(exc).__name__}: {exc})",
                   "rebuild it with `tmpc compile`") from None
    return b"".join(out)


def check_manifest(path, manifest) -> None:
    """The manifest's structure, as reading relies on it (E590 naming the first problem)."""
    fmt = manifest.get("format") if isinstance(manifest, dict) else None
    if fmt != FORMAT:
        raise _bad(path, f"artifact format {fmt!r}, this tmpc reads {FORMAT!r}",
                   "recompile it with this version of tmpc")
    members = manifest.get("members")
    if not isinstance(members, dict):
        raise _bad(path, f"manifest `members` is {_kind(members)}, not a table of member digests")
    for name, d in members.items():
        parts = name.split("/")
        if not name or name.startswith("/") or "\\" in name or ".." in parts or "" in parts:
            raise _bad(path, f"member name {name!r} is not a relative path inside the archive")
        if not (isinstance(d, str) and len(d) == 64 and all(c in "0123456789abcdef" for c in d)):
            raise _bad(path, f"member {name}: its digest {d!r} is not a SHA-256 hex string")
    if "src/run.toml" not in members:
        raise _bad(path, "the manifest has no member src/run.toml (the run it was compiled for)")
    sizes = manifest.get("sizes", {})
    if not isinstance(sizes, dict) or any(
            k not in members or type(v) is not int or v < 0 for k, v in sizes.items()):
        raise _bad(path, "manifest `sizes` must map members to byte counts")
    bank = manifest.get("bank", {})
    if not isinstance(bank, dict):
        raise _bad(path, f"manifest `bank` is {_kind(bank)}, not a table")
    kernels, skipped = bank.get("kernels", {}), bank.get("skipped", {})
    if not isinstance(kernels, dict) or any(
            not isinstance(k, str) or (m is not None and m not in members)
            for k, m in kernels.items()):
        raise _bad(path, "manifest `bank.kernels` must map kernel names to members of the archive")
    if not isinstance(skipped, dict) or any(not isinstance(v, str) for v in skipped.values()):
        raise _bad(path, "manifest `bank.skipped` must map kernel names to reasons")
    if not isinstance(manifest.get("jax", ""), str):
        raise _bad(path, "manifest `jax` must be a version string")


def _kind(v) -> str:
    kinds = {bool: "a boolean", int: "a number", float: "a number", str: "a string",
             list: "a list", dict: "a table"}
    return "missing" if v is None else kinds.get(type(v), type(v).__name__)


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
                target.write_bytes(member(path, z, manifest, name))
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
    # ``manifest`` was checked when the artifact was opened; each kernel read is checked against
    # its digest there, so the archive is not verified a second time
    z = _open_zip(path)
    exported = {key: member(path, z, manifest, name) for key, name in entries.items() if name}
    return KernelBank.load(exported, section.get("skipped", {}), str(path))
