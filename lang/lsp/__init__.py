"""tmpc.lang.lsp: the language server (`tmpc lsp`), on pygls.

Starts without JAX, Z3 or lupa: what needs them comes in through :class:`Hooks` from the
composition root (the compiled-meaning hover) or runs in the worker process whose command it
names (witnesses, evaluation at the start state, static checks).
"""

from tmpc.lang.lsp.server import Hooks as Hooks
from tmpc.lang.lsp.server import TmpcServer as TmpcServer
from tmpc.lang.lsp.server import create_server as create_server
