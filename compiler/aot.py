"""Kernels compiled ahead of time: a numba kernel built once per machine into a plain CPython
extension module, so a run loads machine code without importing numba.

Why: numba's JIT cache loads a kernel's machine code, but only after importing numba and
initialising its CPU target, and LLVM stays in the process (a large share of resident memory):
a large part of a warm run's setup and of its peak memory. numba's ahead-of-time compiler
(``numba.pycc``) compiles the same njit functions for one explicit signature into an extension
module that needs only numpy to import (quick and small).

How: :func:`obtain` returns the module of a :class:`Kernel` from the cache folder (``aot/``),
named by a digest of the kernel's source file, its exports' signatures and the numba, numpy
and Python versions, so a changed kernel builds anew. Without one it builds it in a child process
(``python -m tmpc.compiler.aot``: numba, a C compiler and Python's headers) into a
temporary folder and renames the module into place, so concurrent runs never load a partial
file. :func:`prepare` starts that build early, to overlap a run's other setup. When the build
fails (no C compiler, say) the failure is recorded beside it, the caller falls back to numba's
JIT and is told why once; ``tmpc cache clear aot`` forgets it. ``TMPC_AOT=0`` skips this
module altogether (the JIT, for debugging and for the tests that compare the two).

The extension is tmpc's own code compiled on this machine, like numba's cache; it is not part
of an artifact (which never carries code).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import platform
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from dataclasses import dataclass
from functools import cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from tmpc.compiler.cache import cache_root
from tmpc.lang.fileio import atomic_write_text

#: the cache sub-folder of the built modules
FOLDER = "aot"
#: a build taking longer is abandoned (and recorded as failed); far above a build's usual time
BUILD_SECONDS = 600


@dataclass(frozen=True)
class Kernel:
    """The njit functions of ``module`` (a dotted name) exported as ``exports``: (function,
    signature) pairs, numba's signature syntax; arguments of other types are a TypeError, not
    a new build. One module, one build, however many functions. ``nrt=False`` builds without
    numba's reference counting: for exports that allocate no array (their scratch space is
    passed in), whose loops then carry no atomic incref/decref of every array a helper takes."""

    module: str
    exports: tuple[tuple[str, str], ...]
    nrt: bool = True

    def digest(self) -> str:
        return _digest(self.module, self.exports, self.nrt)

    def name(self) -> str:
        return f"_tmpc_aot_{self.module.rsplit('.', 1)[-1]}_{self.digest()}"

    def path(self) -> Path:
        return cache_root() / FOLDER / (self.name() + sysconfig.get_config_var("EXT_SUFFIX"))

    def failed_path(self) -> Path:
        return cache_root() / FOLDER / (self.name() + ".failed")


@cache
def _digest(module: str, exports: tuple[tuple[str, str], ...], nrt: bool = True) -> str:
    spec = importlib.util.find_spec(module)          # the source, without importing numba
    if spec is None or spec.origin is None:
        raise ImportError(f"no module {module}")
    h = hashlib.sha256(Path(spec.origin).read_bytes())
    for part in (*(x for pair in exports for x in pair), _version("numba"), _version("numpy"),
                 sys.version, platform.machine(), "nrt" if nrt else "no-nrt"):
        h.update(b"\0" + part.encode())
    return h.hexdigest()[:16]


def _version(pkg: str) -> str:
    try:
        return version(pkg)
    except PackageNotFoundError:
        return "none"


def enabled() -> bool:
    return os.environ.get("TMPC_AOT", "1") not in ("0", "no", "off", "false")


_BUILDS: dict[Kernel, subprocess.Popen] = {}


def prepare(kernel: Kernel) -> None:
    """Start building ``kernel`` in a child process unless it is built, known to fail, being
    built by this process, or ahead-of-time compilation is off."""
    if not enabled() or kernel in _BUILDS:
        return
    if kernel.path().exists() or kernel.failed_path().exists():
        return
    kernel.path().parent.mkdir(parents=True, exist_ok=True)
    _BUILDS[kernel] = subprocess.Popen(
        [sys.executable, "-m", "tmpc.compiler.aot", kernel.module,
         "nrt" if kernel.nrt else "no-nrt", *(x for pair in kernel.exports for x in pair)],
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def obtain(kernel: Kernel):
    """(module, None) with the built kernel, building it first if needed; (None, why) when
    there is none to be had (off, or the build failed: the first time ``why`` says so and
    the failure is recorded)."""
    if not enabled():
        return None, "TMPC_AOT=0"
    path, failed = kernel.path(), kernel.failed_path()
    if not path.exists() and not failed.exists():
        prepare(kernel)
        proc = _BUILDS.pop(kernel)
        try:
            _, err = proc.communicate(timeout=BUILD_SECONDS)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            err = f"it took over {BUILD_SECONDS} s"
        if proc.returncode != 0 or not path.exists():
            lines = [ln for ln in (err or "").strip().splitlines() if ln.strip()]
            why = lines[-1] if lines else f"exit status {proc.returncode}"
            atomic_write_text(failed, why + "\n")
            return None, f"the ahead-of-time build failed: {why}"
    if failed.exists() and not path.exists():
        return None, "the ahead-of-time build failed before: " + \
            failed.read_text(errors="replace").strip()
    try:
        spec = importlib.util.spec_from_file_location(kernel.name(), path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except (ImportError, OSError) as exc:         # damaged: build it again next time
        path.unlink(missing_ok=True)
        return None, f"the built module {path} did not load ({exc}); it will be rebuilt"
    return module, None


def build(kernel: Kernel) -> Path:
    """Compile ``kernel`` with numba's ``pycc`` (this process imports numba) into its path."""
    from numba.pycc import CC

    from tmpc.compiler import numbacfg  # noqa: F401  (numba's settings, as for the JIT)

    module = importlib.import_module(kernel.module)
    target = kernel.path()
    target.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(dir=target.parent, prefix=".build-"))
    try:
        cc = CC(kernel.name())
        cc.output_dir = str(work)
        cc.target_cpu = "host"        # built where it runs: this machine's instruction set
        cc.verbose = False
        cc.use_nrt = kernel.nrt
        for function, signature in kernel.exports:
            cc.export(function, signature)(getattr(module, function).py_func)
        cc.compile()
        built = work / target.name
        if not built.exists():
            raise RuntimeError(f"numba.pycc wrote no {target.name}")
        os.replace(built, target)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return target


if __name__ == "__main__":           # the child process of prepare()
    # an empty machine-code cache of its own: numba's JIT cache holds the kernel's helpers
    # compiled with reference counting (a JIT run's), and a build reusing them links symbols
    # a module built without it cannot resolve
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="tmpc-aot-numba-")
    try:
        args = sys.argv[3:]
        build(Kernel(sys.argv[1], tuple(zip(args[::2], args[1::2])), sys.argv[2] == "nrt"))
    except Exception as exc:  # noqa: BLE001 - the parent records the last line, falls back
        first = next((ln for ln in str(exc).splitlines() if ln.strip()), "")
        first = first.split(" If using conda")[0]        # numba's hint for conda users
        sys.stderr.write(f"\n{type(exc).__name__}: {first}\n")
        sys.exit(1)
    finally:
        shutil.rmtree(os.environ["NUMBA_CACHE_DIR"], ignore_errors=True)
