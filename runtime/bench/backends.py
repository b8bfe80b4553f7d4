"""Where a distributed sweep's runs execute: ``BACKENDS`` maps ``--backend``'s names to their
classes.

A backend takes an artifact once per problem (:meth:`put`: a handle its tasks share), runs
:func:`tmpc.runtime.bench.worker.run_task` on it (:meth:`submit`), hands back finished runs as
they finish (:meth:`wait`), and cancels what is still running (:meth:`cancel`). The coordinator
(:mod:`tmpc.runtime.bench.dispatch`) keeps at most ``workers`` runs in flight.

* ``local``: a process pool on this machine (``spawn``: JAX does not survive a fork after it
  started); the artifact travels as its path, each worker reads it once.
* ``ray``: Ray tasks (``num_cpus=1``, a memory request, ``max_retries`` for system failures
  such as a killed worker; a planner's own failure is a result and is not retried); the artifact
  goes into the object store once per problem. Ray is the ``cluster`` extra: without it,
  E831.
"""

from __future__ import annotations

import concurrent.futures as cf
import ctypes
import multiprocessing
import os
import signal
import sys
from multiprocessing import resource_tracker

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.bench.worker import run_task

#: a system failure (a killed worker, a lost node) runs the task again this many times
MAX_RETRIES = 3


class LostRun(Exception):
    """A run that ended without a record (its worker died and retries ran out)."""


class LocalBackend:
    name = "local"

    @staticmethod
    def check_installed() -> None:
        """Nothing to install."""

    def __init__(self, workers: int | None, address=None, memory_mib: int | None = None):
        self.workers = workers or os.cpu_count() or 1
        _start_resource_tracker()
        self.pool = cf.ProcessPoolExecutor(self.workers,
                                           mp_context=multiprocessing.get_context("spawn"),
                                           initializer=_die_with_parent)
        self.flight: dict = {}                         # future -> task

    def put(self, path, data: bytes):
        return str(path)

    def submit(self, handle, task: dict) -> None:
        self.flight[self.pool.submit(run_task, handle, task)] = task

    def wait(self, timeout: float) -> list[tuple[dict, dict | Exception]]:
        done, _ = cf.wait(list(self.flight), timeout=timeout, return_when=cf.FIRST_COMPLETED)
        out = []
        for fut in done:
            task = self.flight.pop(fut)
            try:
                out.append((task, fut.result()))
            except Exception as exc:     # BrokenProcessPool: a worker died
                out.append((task, LostRun(repr(exc))))
        return out

    def cancel(self) -> None:
        """Stop the runs in flight: their worker processes are ended (this pool's own)."""
        for fut in self.flight:
            fut.cancel()
        procs = list((getattr(self.pool, "_processes", None) or {}).values())
        for proc in procs:
            if proc.is_alive():
                proc.kill()
        for proc in procs:
            proc.join(1.0)
        self.flight.clear()
        self.cancelled = True

    def close(self) -> None:
        # after a cancel the pool is broken (its workers were killed): do not wait for it
        self.pool.shutdown(wait=not getattr(self, "cancelled", False), cancel_futures=True)


def _start_resource_tracker() -> None:
    """Start multiprocessing's resource tracker now, keeping this thread's signal mask.

    Starting it (which the pool's first process does) unblocks SIGINT and SIGTERM in the calling
    thread; tmpc blocks them in the main thread and takes them in a watcher thread
    (:mod:`tmpc.runtime.interrupts`), so a Ctrl-C would otherwise kill the process instead of
    cancelling the sweep."""
    if not hasattr(signal, "pthread_sigmask"):
        resource_tracker.ensure_running()
        return
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, ())
    try:
        resource_tracker.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _die_with_parent() -> None:
    """A pool worker ends when the sweep's process does (Linux: PR_SET_PDEATHSIG), so a
    coordinator killed outright leaves no worker planning on."""
    if not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)   # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() == 1:                # the parent died before prctl took effect
        os._exit(1)


def missing_ray() -> InputError:
    return InputError(error("E831", "--backend ray needs Ray, which is not installed", None,
                            "install the cluster extra: pip install 'tmpc[cluster]'"))


class RayBackend:
    name = "ray"

    @staticmethod
    def check_installed() -> None:
        """E831 before anything runs when Ray is missing (its import is not attempted here:
        it takes seconds)."""
        import importlib.util
        if importlib.util.find_spec("ray") is None:
            raise missing_ray()

    def __init__(self, workers: int | None, address: str | None = None,
                 memory_mib: int | None = None):
        try:
            import ray
        except ImportError:
            raise missing_ray() from None
        self.ray = ray
        self.owned = not ray.is_initialized()          # a cluster this sweep started (or joined)
        if self.owned:
            # no address: a local cluster of `workers` CPUs (this machine's by default)
            ray.init(address=address, num_cpus=None if address else workers,
                     include_dashboard=False, log_to_driver=False,
                     runtime_env={"env_vars": _cache_env()})
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.workers = workers or cpus
        opts = {"num_cpus": 1, "max_retries": MAX_RETRIES, "retry_exceptions": False}
        if memory_mib:
            opts["memory"] = memory_mib * 1024 * 1024
        self.remote = ray.remote(**opts)(run_task)
        self.flight: dict = {}                         # ObjectRef -> task

    def put(self, path, data: bytes):
        return self.ray.put(data)

    def submit(self, handle, task: dict) -> None:
        self.flight[self.remote.remote(handle, task)] = task

    def wait(self, timeout: float) -> list[tuple[dict, dict | Exception]]:
        if not self.flight:
            return []
        done, _ = self.ray.wait(list(self.flight), num_returns=1, timeout=timeout)
        out = []
        for ref in done:
            task = self.flight.pop(ref)
            try:
                out.append((task, self.ray.get(ref)))
            except Exception as exc:     # retries ran out (WorkerCrashedError, lost node)
                out.append((task, LostRun(f"{type(exc).__name__}: {exc}")))
        return out

    def cancel(self) -> None:
        for ref in self.flight:
            self.ray.cancel(ref, force=True)
        self.flight.clear()

    def close(self) -> None:
        """Leave the cluster this sweep connected to (stopping it if the sweep started it)."""
        if self.owned:
            self.ray.shutdown()


def _cache_env() -> dict:
    """The tmpc cache folder the workers should share with this process (extracted
    artifacts, XLA's cache)."""
    return {k: os.environ[k] for k in ("TMPC_CACHE_DIR",) if k in os.environ}


BACKENDS = {"local": LocalBackend, "ray": RayBackend}
