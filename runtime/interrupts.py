"""SIGINT and SIGTERM: a clean stop at any instant.

The console entry (:func:`tmpc.runtime.cli.main.run_and_exit`) calls :func:`install`: both
signals are blocked in the main thread (and so in every thread started later, XLA's included)
and a watcher thread takes them with ``sigwait``, so a signal is handled at once even while the
main thread is inside XLA or Lua, and never as a Python exception in the middle of a C++
callback (a KeyboardInterrupt there once ended in SIGSEGV, or was swallowed by a GC callback and
the run went on). What the watcher does depends on the phase:

* by default (loading, compiling, setup): print ``interrupted``, remove temporary files of
  atomic writes in flight (:mod:`tmpc.lang.fileio`), exit 130 at once;
* inside :func:`interruptible` (planning): raise KeyboardInterrupt in the main thread, so the
  planner stops with its best progress (``tmpc run`` then writes a partial plan, exit 3); if
  the main thread is inside C code that does not return within :data:`GRACE` seconds (a
  runaway Lua predicate), stop as above;
* inside :func:`writing` (an output being written): remember it and stop when the write is done.
"""

from __future__ import annotations

import _thread
import os
import signal
import sys
import threading
from contextlib import contextmanager

from tmpc.lang.fileio import remove_in_flight

EXIT_INTERRUPTED = 130
_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_lock = threading.Lock()
_state = {"phase": "stop", "pending": False, "installed": False, "generation": 0}
#: seconds a planner has to stop with its best progress before the process stops anyway
GRACE = 2.0


def install() -> bool:
    """Route SIGINT and SIGTERM to the watcher thread (from the main thread only; a no-op where
    ``pthread_sigmask`` does not exist). Returns whether it did."""
    if _state["installed"] or not hasattr(signal, "pthread_sigmask") or \
            threading.current_thread() is not threading.main_thread():
        return False
    signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    threading.Thread(target=_watch, daemon=True, name="tmpc-signals").start()
    _state["installed"] = True
    return True


def _watch() -> None:
    while True:
        signal.sigwait(_SIGNALS)
        with _lock:
            phase = _state["phase"]
            if phase == "interruptible":
                _thread.interrupt_main()
                # the main thread may be inside C code that does not return soon (a Lua call,
                # an XLA compile): if the planner has not stopped within the grace period, stop
                threading.Timer(GRACE, _unless_stopped, (_state["generation"],)).start()
            elif phase == "writing":
                _state["pending"] = True
            else:
                stop()


def _unless_stopped(generation: int) -> None:
    with _lock:
        if _state["phase"] != "interruptible" or _state["generation"] != generation:
            return
    stop()


def stop() -> None:
    """Exit 130 now, leaving no temporary file of an atomic write behind."""
    remove_in_flight()
    try:
        sys.stderr.write("interrupted\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    os._exit(EXIT_INTERRUPTED)


@contextmanager
def _phase(name: str):
    with _lock:
        before, _state["phase"] = _state["phase"], name
        _state["generation"] += 1
    try:
        yield
    finally:
        with _lock:
            _state["phase"] = before
            _state["generation"] += 1
            pending = _state["pending"] and before != "writing"
        if pending:
            stop()


def interruptible():
    """A signal raises KeyboardInterrupt in the main thread (a planner's loop handles it)."""
    return _phase("interruptible")


def writing():
    """A signal waits until the block ends (an output is being written), then stops."""
    return _phase("writing")
