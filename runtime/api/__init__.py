"""tmpc.runtime.api: the Python API (docs/api.md), what ``import tmpc`` exposes: :func:`load` a
world, :func:`check` files, :func:`compile` an artifact; a :class:`World` plans (again, from any
start, in one process), validates, views, evaluates and samples; a :class:`Plan` is what
planning returns; :class:`Planner` is what a registered planner satisfies."""

from tmpc.lang.diagnostics import Diagnostic as Diagnostic
from tmpc.lang.diagnostics import TmpcError as TmpcError
from tmpc.runtime.api.plan import Plan as Plan
from tmpc.runtime.api.protocol import Planner as Planner
from tmpc.runtime.api.protocol import PlannerFactory as PlannerFactory
from tmpc.runtime.api.protocol import PlannerResult as PlannerResult
from tmpc.runtime.api.symbolic import start_symbols as start_symbols
from tmpc.runtime.api.world import World as World
from tmpc.runtime.api.world import check as check
from tmpc.runtime.api.world import compile as compile
from tmpc.runtime.api.world import load as load

__all__ = ["load", "check", "compile", "World", "Plan", "Planner", "PlannerFactory",
           "PlannerResult", "Diagnostic", "TmpcError", "start_symbols"]
