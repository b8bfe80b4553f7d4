"""One place that imports numba for tmpc's compiled kernels (A*'s LM-cut, the collision first
pass): its machine-code cache goes under tmpc's cache folder (``numba/``) unless
``$NUMBA_CACHE_DIR`` says otherwise, so a kernel compiles once per machine. Import this module
only where a kernel runs: ``tmpc --help``, ``tmpc check`` and the language server load no numba.
"""

from __future__ import annotations

import os

from tmpc.compiler.cache import cache_root

os.environ.setdefault("NUMBA_CACHE_DIR", str(cache_root() / "numba"))

import numba  # noqa: E402  (after NUMBA_CACHE_DIR: numba reads it at import)

__all__ = ["numba"]
