"""Atomic file writes: a reader sees the old file or the new one, never half of either."""

from __future__ import annotations

import os
import tempfile
import threading
from pathlib import Path

#: temporary files of atomic writes under way (removed by an interrupt, tmpc.runtime.interrupts)
_IN_FLIGHT: set[str] = set()
#: guards making a temporary file and listing it, against :func:`remove_in_flight`
_LOCK = threading.Lock()
_STOPPING = [False]


class StoppingError(OSError):
    """The process is stopping: no new temporary file is made."""


def remove_in_flight() -> None:
    """Remove the temporary files of the atomic writes under way (the process is stopping);
    from then on no thread makes a new one (a kernel export finishing on another thread would
    otherwise leave its file between this call and the exit)."""
    with _LOCK:
        _STOPPING[0] = True
        for tmp in list(_IN_FLIGHT):
            try:
                os.unlink(tmp)
            except OSError:
                pass


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, fsync it, then rename over ``path``.

    File permissions of an existing ``path`` are kept.
    """
    path = Path(path)
    with _LOCK:
        if _STOPPING[0]:
            raise StoppingError(f"not writing {path}: the process is stopping")
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp",
                                   dir=path.parent or ".")
        _IN_FLIGHT.add(tmp)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if path.exists():
            os.chmod(tmp, path.stat().st_mode & 0o7777)
        else:                               # mkstemp makes 0600; a new file gets the usual mode
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    finally:
        _IN_FLIGHT.discard(tmp)


def unwritable(path: str | Path) -> str | None:
    """Why a file could not be written at ``path`` (a directory, no such directory, a directory
    without write permission), or None: checked before work whose result would be lost."""
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if p.is_dir():
        return "it is a directory"
    if not parent.is_dir():
        return f"no such directory {parent}"
    if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        return f"{'it' if p.exists() else f'the directory {parent}'} is not writable"
    return None


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))
