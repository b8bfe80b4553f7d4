"""tmpc: a compiler and interpreter for robot task and motion planning; the Python API
(docs/api.md): ``tmpc.load(path).plan()``. Light to import: the API's names (and numpy, the
compiler, JAX) load on first use (PEP 562). Installed as the package ``tmpc`` itself."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from tmpc.runtime.api import (
        Diagnostic as Diagnostic,
    )
    from tmpc.runtime.api import (
        Plan as Plan,
    )
    from tmpc.runtime.api import (
        Planner as Planner,
    )
    from tmpc.runtime.api import (
        PlannerFactory as PlannerFactory,
    )
    from tmpc.runtime.api import (
        PlannerResult as PlannerResult,
    )
    from tmpc.runtime.api import (
        TmpcError as TmpcError,
    )
    from tmpc.runtime.api import (
        World as World,
    )
    from tmpc.runtime.api import (
        check as check,
    )
    from tmpc.runtime.api import (
        compile as compile,
    )
    from tmpc.runtime.api import (
        load as load,
    )

__version__ = "0.1.0"
__all__ = ["load", "check", "compile", "World", "Plan", "Planner", "PlannerFactory",
           "PlannerResult", "Diagnostic", "TmpcError"]


def __getattr__(name: str) -> Any:
    if name not in __all__:
        raise AttributeError(f"module 'tmpc' has no attribute {name!r}")
    # the API (numpy, the compiler) loads on first use: `import tmpc` stays light
    import tmpc.runtime.api as api
    return getattr(api, name)


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
