"""tmpc.runtime.simulate: the physics check of a plan in MuJoCo (docs/physics.md)."""

from tmpc.runtime.simulate.report import DRIFT_LIMIT as DRIFT_LIMIT
from tmpc.runtime.simulate.report import TILT_LIMIT as TILT_LIMIT
from tmpc.runtime.simulate.report import SimReport as SimReport
from tmpc.runtime.simulate.run import simulate as simulate
from tmpc.runtime.simulate.page import write_sim_html as write_sim_html
