"""tmpc.compiler.smt: the Z3 task encoding (SMT-LIB2 step templates), its analyses (relevance,
landmark bound, mutexes) and the static checks reported as diagnostics.
"""

from tmpc.compiler.smt.bound import lmcut as lmcut
from tmpc.compiler.smt.checks import not_checked_note as not_checked_note
from tmpc.compiler.smt.checks import static_checks as static_checks
from tmpc.compiler.smt.checks import unreachable_goal_names as unreachable_goal_names
from tmpc.compiler.smt.encode import Changers as Changers
from tmpc.compiler.smt.encode import Encoding as Encoding
from tmpc.compiler.smt.encode import encode as encode
from tmpc.compiler.smt.encode import relevant_atoms as relevant_atoms
from tmpc.compiler.smt.encode import smtlib_templates as smtlib_templates
from tmpc.compiler.smt.mutex import mutex_pairs as mutex_pairs
