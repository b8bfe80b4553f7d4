"""A planner from a test distribution, registered under the entry point group ``tmpc.planners``:
it joins ``PLANNERS`` (so ``--planner`` lists it), plans through the API and its plan validates."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import tmpc
from tests.support import TABLETOP
from tmpc.runtime.planners import PLANNERS, load_entry_points

PLANNER_MODULE = '''
"""A third-party planner: the optimal planner, through the public Planner protocol."""
from tmpc.runtime.planners import make_planner


class Wrapped:
    def __init__(self, problem, seed, overrides):
        self.inner = make_planner("optimal", problem, seed, dict(overrides, first_solution=True))

    def warm_up_calls(self):
        return self.inner.warm_up_calls()

    def solve(self, time_limit, progress=None):
        return self.inner.solve(time_limit, progress)
'''


@pytest.fixture(scope="module")
def distribution(tmp_path_factory):
    root = tmp_path_factory.mktemp("site")
    (root / "thirdparty_planner.py").write_text(PLANNER_MODULE)
    info = root / "thirdparty_planner-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: thirdparty-planner\n"
                                   "Version: 1.0\n")
    (info / "entry_points.txt").write_text("[tmpc.planners]\nthirdparty = "
                                           "thirdparty_planner:Wrapped\n")
    sys.path.insert(0, str(root))
    try:
        assert load_entry_points() == ["thirdparty"]
        yield root
    finally:
        sys.path.remove(str(root))
        PLANNERS.pop("thirdparty", None)
        sys.modules.pop("thirdparty_planner", None)


def test_entry_point_planner_plans_and_validates(distribution):
    assert "thirdparty-planner" in PLANNERS["thirdparty"].summary
    world = tmpc.load(TABLETOP)
    plan = world.plan(planner="thirdparty", seed=0, time_limit=60.0)
    assert plan.solved and len(plan.actions) == 4
    assert world.validate(plan).valid
    import thirdparty_planner
    assert isinstance(thirdparty_planner.Wrapped.__new__(thirdparty_planner.Wrapped),
                      tmpc.Planner)


def test_entry_point_planner_is_a_planner_choice(distribution):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(distribution),
                                                         os.environ.get("PYTHONPATH", "")]))
    out = subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", "run", "--help"],
                         capture_output=True, text=True, env=env, check=True).stdout
    assert "thirdparty" in out
