"""The worker's loop: JSON lines in, JSON lines out.

A request is one line ``{"id": int, "method": str, "params": {...}}``; the answer is one line
``{"id": ..., "result": ...}`` or ``{"id": ..., "error": {"message": str, "diagnostics":
[...]}}`` (diagnostics in :mod:`tmpc.runtime.lsp_worker.wire`'s form). Methods (:data:`METHODS`):
``ping`` -> ``{"pid"}``, and ``witness``, ``evaluate``, ``static``, ``view`` whose params are
the keyword arguments of :mod:`tmpc.runtime.lsp_worker.work`'s functions.

Nothing a request does stops the loop: a :class:`~tmpc.lang.diagnostics.TmpcError` is answered
with its diagnostics, any other exception with its type and message (its traceback goes to
stderr), a line that is not a request (not JSON, no id, unknown method, wrong params) with an
error (id null when it has none). End of input ends the loop. :func:`main` keeps the real
stdout for the protocol and points ``sys.stdout`` and fd 1 at stderr, so a stray print (from
Python or C) cannot corrupt the stream.
"""

from __future__ import annotations

import inspect
import io
import json
import math
import os
import sys
import traceback
from typing import Callable, TextIO

from tmpc.lang.diagnostics import TmpcError
from tmpc.runtime.lsp_worker.wire import diagnostic_to_json

#: method -> the function of :mod:`tmpc.runtime.lsp_worker.work` it calls (``ping`` is the loop's)
METHODS = {"ping": None, "witness": "witness", "evaluate": "evaluate", "static": "static_checks",
           "view": "view"}


class BadRequest(Exception):
    """A line that is not a well-formed request."""


def serve(stdin: TextIO, stdout: TextIO) -> int:
    """Answer requests from ``stdin`` on ``stdout`` until end of input; returns 0 (also when
    ``stdout`` is closed by the reader)."""
    while line := stdin.readline():
        if not line.strip():
            continue
        try:
            stdout.write(encode(respond(line)) + "\n")
            stdout.flush()
        except (BrokenPipeError, ValueError):      # the reader is gone (ValueError: closed)
            return 0
    return 0


def respond(line: str) -> dict:
    """The answer to one request line."""
    rid = None
    try:
        req = _request(line)
        rid = req["id"]
        return {"id": rid, "result": _call(*_method(req))}
    except BadRequest as exc:
        return error_reply(rid, str(exc))
    except TmpcError as exc:
        return error_reply(rid, str(exc), [diagnostic_to_json(d) for d in exc.diagnostics])
    except Exception as exc:                       # a bug or a bad value: the loop lives on
        traceback.print_exc(file=sys.stderr)
        return error_reply(rid, f"{type(exc).__name__}: {exc}")


def error_reply(rid, message: str, diagnostics: list | None = None) -> dict:
    return {"id": rid, "error": {"message": message, "diagnostics": diagnostics or []}}


def encode(reply: dict) -> str:
    """One protocol line: strict JSON (a non-finite number becomes null)."""
    try:
        return json.dumps(_finite(reply), allow_nan=False)
    except (TypeError, ValueError) as exc:
        return json.dumps(error_reply(reply.get("id"), f"the result is not JSON: {exc}"))


def _request(line: str) -> dict:
    """The request object of a line, with an id (BadRequest otherwise)."""
    try:
        req = json.loads(line)
    except ValueError as exc:
        raise BadRequest(f"not a JSON request: {exc}") from None
    rid = req.get("id") if isinstance(req, dict) else None
    if not isinstance(rid, (int, str)) or isinstance(rid, bool):
        raise BadRequest('a request is {"id": int, "method": str, "params": {...}}')
    return req


def _method(req: dict) -> tuple[str, dict]:
    method, params = req.get("method"), req.get("params", {})
    if method not in METHODS:
        raise BadRequest(f"unknown method {method!r}; methods: {', '.join(METHODS)}")
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise BadRequest(f"`{method}`: params must be an object")
    return method, params


def _call(method: str, params: dict):
    if method == "ping":
        if params:
            raise BadRequest("`ping` takes no params")
        return {"pid": os.getpid()}
    fn = _handler(method)
    try:
        inspect.signature(fn).bind(**params)
    except TypeError as exc:
        raise BadRequest(f"`{method}`: {exc}") from None
    return fn(**params)


def _handler(method: str) -> Callable:
    # imported on the first heavy request, for start-up time: `ping` answers before numpy, the
    # compiler and JAX are loaded
    from tmpc.runtime.lsp_worker import work
    return getattr(work, METHODS[method])


def _finite(value):
    """``value`` with non-finite floats as None (JSON has no inf/NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def main() -> int:
    """Run the worker on this process's stdin and stdout (``python -m tmpc.runtime.lsp_worker``)."""
    protocol = _protocol_stream()
    stdin = io.TextIOWrapper(sys.stdin.buffer, encoding="utf-8", errors="replace")
    return serve(stdin, protocol)


def _protocol_stream() -> TextIO:
    """A stream on the real stdout for protocol lines; fd 1 and ``sys.stdout`` then go to
    stderr."""
    sys.stdout.flush()
    fd = os.dup(1)
    try:
        os.dup2(2, 1)
    except OSError:
        pass                     # no usable stderr: Python-level prints are redirected anyway
    sys.stdout = sys.stderr
    return open(fd, "w", encoding="utf-8", newline="\n")
