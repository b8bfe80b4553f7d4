"""The symbolic state a start implies: its mode atoms (or the problem's initial ones) and the
geometric symbols true where its objects are."""

from __future__ import annotations

from typing import Any

from tmpc.compiler.ground import is_symbol
from tmpc.compiler.state import WorldState
from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.plans import parse_ground
from tmpc.runtime.problem import true_symbols


def start_symbols(compiled: Any, state: WorldState, from_atoms: bool = True) -> int:
    """The ground symbolic state (a bitset) of ``state``: its mode atoms when it lists them
    (``from_atoms``; static facts are skipped, an unknown atom is E580), else the problem's
    initial atoms; geometric symbols decided at ``state`` either way."""
    gp = compiled.ground
    symbols = [i for i, a in enumerate(gp.atoms) if is_symbol(a.predicate)]
    if from_atoms and state.atoms:
        sym = 0
        for text in state.atoms:
            parsed = parse_ground(text)
            i = gp.atom_id(parsed[0], *parsed[1]) if parsed is not None else None
            if i is None:
                if parsed is not None and _static(gp, parsed):
                    continue
                raise InputError(error("E580", f"<state>: /mode/atoms: unknown atom `{text}`",
                                       None, "atoms are written `(predicate arg...)`"))
            sym |= 1 << i
    else:
        sym = gp.init
        for i in symbols:
            sym &= ~(1 << i)
    if symbols:
        sym |= true_symbols(gp, compiled.scene, compiled.model, compiled.program.scope,
                            state.poses)
    return sym


def _static(gp: Any, parsed: tuple[str, tuple[str, ...]]) -> bool:
    name, args = parsed
    return any(p.lower() == name.lower() and tuple(a.lower() for a in xs) ==
               tuple(a.lower() for a in args) for p, xs in gp.static_facts)
