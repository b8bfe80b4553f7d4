"""tmpc.runtime.bench: planner x problem x seed sweeps, their statistics, tables and OMPL logs.
"""

from tmpc.runtime.bench.sweep import Bench as Bench
from tmpc.runtime.bench.sweep import Stop as Stop
from tmpc.runtime.bench.sweep import check_output as check_output
from tmpc.runtime.bench.sweep import problem_names as problem_names
