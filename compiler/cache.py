"""The user cache directory: ``$TMPC_CACHE_DIR``, else ``~/.cache/tmpc``. Below it: ``jax/`` (XLA's
persistent compilation cache), ``exports/`` (serialized kernels by source digest) and
``artifacts/`` (extracted artifacts by manifest digest)."""

from __future__ import annotations

import os
from pathlib import Path


def cache_root() -> Path:
    return Path(os.environ.get("TMPC_CACHE_DIR") or os.path.join(Path.home(), ".cache", "tmpc"))
