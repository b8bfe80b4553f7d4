"""`tmpc lsp [--tcp PORT] [--no-worker]`: the language server (tmpc.lang.lsp) wired to the
compiler's explain hook and the runtime's worker process. Logs go to stderr."""

from __future__ import annotations

import gc
import logging
import sys

from tmpc.lang.lsp import Hooks, create_server
from tmpc.runtime.cli.exits import EXIT_OK


def run_lsp(args) -> int:
    def explain(scope, decl, lua_path):
        # the compiler is imported after start (warm, below) or on the first hover
        from tmpc.compiler.explain import explain_predicate
        return explain_predicate(scope, decl, lua_path)

    def warm():
        import tmpc.compiler.explain  # noqa: F401  (numpy and the lowering)

    logging.basicConfig(stream=sys.stderr, level=logging.WARNING,
                        format="tmpc lsp: %(levelname)s %(message)s")
    worker = None if args.no_worker or not _has_worker() else \
        [sys.executable, "-m", "tmpc.runtime.lsp_worker"]
    server = create_server(Hooks(explain=explain, warm=warm, worker_command=worker), _version())
    # a long-lived process that re-parses on every edit: the objects of start-up are never
    # scanned again, and the young generation is collected less often (edits reach their
    # diagnostics sooner; tests/bench/test_bench_lsp.py measures it)
    gc.freeze()
    gc.set_threshold(50_000, 20, 100)
    if args.tcp is not None:
        server.start_tcp("127.0.0.1", args.tcp)
    else:
        server.start_io()
    return EXIT_OK


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("tmpc")
    except PackageNotFoundError:
        return "0"


def _has_worker() -> bool:
    """Whether the heavy-work worker (tmpc.runtime.lsp_worker) is installed."""
    from importlib.util import find_spec
    return find_spec("tmpc.runtime.lsp_worker") is not None
