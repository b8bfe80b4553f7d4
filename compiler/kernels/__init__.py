"""tmpc.compiler.kernels: IR -> JAX. The kernel tables (entities, poses, frames), the truth and
distance kernels of lifted formulas, and the projection sampler. Forward kinematics is
:mod:`tmpc.compiler.robot`; the JAX configuration is :mod:`tmpc.compiler.jaxcfg`.
"""

from tmpc.compiler.kernels.bands import inner_bands as inner_bands
from tmpc.compiler.kernels.emit import Options as Options
from tmpc.compiler.kernels.emit import condition_kernel as condition_kernel
from tmpc.compiler.kernels.emit import has_lua_calls as has_lua_calls
from tmpc.compiler.kernels.emit import lua_host_call as lua_host_call
from tmpc.compiler.kernels.emit import residual_kernel as residual_kernel
from tmpc.compiler.kernels.emit import state_inputs as state_inputs
from tmpc.compiler.kernels.project import make_projector as make_projector
from tmpc.compiler.kernels.project import projector_fn as projector_fn
from tmpc.compiler.kernels.project import uniform_starts as uniform_starts
from tmpc.compiler.kernels.tables import KernelTables as KernelTables
from tmpc.compiler.kernels.tables import build_tables as build_tables
