"""tmpc.runtime.simulate: the physics check of a plan in MuJoCo (docs/robot-export.md)."""

from tmpc.runtime.simulate.run import DRIFT_LIMIT as DRIFT_LIMIT
from tmpc.runtime.simulate.run import SimReport as SimReport
from tmpc.runtime.simulate.run import simulate as simulate
