"""`tmpc bench --param NAME=V1,V2,...`: planner-option sweeps.

A parameter is an override a planner's factory reads (``PlannerSpec.parameters``, e.g. the
unified planner's ``heuristic_bias``); several ``--param`` give their cross product, and each run
records its point (``params``). Values read as JSON scalars where they can (``0.4``, ``3``,
``true``), else as strings.
"""

from __future__ import annotations

import itertools
import json

from tmpc.runtime.planners import PLANNERS


class ParamError(ValueError):
    """A malformed or unknown ``--param`` (a usage error: nothing has run)."""


def parse_value(text: str):
    try:
        v = json.loads(text)
    except ValueError:
        return text
    return v if isinstance(v, (int, float, bool, str)) else text


def parse_params(specs: list[str] | None, planners: list[str]) -> dict[str, list]:
    """``["heuristic_bias=0.2,0.4"]`` -> ``{"heuristic_bias": [0.2, 0.4]}``; every name must be a
    parameter of every selected planner (ParamError says which planner lacks it)."""
    out: dict[str, list] = {}
    for spec in specs or []:
        name, eq, values = spec.partition("=")
        name = name.strip()
        vals = [parse_value(v.strip()) for v in values.split(",") if v.strip()]
        if not eq or not name or not vals:
            raise ParamError(f"--param {spec!r}: expected NAME=V1,V2,...")
        if name in out:
            raise ParamError(f"--param {name} is given twice")
        for planner in planners:
            known = PLANNERS[planner].parameters
            if name not in known:
                raise ParamError(f"--param {name}: not a parameter of planner {planner} (its "
                                 f"parameters: {', '.join(known) or 'none'})")
        out[name] = vals
    return out


def param_points(grid: dict[str, list]) -> list[dict]:
    """The cross product of a parsed grid, in the order given ([{}] for no parameters)."""
    names = list(grid)
    return [dict(zip(names, combo)) for combo in itertools.product(*(grid[n] for n in names))]


def params_key(params: dict | None) -> str:
    """A parameter point as a stable string (the resume key's part)."""
    return json.dumps(params or {}, sort_keys=True)
