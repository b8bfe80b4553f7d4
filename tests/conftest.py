"""Shared fixtures. Plain helpers and paths are in tests/support.py.

The session-scoped fixtures hold expensive objects (a loaded world compiles once, and its jitted
kernels are shared by everything that uses the same world object): a test must only read them.
A test that changes its world or problem builds its own."""

from __future__ import annotations

import numpy as np
import pytest

from tests.support import CLUTTER, ROOT, TABLETOP


def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject's addopts) is one worker per core, except for benchmarks and
    ``-s`` runs: they run in this process, so their tables print and their ratios are not
    measured under a parallel suite's load."""
    marks = config.getoption("markexpr") or ""
    benchmarks = "bench" in marks and "not bench" not in marks
    if benchmarks or config.getoption("capture") == "no":
        return 0
    return None                     # xdist's own choice: the number of cores


@pytest.fixture
def tmp_cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.fixture(scope="session")
def aot_folder():
    """The user cache's folder of kernels built ahead of time (tmpc.compiler.aot), the collision
    pass built in it (as any run does; where the build fails, its recorded failure, and runs
    use numba's JIT as they would with the user cache). A test that gives a process a cache of
    its own, to compile an artifact cold, links its ``aot`` folder here: the pass's numba build
    (tens of seconds, tested in tests/runtime/test_aot.py) is not what it checks."""
    from tmpc.compiler import aot
    from tmpc.runtime.collision.kernel import PASS_KERNEL
    aot.obtain(PASS_KERNEL)
    PASS_KERNEL.path().parent.mkdir(parents=True, exist_ok=True)      # TMPC_AOT=0: none built
    return PASS_KERNEL.path().parent


@pytest.fixture(scope="session")
def tabletop_world():
    """examples/tabletop/tabletop.toml opened with its program (read only)."""
    from tmpc.compiler.artifact import open_world
    return open_world(TABLETOP)


@pytest.fixture(scope="session")
def clutter_world():
    """examples/clutter/clutter.toml opened with its program (read only)."""
    from tmpc.compiler.artifact import open_world
    return open_world(CLUTTER)


@pytest.fixture(scope="session")
def clutter_problem_1(clutter_world):
    """The bundled 1-stick clutter problem as a planner sees it, compiled and warmed up once for
    the session (read only: planners built on it keep their own state)."""
    from tmpc.runtime.problem import PlanningProblem
    problem = PlanningProblem(clutter_world)
    problem.warm_up(np.random.default_rng(0))
    return problem


@pytest.fixture(scope="session")
def blocks_d():
    """Blocks World D of the Lagriffoul suite (a PR2, two arms) as a planner sees it (read
    only: planners and task planners built on it keep their own state)."""
    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.problem import PlanningProblem
    return PlanningProblem(open_world(ROOT / "examples/lagriffoul/blocks-D/run.toml"))
