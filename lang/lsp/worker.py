"""The language server's side of the heavy-work worker: a separate process (compile, sample,
SMT checks) that speaks JSON lines on its stdin/stdout.

The server never imports JAX, Z3 or lupa for this work: it is handed the worker's command line
by the composition root (``tmpc lsp`` passes ``python -m tmpc.runtime.lsp_worker``). One request
runs at a time. A request past its time budget, or cancelled by the editor, kills the worker (the
next request starts a fresh one); a worker that dies is reported as :class:`WorkerError`, and the
server lives on. The worker keeps compiled worlds in memory, and the artifact cache on disk, so a
second request on unchanged files is fast.
"""

from __future__ import annotations

import asyncio
import json
import sys


class WorkerError(Exception):
    """A request failed: the worker's error (``diagnostics`` as JSON), a crash or a timeout."""

    def __init__(self, message: str, diagnostics: list | None = None):
        super().__init__(message)
        self.diagnostics = diagnostics or []


class Worker:
    def __init__(self, command: list[str]):
        self.command = command
        self._proc: asyncio.subprocess.Process | None = None
        self._lock = asyncio.Lock()
        self._next = 0

    async def _ensure(self) -> asyncio.subprocess.Process:
        if self._proc is None or self._proc.returncode is not None:
            self._proc = await asyncio.create_subprocess_exec(
                *self.command, stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE,
                stderr=sys.stderr, limit=64 * 1024 * 1024)
        return self._proc

    async def start(self) -> None:
        """Start the worker ahead of the first request (its imports take a few seconds)."""
        async with self._lock:
            await self._ensure()

    async def call(self, method: str, params: dict, timeout: float) -> dict:
        async with self._lock:
            proc = await self._ensure()
            self._next += 1
            line = json.dumps({"id": self._next, "method": method, "params": params}) + "\n"
            try:
                proc.stdin.write(line.encode())
                await proc.stdin.drain()
                raw = await asyncio.wait_for(proc.stdout.readline(), timeout)
            except asyncio.TimeoutError:
                self.kill()
                raise WorkerError(f"`{method}` took longer than its {timeout:g} s budget and was "
                                  "stopped") from None
            except asyncio.CancelledError:
                self.kill()                     # the editor cancelled: stop the work now
                raise
            except (BrokenPipeError, ConnectionResetError):
                self.kill()
                raise WorkerError("the tmpc worker process stopped; it restarts on the next "
                                  "request") from None
            if not raw:
                code = await proc.wait()
                self._proc = None
                raise WorkerError(f"the tmpc worker process exited (status {code}) during "
                                  f"`{method}`; it restarts on the next request")
            try:
                reply = json.loads(raw)
            except ValueError:
                self.kill()
                raise WorkerError("the tmpc worker answered something that is not JSON") from None
        if "error" in reply:
            err = reply["error"] or {}
            raise WorkerError(err.get("message", "the worker failed"), err.get("diagnostics"))
        return reply.get("result")

    @property
    def pid(self) -> int | None:
        """The worker process's id while it runs."""
        alive = self._proc is not None and self._proc.returncode is None
        return self._proc.pid if alive else None

    def kill(self) -> None:
        if self._proc is not None and self._proc.returncode is None:
            try:
                self._proc.kill()
            except ProcessLookupError:
                pass
        self._proc = None

    async def stop(self) -> None:
        if self._proc is not None and self._proc.returncode is None:
            self._proc.stdin.close()
            try:
                await asyncio.wait_for(self._proc.wait(), 2.0)
            except asyncio.TimeoutError:
                self.kill()
        self._proc = None
