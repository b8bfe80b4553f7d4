"""tmpc.compiler.ground: a checked program -> :class:`GroundProblem` (objects, atoms, ground actions
with discrete and geometric parts, derived axioms), pruned by relaxed reachability; and LM-cut over
its delete relaxation (:class:`LMCut`).
"""

from tmpc.compiler.ground.build import build
from tmpc.compiler.ground.formula import GAnd as GAnd
from tmpc.compiler.ground.formula import GAtom as GAtom
from tmpc.compiler.ground.formula import GeoLiteral as GeoLiteral
from tmpc.compiler.ground.formula import GFalse as GFalse
from tmpc.compiler.ground.formula import GFormula as GFormula
from tmpc.compiler.ground.formula import GGeo as GGeo
from tmpc.compiler.ground.formula import GNot as GNot
from tmpc.compiler.ground.formula import GOr as GOr
from tmpc.compiler.ground.formula import GTrue as GTrue
from tmpc.compiler.ground.formula import atom_ids as atom_ids
from tmpc.compiler.ground.formula import conj as conj
from tmpc.compiler.ground.formula import conjuncts as conjuncts
from tmpc.compiler.ground.formula import geo_atoms as geo_atoms
from tmpc.compiler.ground.formula import relaxed_holds as relaxed_holds
from tmpc.compiler.ground.formula import small_dnf as small_dnf
from tmpc.compiler.ground.lmcut import LMCut as LMCut
from tmpc.compiler.ground.lmcut import load_kernel as load_kernel
from tmpc.compiler.ground.problem import MAX_BINDINGS as MAX_BINDINGS
from tmpc.compiler.ground.problem import GroundAction as GroundAction
from tmpc.compiler.ground.problem import GroundingError as GroundingError
from tmpc.compiler.ground.problem import GroundProblem as GroundProblem
from tmpc.compiler.ground.problem import bits as bits
from tmpc.compiler.ground.symbols import SYMBOL as SYMBOL
from tmpc.compiler.ground.symbols import is_symbol as is_symbol
from tmpc.compiler.ground.symbols import shown_as as shown_as
from tmpc.compiler.ground.symbols import with_geometric_symbols as with_geometric_symbols


def ground(program, max_bindings: int = MAX_BINDINGS) -> GroundProblem:
    """Ground ``program`` (a :class:`~tmpc.lang.checker.CheckedProgram` with a problem). Raises
    :class:`GroundingError`."""
    return build(program, max_bindings)
