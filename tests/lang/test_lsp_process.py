"""`tmpc lsp` as a process: it starts without JAX, Z3, lupa or numpy, and `--tcp PORT` serves
LSP on a socket as stdio does."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time


def test_the_server_starts_without_the_heavy_libraries():
    code = ("import sys\n"
            "import tmpc.runtime.cli.lsp\n"
            "from tmpc.lang.lsp import Hooks, create_server\n"
            "create_server(Hooks())\n"
            "print([m for m in ('jax', 'z3', 'lupa', 'numpy', 'tmpc.compiler.compile') "
            "if m in sys.modules])\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


def _frame(msg: dict) -> bytes:
    body = json.dumps(msg).encode()
    return b"Content-Length: %d\r\n\r\n" % len(body) + body


def _read(sock_file) -> dict:
    length = 0
    while (line := sock_file.readline().strip()):
        if line.lower().startswith(b"content-length:"):
            length = int(line.split(b":")[1])
    return json.loads(sock_file.read(length))


def test_tcp_serves_initialize_and_shuts_down():
    with socket.socket() as s:                 # a free port
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "tmpc.runtime.cli", "lsp", "--tcp", str(port),
                             "--no-worker"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        end = time.monotonic() + 30
        while True:
            try:
                conn = socket.create_connection(("127.0.0.1", port), timeout=30)
                break
            except OSError:
                assert proc.poll() is None and time.monotonic() < end, proc.stderr.read()
                time.sleep(0.05)
        with conn, conn.makefile("rb") as f:
            conn.sendall(_frame({"jsonrpc": "2.0", "id": 1, "method": "initialize",
                                 "params": {"processId": None, "rootUri": None,
                                            "capabilities": {}}}))
            reply = _read(f)
            assert reply["id"] == 1 and reply["result"]["serverInfo"]["name"] == "tmpc"
            assert reply["result"]["capabilities"]["hoverProvider"]
            conn.sendall(_frame({"jsonrpc": "2.0", "id": 2, "method": "shutdown"}))
            assert _read(f)["id"] == 2
            conn.sendall(_frame({"jsonrpc": "2.0", "method": "exit"}))
        assert proc.wait(timeout=30) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
