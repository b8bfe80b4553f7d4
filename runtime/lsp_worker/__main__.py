"""``python -m tmpc.runtime.lsp_worker``: the language server's worker process (JSON lines on
stdin/stdout, :mod:`tmpc.runtime.lsp_worker.protocol`)."""

from tmpc.runtime.lsp_worker.protocol import main

raise SystemExit(main())
