"""``python -m tmpc.runtime.editor``: the language server's worker process (JSON lines on
stdin/stdout, :mod:`tmpc.runtime.editor.protocol`)."""

from tmpc.runtime.editor.protocol import main

raise SystemExit(main())
