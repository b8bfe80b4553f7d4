"""Kernels built ahead of time (tmpc.compiler.aot): a warm run loads the collision pass without
numba; a build that fails or a damaged module falls back to numba's JIT with the reason, and
never a traceback."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.support import CLUTTER


@pytest.fixture
def kernel(tmp_path, monkeypatch):
    """:mod:`tmpc.compiler.aot` with a private cache folder."""
    from tmpc.compiler import aot
    monkeypatch.setenv("TMPC_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("TMPC_AOT", raising=False)
    return aot


def test_a_build_that_fails_is_recorded_and_said_once(kernel):
    aot = kernel
    bad = aot.Kernel("tmpc.runtime.collision.pass_kernel", (("candidates", "i8(f8[:]"),))  # syntax
    module, why = aot.obtain(bad)
    assert module is None and why.startswith("the ahead-of-time build failed:"), why
    assert bad.failed_path().exists() and not bad.path().exists()
    module, again = aot.obtain(bad)            # not built again: the recorded failure
    assert module is None and again.startswith("the ahead-of-time build failed before:")
    assert why.split(": ", 1)[1] in again
    assert not list(bad.path().parent.glob(".build-*"))      # no half-built folder left


def test_a_damaged_module_is_removed_and_the_jit_used(kernel, monkeypatch):
    aot = kernel
    from tmpc.runtime.collision import kernel as kernel_loader
    k = kernel_loader.PASS_KERNEL
    k.path().parent.mkdir(parents=True)
    k.path().write_bytes(b"\x7fELF not really")
    module, why = aot.obtain(k)
    assert module is None and "did not load" in why and not k.path().exists()
    monkeypatch.setattr(kernel_loader, "KERNEL_STATE",
                        {"candidates": None, "kinematics": None, "table_free": None,
                         "why": None})
    monkeypatch.setattr(aot, "obtain", lambda kernel: (None, why))
    with pytest.warns(UserWarning, match="using numba's JIT"):
        fn = kernel_loader.pass_kernel()
    from tmpc.runtime.collision import pass_kernel as jit
    assert fn is jit.candidates and kernel_loader.pass_kernel("kinematics") is jit.kinematics
    assert kernel_loader.pass_kernel("table_free") is jit.table_free


def test_reference_counting_is_part_of_a_build_s_name(kernel):
    """A module built without numba's reference counting is another module (the collision
    pass is one: its scratch arrays come from the caller)."""
    from tmpc.runtime.collision import kernel as kernel_loader
    k = kernel_loader.PASS_KERNEL
    assert not k.nrt
    counted = kernel.Kernel(k.module, k.exports)
    assert counted.nrt and counted.name() != k.name() and counted.path() != k.path()


def test_aot_off_uses_the_jit(kernel, monkeypatch):
    monkeypatch.setenv("TMPC_AOT", "0")
    assert kernel.obtain(kernel.Kernel("x", (("y", "z"),))) == (None, "TMPC_AOT=0")


def test_a_warm_run_plans_without_numba(tmp_path):
    """The second `tmpc run` of the bundled example loads the collision pass built ahead of
    time: numba (and LLVM) are not in the process, and `-v` says how the pass runs."""
    from tmpc.runtime.cli.main import main
    # the first run (in this process) fills the user cache: the run's artifact, the pass's module
    assert main(["run", str(CLUTTER), "-o", str(tmp_path / "first.json"), "-q"]) == 0
    code = ("import sys, json\n"
            "from tmpc.runtime.cli.main import main\n"
            f"rc = main(['run', {str(CLUTTER)!r}, '-o', {str(tmp_path / 'p.json')!r}, '-v'])\n"
            "print(json.dumps([rc, 'numba' in sys.modules, 'llvmlite' in sys.modules]))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=600)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == [0, False, False], out.stderr
    assert "collision pass: built ahead of time" in out.stderr


def test_a_call_the_built_module_refuses_goes_to_the_jit(monkeypatch):
    """Should the pass ever hand the module built ahead of time an argument of another type,
    the call (and every later one) goes to numba's JIT of the same source, with a warning,
    and the answer is the JIT's: not a traceback in the middle of planning."""

    from tmpc.runtime.collision import pass_kernel as jit
    from tmpc.runtime.collision import kernel as kernel_loader

    def picky(*args):
        raise TypeError("No matching definition for argument type(s) array(int32, 1d, C)")

    monkeypatch.setattr(kernel_loader, "KERNEL_STATE",
                        {"candidates": picky, "kinematics": picky, "table_free": picky,
                         "why": None})
    with pytest.warns(UserWarning, match="refused a call"):
        kernel = kernel_loader.fall_back(TypeError("int32"))
    assert kernel is jit.candidates and kernel_loader.pass_kernel() is jit.candidates
    assert kernel_loader.pass_kernel("kinematics") is jit.kinematics       # both switch
    assert kernel(*kernel_loader.empty_pass_args()) == (0, 0, 0)
    with pytest.raises(TypeError):             # the JIT refusing too is a real error
        kernel_loader.fall_back(TypeError("again"))


def test_the_collision_pass_builds_and_loads_from_an_empty_cache(kernel):
    """The pass kernel built in a fresh cache folder loads (its build once linked numba's
    reference counting by mistake, and every run fell back to the JIT with a warning)."""
    from tmpc.runtime.collision.kernel import PASS_KERNEL
    module, why = kernel.obtain(PASS_KERNEL)
    assert why is None and module is not None, why
    assert hasattr(module, "candidates") and hasattr(module, "kinematics")
