"""Loading the collision checker's compiled loops: the module built ahead of time, or numba's JIT.

The loops (:mod:`tmpc.runtime.collision.pass_kernel`: the first pass's candidate search and the
checker's forward kinematics) are built once per machine with numba's ahead-of-time compiler
(``numba.pycc``, through :mod:`tmpc.compiler.aot`) into an extension module under the cache
folder, so a run imports them with no numba in the process. When that build fails, when the
module does not load, or when it refuses a call (it takes its one signature only), the same
source runs under numba's JIT instead (:func:`use_jit`), with a warning; ``TMPC_AOT=0`` forces
the JIT. docs/collision.md ("Built ahead of time", "When numba drops pycc") says why and what
replaces ``numba.pycc`` once numba removes it.
"""

from __future__ import annotations

import warnings

import numpy as np

from tmpc.compiler import aot
from tmpc.compiler.aot import Kernel

#: the collision checker's compiled loops built ahead of time, in one module:
#: :func:`~tmpc.runtime.collision.pass_kernel.candidates` and
#: :func:`~tmpc.runtime.collision.pass_kernel.kinematics` (their argument types: what
#: :meth:`tmpc.runtime.collision.first_pass.FirstPass.candidates` and
#: :class:`tmpc.runtime.collision.kinematics.Kinematics` pass; a test checks them against
#: numba's typeof)
PASS_KERNEL = Kernel("tmpc.runtime.collision.pass_kernel", (
    ("candidates",
     ("UniTuple(i8, 3)(f8[:,:,:,::1], f8[:,:,::1], i8[::1], f8[:,::1], f8[::1], f8[:,::1], "
      "f8[:,:,::1], f8[:,::1], f8[:,:,::1], f8[:,::1], i8[::1], i8[:,::1], i8[::1], b1[:,::1], "
      "i8[::1], i8[::1], f8[:,:,::1], f8[:,::1], f8[:,::1], f8[::1], f8[:,::1], i8[::1], "
      "i8[::1], f8[:,::1], i8[::1], f8[:,::1], i8[::1], f8[::1], b1[::1], f8[:,::1], f8, "
      "i8[::1], i8[::1], i8[::1], b1[::1], f8[:,::1], f8[:,::1], f8[:,::1], f8[:,::1], f8[::1], "
      "i8[::1], i8[::1], i8[::1])")),
    ("kinematics",
     ("void(f8[:,::1], i8[::1], i8[::1], f8[:,:,::1], f8[:,::1], i8[::1], f8[:,::1], i8[::1], "
      "f8[::1], f8[::1], i8, b1, f8[:,::1], f8[::1], f8[:,::1], f8, i8[::1], f8[:,:,:,::1], "
      "f8[:,:,::1])")),
    ("table_free",
     ("void(f8[:,::1], i8[:,::1], f8[:,::1], f8[:,::1], i8[:,::1], b1[:,::1], f8[:,::1], "
      "i8[::1], f8[::1], b1[:,::1])"))), nrt=False)
#: the kernels in use ("candidates", "kinematics": functions of the built module or of numba's
#: JIT) and why the JIT (None: the built module)
KERNEL_STATE: dict = {"candidates": None, "kinematics": None, "table_free": None, "why": None}


def empty_pass_args() -> tuple:
    """Arguments of :func:`~tmpc.runtime.collision.pass_kernel.candidates` for one state with no
    geometry pair (a call that loads the kernel and finds nothing)."""
    f, i = np.zeros((1, 3)), np.zeros(1, np.int64)
    e3, e = np.zeros((0, 3)), np.zeros(0, np.int64)
    return (np.zeros((1, 3, 3, 1)), np.zeros((1, 3, 1)), i, f, np.zeros(1), f,
            np.zeros((1, 3, 3)), f, np.zeros((1, 1, 3)), np.zeros((1, 1)), i,
            np.zeros((0, 2), np.int64), e, np.zeros((0, 1), bool), i, e, np.zeros((0, 3, 3)),
            e3, e3, np.zeros(0), e3, i, e, e3, i, e3, i, np.zeros(0), np.zeros(1, bool), e3,
            0.0, i.copy(), i.copy(), i.copy(), np.zeros(1, bool), f.copy(), f.copy(),
            f.copy(), np.zeros((4, 3)), np.zeros(3), i.copy(), i.copy(), i.copy())


def prepare_kernel() -> None:
    """Start building the pass ahead of time if this machine has not yet (a run calls this
    early: the build overlaps its other setup)."""
    aot.prepare(PASS_KERNEL)


def fall_back(exc: TypeError, name: str = "candidates"):
    """numba's JIT of the pass from now on (an argument the built module does not take);
    returns the JIT's function ``name``."""
    if KERNEL_STATE["why"] is not None:       # the JIT already: its refusal is a real error
        raise exc
    use_jit(f"a refused call: {exc}",
            f"the module built ahead of time refused a call ({exc}); using numba's JIT "
            "from now on (please report this)")
    return KERNEL_STATE[name]


def pass_kernel(name: str = "candidates"):
    """The compiled function ``name`` (``candidates``: the candidate search; ``kinematics``):
    the module built ahead of time (:mod:`tmpc.compiler.aot`: no numba in the process), else
    numba's JIT of the same source (the reason is kept in ``KERNEL_STATE["why"]`` and said
    once on stderr when the build has just failed)."""
    if KERNEL_STATE[name] is None:
        module, why = aot.obtain(PASS_KERNEL)
        if module is not None:
            KERNEL_STATE.update(candidates=module.candidates, kinematics=module.kinematics,
                                table_free=module.table_free)
        else:
            say = why.startswith("the ahead-of-time build failed:") or "rebuilt" in why
            use_jit(why, f"{why}; using numba's JIT instead (about 0.5 s more setup and 140 MB "
                    "more memory per run; `tmpc cache clear aot` tries the build again)"
                    if say else None)
    return KERNEL_STATE[name]


def use_jit(why: str, warning: str | None) -> None:
    """Switch the pass to numba's JIT (imported here: only this path loads numba), saying
    ``warning`` if given."""
    from tmpc.runtime.collision import pass_kernel as jit
    if warning is not None:
        warnings.warn(f"collision pass: {warning}", stacklevel=3)
    KERNEL_STATE.update(candidates=jit.candidates, kinematics=jit.kinematics,
                        table_free=jit.table_free, why=why)


def load_kernel() -> str | None:
    """Load the compiled pass (:func:`pass_kernel`) and make one call on a batch of one state
    and no pair; returns why it is numba's JIT, not the ahead-of-time module (None when it is
    that module)."""
    pass_kernel()(*empty_pass_args())
    return KERNEL_STATE["why"]
