"""One place that imports and configures JAX for tmpc.

* 64-bit floats: forward kinematics and distances are checked to 1e-9 against independent
  implementations, which float32 cannot give.
* A persistent compilation cache (``$TMPC_CACHE_DIR`` or ``~/.cache/tmpc/jax``) so repeated CLI
  runs and test sessions do not pay XLA compilation again. ``TMPC_JAX_CACHE=0`` turns it off.
"""

from __future__ import annotations

import ctypes
import os
from functools import lru_cache
from pathlib import Path

from tmpc.compiler.cache import cache_root


def cache_dir() -> Path:
    """XLA's persistent compilation cache."""
    return cache_root() / "jax"


def _import_jax():
    """``import jax``, without reading every installed distribution's metadata.

    JAX 0.10's ``jax._src.numpy.array_constructors`` looks for a ROCm plugin at import by
    parsing the METADATA of every installed distribution (``importlib.metadata.distributions``),
    a cost in each run's start-up that grows with the environment (more with the ``cluster``
    extra). A plugin's distribution is named ``jax-...-plugin``, so while JAX is imported the
    scan sees only the distributions whose folder name starts with ``jax``: the
    same plugins are found, and the rest are not parsed.
    """
    import importlib.metadata as md

    every = md.distributions

    def jax_named(**kw):
        for dist in every(**kw):
            folder = getattr(dist, "_path", None)
            if folder is None or folder.name.lower().startswith("jax"):
                yield dist

    md.distributions = jax_named
    try:
        import jax
    finally:
        md.distributions = every
    return jax


@lru_cache(maxsize=1)
def configured():
    """The configured ``jax`` module (idempotent)."""
    jax = _import_jax()

    jax.config.update("jax_enable_x64", True)
    jax.config.update("jax_platforms", "cpu")
    if os.environ.get("TMPC_JAX_CACHE", "1") != "0":
        try:
            cache_dir().mkdir(parents=True, exist_ok=True)
            jax.config.update("jax_compilation_cache_dir", str(cache_dir()))
            jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.2)
            jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
        except OSError:
            pass   # a read-only home: run without the cache
    return jax


@lru_cache(maxsize=1)
def _libc():
    try:
        libc = ctypes.CDLL("libc.so.6")
        return libc if hasattr(libc, "malloc_trim") else None
    except OSError:
        return None                      # not glibc (musl, macOS): nothing to trim


def trim_heap() -> None:
    """Give the C heap's free pages back to the OS (glibc's ``malloc_trim``; a no-op elsewhere).
    Loading an XLA executable from the compilation cache leaves freed buffers in the heap that
    glibc keeps; trimming after each load lowers a warm run's peak memory."""
    libc = _libc()
    if libc is not None:
        libc.malloc_trim(0)

