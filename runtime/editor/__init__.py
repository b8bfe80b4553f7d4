"""tmpc.runtime.editor: the language server's heavy-work worker.

``tmpc lsp`` (in ``lang/``, which never imports JAX, Z3 or lupa) spawns ``python -m
tmpc.runtime.editor`` and sends it JSON-line requests (:mod:`.protocol`): witness states by the
projection sampler, evaluation at the start state, and the static checks of ``tmpc check
--static`` (:mod:`.work`), diagnostics crossing as JSON (:mod:`.wire`).

The loop and the wire format are light; the request functions (which load the compiler) resolve
on first access (PEP 562 ``__getattr__`` below), so the worker answers ``ping`` before they are
imported.
"""

from tmpc.runtime.editor.protocol import METHODS as METHODS
from tmpc.runtime.editor.protocol import main as main
from tmpc.runtime.editor.protocol import respond as respond
from tmpc.runtime.editor.protocol import serve as serve
from tmpc.runtime.editor.wire import diagnostic_to_json as diagnostic_to_json

#: heavy names of this package, imported on first access
_LAZY = {name: "tmpc.runtime.editor.work" for name in
         ("witness", "evaluate", "static_checks", "view", "WorldCache", "WORLDS",
          "MAX_GROUNDINGS")}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib
    return getattr(importlib.import_module(module), name)


__all__ = ["METHODS", "main", "respond", "serve", "diagnostic_to_json", *_LAZY]
