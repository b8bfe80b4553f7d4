"""tmpc.runtime.lsp_worker: the language server's heavy-work worker.

``tmpc lsp`` (in ``lang/``, which never imports JAX, Z3 or lupa) spawns ``python -m
tmpc.runtime.lsp_worker`` and sends it JSON-line requests
(:mod:`tmpc.runtime.lsp_worker.protocol`): witness states by the projection sampler, evaluation
at the start state, and the static checks of ``tmpc check --static``
(:mod:`tmpc.runtime.lsp_worker.work`), diagnostics crossing as JSON
(:mod:`tmpc.runtime.lsp_worker.wire`).

The loop and the wire format are light; the request functions (which load the compiler) resolve
on first access (PEP 562 ``__getattr__`` below), so the worker answers ``ping`` before they are
imported.
"""

from tmpc.runtime.lazy import lazy_getattr
from tmpc.runtime.lsp_worker.protocol import METHODS as METHODS
from tmpc.runtime.lsp_worker.protocol import main as main
from tmpc.runtime.lsp_worker.protocol import respond as respond
from tmpc.runtime.lsp_worker.protocol import serve as serve
from tmpc.runtime.lsp_worker.wire import diagnostic_to_json as diagnostic_to_json

#: heavy names of this package, imported on first access
_LAZY = {name: "tmpc.runtime.lsp_worker.work" for name in
         ("witness", "evaluate", "static_checks", "view", "WorldCache", "WORLDS",
          "MAX_GROUNDINGS")}


__getattr__ = lazy_getattr(__name__, _LAZY)


__all__ = ["METHODS", "main", "respond", "serve", "diagnostic_to_json", *_LAZY]
