"""Lazy package attributes (PEP 562): a package lists its heavy names and the modules that
define them, and imports a module only when one of its names is first used, so importing the
package costs nothing (`tmpc check` and the language server never load JAX, Z3 or OMPL)."""

from __future__ import annotations

import importlib
from typing import Any, Callable, Mapping


def lazy_getattr(package: str, table: Mapping[str, str]) -> Callable[[str], Any]:
    """A module ``__getattr__`` for ``package``: ``table`` maps a name to the module that
    defines it; other names are an AttributeError."""
    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(module), name)
    return __getattr__
