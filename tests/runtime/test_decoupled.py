"""OMPL inside tmpc (issue Q): the decoupled planner, `tmpc motion` with OMPL's planners and
tmpc's own, `--simplify ompl`, and OMPL loaded only where it is used.

Plans are checked by the independent validator; single motions by tmpc's batched motion
checker at the validator's resolution, their ends against the states asked for."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.support import ROOT, TABLETOP, run_tmpc
from tmpc.lang.diagnostics import InputError
from tmpc.runtime.planners import MOTION_PLANNERS, PLANNERS, check_motion_planner


@pytest.fixture(scope="module")
def tabletop_run(tabletop_world):
    """(problem, result) of a decoupled run on tabletop, seed 0 (the problem is reused by
    :func:`tmpc.runtime.solve.replan`)."""
    from tmpc.runtime.solve import plan_problem
    problem, result, _ = plan_problem(tabletop_world, "decoupled", seed=0, time_limit=60.0)
    return problem, result


def _validate(problem, result, name: str):
    from tmpc.lang.source import SourceFile
    from tmpc.runtime.plans import parse_plan, plan_document
    from tmpc.runtime.validate import validate_plan
    doc = plan_document(problem, result, planner=name, seed=0, input_path=str(TABLETOP),
                        setup_seconds=0.0)
    report = validate_plan(problem.world, parse_plan(SourceFile("<plan>", json.dumps(doc))))
    return doc, report


def test_decoupled_plan_validates_and_is_a_function_of_the_seed(tabletop_run):
    from tmpc.runtime.solve import replan
    problem, first = tabletop_run
    assert first.status == "solved"
    doc, report = _validate(problem, first, "decoupled")
    assert report.valid, report.text()
    assert len(doc["actions"]) == 4
    assert first.stats["motions"] >= 4 and first.stats["motion_planner"] == "ompl:RRTConnect"
    again, _ = replan(problem, "decoupled", seed=0, time_limit=60.0)
    assert [q.tolist() for q, _, _ in again.path] == [q.tolist() for q, _, _ in first.path]
    other, _ = replan(problem, "decoupled", seed=1, time_limit=60.0)
    assert other.status == "solved"
    assert [q.tolist() for q, _, _ in other.path] != [q.tolist() for q, _, _ in first.path]


@pytest.mark.parametrize("planner", ["decoupled", "optimal"])
def test_simplify_ompl_keeps_the_plan_valid_and_no_longer(tabletop_run, planner):
    from tmpc.runtime.solve import replan
    problem, _ = tabletop_run
    over = {"first_solution": True}
    plain, _ = replan(problem, planner, seed=2, time_limit=60.0, overrides=over)
    simple, _ = replan(problem, planner, seed=2, time_limit=60.0,
                       overrides=dict(over, simplify="ompl"))
    assert simple.status == "solved"
    _, report = _validate(problem, simple, planner)
    assert report.valid, report.text()
    s = simple.stats["simplify"]
    assert s["motions"] == len([a for _, _, a in simple.path if a is not None]) + 1
    assert s["length_after"] <= s["length_before"] + 1e-9
    # the same actions at the same configurations: only the motions between them change
    acts = [(a.name, q.tolist()) for q, _, a in simple.path if a is not None]
    if planner == "optimal":          # no internal shortcut to skip: the same plan underneath
        assert acts == [(a.name, q.tolist()) for q, _, a in plain.path if a is not None]


def test_simplify_ompl_falls_back_where_tmpc_rejects(tabletop_run, monkeypatch):
    """A simplified motion tmpc's checker rejects is replaced by the original."""
    from tmpc.runtime.planners.decoupled import MotionSpace, simplify_path
    problem, result = tabletop_run
    monkeypatch.setattr(MotionSpace, "path_valid", lambda self, Q, mode=None: False)
    path, stats = simplify_path(problem, result.path, seed=0)
    assert stats["simplified"] == 0
    assert [q.tolist() for q, _, _ in path] == [q.tolist() for q, _, _ in result.path]


def test_unknown_simplifier_and_motion_planner_are_diagnosed(tabletop_run):
    from tmpc.runtime.planners import make_planner
    problem, _ = tabletop_run
    with pytest.raises(InputError) as info:
        make_planner("optimal", problem, 0, {"simplify": "omp"})
    assert info.value.diagnostics[0].code == "E855"
    with pytest.raises(InputError) as info:
        make_planner("decoupled", problem, 0, {"motion_planner": "ompl:RRTconect"})
    d = info.value.diagnostics[0]
    assert d.code == "E850" and "`ompl:RRTConnect`" in d.hint


def test_every_listed_ompl_planner_exists_and_is_in_run_help():
    from ompl import geometric as og
    from tmpc.runtime.cli.main import build_parser
    assert "tmpc" in MOTION_PLANNERS and "decoupled" in PLANNERS
    for name in MOTION_PLANNERS:
        if name != "tmpc":
            assert hasattr(og, name.split(":")[1]), name
    assert check_motion_planner("ompl:RRTConnect") == "ompl:RRTConnect"
    helps = build_parser()._subparsers._group_actions[0].choices["run"].format_help()
    assert "ompl:BITstar" in " ".join(helps.split())


def _colliding_pair(problem, mode, seed: int):
    """Two collision-free random states whose straight motion collides (the first such of
    200 pairs drawn from ``seed``)."""
    Q = problem.uniform(np.random.default_rng(seed), 400)
    Q = Q[problem.valid_batch(mode, Q)]
    ok = problem.motions_valid(mode, Q[:-1:2], Q[1::2], 0.05)
    i = int(np.nonzero(~ok)[0][0])
    return Q[2 * i], Q[2 * i + 1]


@pytest.mark.parametrize("planner", ["ompl:RRTConnect", "ompl:KPIECE1", "tmpc"])
def test_one_motion_each_planner(tabletop_run, planner):
    """Random start and goal states whose straight motion collides: the planned path joins
    them exactly and every segment is collision-free by tmpc's checker."""
    from tmpc.runtime.planners import plan_motion
    problem, _ = tabletop_run
    mode = problem.initial
    q0, q1 = _colliding_pair(problem, mode, 11)
    res = plan_motion(problem, mode, q0, q1, planner, time_limit=20.0, seed=4)
    assert res.path is not None, res.status
    assert np.array_equal(res.path[0], q0) and np.array_equal(res.path[-1], q1)
    assert len(res.path) >= 3                       # the straight motion collides
    assert problem.motions_valid(mode, res.path[:-1], res.path[1:], 0.05, ends=True).all()
    again = plan_motion(problem, mode, q0, q1, planner, time_limit=20.0, seed=4)
    assert np.array_equal(again.path, res.path)


def _shortcut_one_batch(p, mode, Q, rng, rounds=32, tries=16, resolution=0.05):
    """The reference for :func:`~tmpc.runtime.planners.decoupled.lazyprm.shortcut`: the same
    draws, every new piece of every try checked in one batch."""
    from tmpc.runtime.planners.decoupled.lazyprm import points_along
    for _ in range(rounds):
        seg = np.array([p.cost(Q[n + 1:n + 2], Q[n])[0] for n in range(len(Q) - 1)])
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        T = np.sort(rng.uniform(0.0, cum[-1], (tries, 2)), axis=1)
        ia, A = points_along(p, Q, cum, seg, T[:, 0])
        ib, B = points_along(p, Q, cum, seg, T[:, 1])
        gain = (T[:, 1] - T[:, 0]) - np.array([p.cost(b[None], a)[0] for a, b in zip(A, B)])
        idx = np.nonzero((gain > 1e-9) & (ia < ib))[0]
        if len(Q) < 3:
            break
        if not len(idx):
            continue
        ok = p.motions_valid(mode, np.vstack([Q[ia[idx]], A[idx], B[idx]]),
                             np.vstack([A[idx], B[idx], Q[ib[idx] + 1]]), resolution,
                             ends=True).reshape(3, -1).all(axis=0)
        if ok.any():
            k = idx[np.nonzero(ok)[0][np.argmax(gain[idx][ok])]]
            Q = np.vstack([Q[:ia[k] + 1], A[k][None], B[k][None], Q[ib[k] + 1:]])
    return Q


def test_shortcuts_take_the_cut_a_one_batch_check_takes(tabletop_run):
    """tmpc's shortcuts check the cuts first and the pieces along the path only where a cut
    holds: on a jagged path (OMPL's RRT, twice) they take, round by round, the cuts that
    checking every piece at once takes, and every segment of the result is collision-free."""
    from tmpc.runtime.planners import plan_motion
    from tmpc.runtime.planners.decoupled.lazyprm import shortcut
    problem, _ = tabletop_run
    mode = problem.initial
    q0, q1 = _colliding_pair(problem, mode, 5)
    there = plan_motion(problem, mode, q0, q1, "ompl:RRT", 20.0, seed=3)
    back = plan_motion(problem, mode, q1, q0, "ompl:RRT", 20.0, seed=4)
    path = np.vstack([there.path, back.path[1:], there.path[1:]])
    for seed in range(3):
        got = shortcut(problem, mode, path, np.random.default_rng(seed), rounds=12)
        want = _shortcut_one_batch(problem, mode, path, np.random.default_rng(seed), rounds=12)
        assert np.array_equal(got, want)
        assert np.array_equal(got[0], path[0]) and np.array_equal(got[-1], path[-1])
        assert len(got) < len(path)
        assert problem.motions_valid(mode, got[:-1], got[1:], 0.05, ends=True).all()


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["ompl:RRTConnect", "tmpc"])
def test_tmpc_motion_cli_on_tabletop(tabletop_run, tmp_path, planner):
    problem, _ = tabletop_run
    r = run_tmpc("motion", TABLETOP, "--from", "start", "--to", "random", "--seed", "5",
                 "--planner", planner, "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    path = np.array(out["path"])
    assert out["planner"] == planner and out["states"] == len(path)
    assert np.allclose(path[0], problem.q0)
    assert problem.motions_valid(problem.initial, path[:-1], path[1:], 0.05, ends=True).all()
    assert out["length"] > 0 and out["seconds"] >= 0


@pytest.mark.slow
def test_tmpc_motion_cli_errors(tabletop_run, tmp_path):
    problem, _ = tabletop_run
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    hit = tmp_path / "hit.json"      # the arm folded into the table
    hit.write_text(json.dumps({"joints": {"panda_joint2": 1.7, "panda_joint4": -0.1}}))
    cases = [(["--from", "start", "--to", "random", "--planner", "ompl:rrtconnect"], "E850"),
             (["--from", "strat", "--to", "random"], "E852"),
             (["--from", str(bad), "--to", "start"], "E580"),
             (["--from", "start", "--to", str(hit)], "E853")]
    for args, code in cases:
        r = run_tmpc("motion", TABLETOP, *args)
        assert r.returncode == 1 and code in r.stderr, (args, r.stderr)
        assert "Traceback" not in r.stderr
    # a goal whose straight motion collides, with no time to plan around: exit 3, the reason
    seed = next(s for s in range(100) if not _straight_ok(problem, s))
    r = run_tmpc("motion", TABLETOP, "--from", "start", "--to", "random", "--seed", seed,
                 "--planner", "tmpc", "--time-limit", "1e-9")
    assert r.returncode == 3 and "no motion found" in r.stderr, r.stderr


def _straight_ok(problem, seed: int) -> bool:
    """Is the straight motion from the start to `tmpc motion --to random --seed S`'s goal
    (the first valid of 64 uniform draws) collision-free?"""
    Q = problem.uniform(np.random.default_rng(seed), 64)
    q1 = Q[np.nonzero(problem.valid_batch(problem.initial, Q))[0][0]]
    return bool(problem.motions_valid(problem.initial, problem.q0[None], q1[None], 0.05,
                                      ends=True)[0])


def test_check_help_and_the_language_server_import_no_ompl():
    code = """
import sys, io, contextlib
from tmpc.runtime.cli.main import build_parser, main
parser = build_parser()
for name in ("run", "motion", "bench"):
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            parser.parse_args([name, "--help"])
        except SystemExit:
            pass
with contextlib.redirect_stdout(io.StringIO()):
    main(["check", "examples/tabletop/domain.pddl", "examples/tabletop/problem.pddl"])
import tmpc.lang.lsp
assert "ompl" not in sys.modules, "ompl imported"
import tmpc.runtime.planners.decoupled as d
assert "ompl" not in sys.modules and d.MOTION_PLANNERS
print("ok")
"""
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr[-2000:]


def test_lazy_motions_follow_the_whole_chain_and_a_failed_motion_backtracks(tabletop_run):
    """With ``lazy_motions`` every step's transition configuration comes before the first
    motion; a motion that fails sends the search back to its step's next configuration, the
    motions before it kept; the plan validates. The eager planner (a motion per step) plans
    it too."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    problem, _ = tabletop_run
    planner = DecoupledPlanner(problem, seed=0, options=DecoupledOptions(lazy_motions=True))
    calls: list[str] = []
    failed: list[int] = []
    samples, motion = planner.transition_samples, planner.motion

    def sampling(*args):
        calls.append("sample")
        return samples(*args)

    def moving(mode, q0, q1, deadline, before=None, after=None):
        calls.append("motion")
        if calls.count("motion") == 2 and not failed:      # the second motion fails once
            failed.append(len(calls))
            return None
        return motion(mode, q0, q1, deadline, before, after)

    planner.transition_samples, planner.motion = sampling, moving
    result = planner.solve(60.0)
    assert result.status == "solved" and failed
    steps = len([a for _, _, a in result.path if a is not None])
    first = calls.index("motion")
    assert calls[:first] == ["sample"] * first and first >= steps
    # after the failure: the failed step's configurations, then motions from that step on
    # (the first motion is not planned again)
    assert calls.count("motion") == steps + 1
    _, report = _validate(problem, result, "decoupled")
    assert report.valid, report.text()
    eager = DecoupledPlanner(problem, seed=0)                 # the default: eager
    assert not eager.opt.lazy_motions
    plain = eager.solve(60.0)
    assert plain.status == "solved"
    _, report = _validate(problem, plain, "decoupled")
    assert report.valid, report.text()


def test_lazy_motions_come_from_the_manifest():
    """A manifest's ``[planner] lazy_motions = true`` (Blocks World E's) and ``lookahead =
    true`` reach the planner; without them the decoupled planner plans a motion at every step
    and takes its configurations nearest first."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledPlanner

    class World:
        config = type("Config", (), {"params": (("lazy_motions", True),
                                                ("lookahead", True), ("backjump", True))})()

    class Problem:
        world = World()

    opt = DecoupledPlanner.from_options(Problem(), 0, {}).opt
    assert opt.lazy_motions and opt.lookahead and opt.backjump
    Problem.world.config = type("Config", (), {"params": ()})()
    opt = DecoupledPlanner.from_options(Problem(), 0, {}).opt
    assert not opt.lazy_motions and not opt.lookahead and not opt.backjump


def test_the_motion_budget_comes_from_the_manifest_and_the_command_line_wins():
    """A manifest's ``[planner] motion_checks`` (Sort Clutter's 2,500) and ``motion_budget``
    (seconds) are each motion's budget; ``--motion-checks`` and ``--motion-budget`` override
    them; 4,000 checks and no seconds without either; 0 is E851."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledPlanner

    class World:
        config = type("Config", (), {"params": (("motion_budget", 1.0),
                                                ("motion_checks", 2500))})()

    class Problem:
        world = World()

    opt = DecoupledPlanner.from_options(Problem(), 0, {}).opt
    assert (opt.motion_budget, opt.motion_checks) == (1.0, 2500)
    over = {"motion_budget": 3.0, "motion_checks": 7}
    opt = DecoupledPlanner.from_options(Problem(), 0, over).opt
    assert (opt.motion_budget, opt.motion_checks) == (3.0, 7)
    opt = DecoupledPlanner.from_options(Problem(), 0, {"motion_budget": None,
                                                       "motion_checks": None}).opt
    assert (opt.motion_budget, opt.motion_checks) == (1.0, 2500)
    Problem.world.config = type("Config", (), {"params": ()})()
    opt = DecoupledPlanner.from_options(Problem(), 0, {}).opt
    assert (opt.motion_budget, opt.motion_checks) == (None, 4000)
    for bad in (("motion_budget", 0.0), ("motion_checks", 0)):
        Problem.world.config = type("Config", (), {"params": (bad,)})()
        with pytest.raises(InputError) as err:
            DecoupledPlanner.from_options(Problem(), 0, {})
        assert err.value.diagnostics[0].code == "E851"


def test_a_motion_budget_counts_checks_so_a_slow_machine_plans_the_same_motion(tabletop_run,
                                                                              monkeypatch):
    """An OMPL motion within ``checks`` of tmpc's checks (no seconds): the same path with the
    checker ten times slower (the machine loaded), and the budget kept to within one of
    OMPL's iterations; a budget too small to find it fails after its checks, not its time."""
    from tmpc.runtime.planners import plan_motion
    from tmpc.runtime.planners.decoupled.motion import ompl_space

    problem, _ = tabletop_run
    mode = problem.initial
    q0, q1 = _colliding_pair(problem, mode, 11)
    space = ompl_space(problem)
    before = space.checks
    res = plan_motion(problem, mode, q0, q1, "ompl:RRTConnect", np.inf, 4, space,
                      checks=4000)
    used = space.checks - before
    assert res.path is not None and 0 < used < 4000
    valid, motions = problem.valid_batch, problem.motions_valid

    def slow(f):
        def call(*a, **k):
            time.sleep(2e-3)
            return f(*a, **k)
        return call
    monkeypatch.setattr(problem, "valid_batch", slow(valid))
    monkeypatch.setattr(problem, "motions_valid", slow(motions))
    before = space.checks
    again = plan_motion(problem, mode, q0, q1, "ompl:RRTConnect", np.inf, 4, space,
                        checks=4000)
    assert again.seconds > res.seconds and space.checks - before == used
    assert np.array_equal(again.path, res.path)
    monkeypatch.undo()
    before = space.checks
    short = plan_motion(problem, mode, q0, q1, "ompl:RRTConnect", np.inf, 4, space,
                        checks=3)
    assert short.path is None and 3 <= space.checks - before < 3 + 40


def test_the_motion_range_comes_from_the_manifest_and_reaches_ompls_planner(tabletop_run,
                                                                             monkeypatch):
    """A manifest's ``[planner] motion_range`` is the longest edge OMPL's planner grows its
    trees by (``setRange``); 0, the default, leaves OMPL's own; a negative one is E851. The
    motion planned with it is valid."""
    import math

    from tmpc.runtime.planners.decoupled import space as space_module
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    problem, _ = tabletop_run

    class World:
        config = type("Config", (), {"params": (("motion_range", 0.3),)})()

    class Problem:
        world = World()

    assert DecoupledPlanner.from_options(Problem(), 0, {}).opt.motion_range == 0.3
    Problem.world.config = type("Config", (), {"params": ()})()
    assert DecoupledPlanner.from_options(Problem(), 0, {}).opt.motion_range == 0.0
    Problem.world.config = type("Config", (), {"params": (("motion_range", -1.0),)})()
    with pytest.raises(InputError) as err:
        DecoupledPlanner.from_options(Problem(), 0, {})
    assert err.value.diagnostics[0].code == "E851"

    ob, og, ou = space_module.ompl_modules()
    made: list = []

    class Recorded:
        def __getattr__(self, name):
            return getattr(og, name)

        def RRTConnect(self, si):
            made.append(og.RRTConnect(si))
            return made[-1]
    monkeypatch.setattr(space_module, "ompl_modules", lambda: (ob, Recorded(), ou))
    for value in (0.3, 0.0):
        planner = DecoupledPlanner(problem, 0, DecoupledOptions(motion_range=value))
        space = planner.motion_space()
        assert space.range == value
        steps = _plan_steps(planner)
        q = planner.transition_samples(problem.initial, steps[0][0], problem.q0, steps[0][1])[0]
        motion = planner.motion(problem.initial, problem.q0, q, math.inf)
        assert motion is not None and space.path_valid(motion, problem.initial)
        ranges = {round(ompl.getRange(), 6) for ompl in made}
        made.clear()
        # OMPL's own: a fifth of the space's extent
        assert ranges == {value or round(0.2 * space.si.getMaximumExtent(), 6)}


def test_lookahead_tries_first_what_the_next_step_on_the_object_can_follow(tabletop_run):
    """``lookahead``: a grasp's configurations are reordered by the placement that follows
    (projected in the mode after each), those after which it holds collision-free first;
    none is dropped, and the plan validates."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    from tmpc.runtime.problem import PROJECTION_BATCH
    problem, _ = tabletop_run
    planner = DecoupledPlanner(problem, seed=0, options=DecoupledOptions(lookahead=True))
    steps = _plan_steps(planner)
    grasp, tr = steps[0]
    todo = planner.transition_samples(problem.initial, grasp, problem.q0, tr,
                                      keep=PROJECTION_BATCH)
    assert len(todo) >= 3
    asked, real = [], problem.project_raw
    chosen = todo[-1]                           # only the last one can be followed

    def project(mode, action, starts, iterations=None):
        asked.append(action)
        Q, holds, d = real(mode, action, starts, iterations)
        return Q, holds & bool(np.allclose(starts[0], chosen)), d
    problem.project_raw = project
    try:
        order = planner.looking_ahead(steps, 0, problem.initial, todo)
    finally:
        del problem.project_raw
    assert asked == [steps[1][0]] * len(todo)   # the placement that follows, once each
    assert np.allclose(order[0], chosen)
    assert [list(x) for x in order[1:]] == [list(x) for x in todo[:-1]]   # nearest first
    # the real projections: a reordering, nothing dropped
    order = planner.looking_ahead(steps, 0, problem.initial, todo)
    assert sorted(map(tuple, order)) == sorted(map(tuple, todo))
    result = DecoupledPlanner(problem, seed=0,
                              options=DecoupledOptions(lookahead=True)).solve(60.0)
    assert result.status == "solved" and result.stats["lookahead_projections"] > 0
    _, report = _validate(problem, result, "decoupled")
    assert report.valid, report.text()


def _plan_steps(planner):
    import math
    assert planner.tasks.next_plan(math.inf)
    return [(tr.action, tr) for tr in planner.tasks.plan_transitions]


def test_backjumping_goes_back_to_the_culprit_past_the_steps_between(tabletop_run):
    """With ``backjump``, a step none of whose configurations exists sends the search back to
    the latest of its culprits (here said to be the first step), past the steps between,
    which are sampled afresh only under the culprit's next configuration; without culprits,
    or without ``backjump``, back to the step before."""
    import math

    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    problem, _ = tabletop_run

    def follow(options, blame):
        planner = DecoupledPlanner(problem, seed=0, options=options)
        steps = _plan_steps(planner)
        assert len(steps) == 4
        last = steps[3][0]
        calls: list[int] = []
        real = planner.transition_samples

        def sampling(mode, action, q, tr, keep=None):
            calls.append(next(i for i, (a, _) in enumerate(steps) if a is action))
            if action is last:                 # the second cube's placement never holds
                planner.collided_now = []
                return []
            return real(mode, action, q, tr, keep)

        planner.transition_samples = sampling
        planner.culprits = lambda steps, i, mode, moved, collided: blame if i == 3 else set()
        assert planner.follow(steps, math.inf) is None
        return planner, calls

    planner, calls = follow(DecoupledOptions(backjump=True), {0})
    # every configuration of the first step is followed to the failing placement once: the
    # second and third steps are sampled once under each, never for another of their own
    n = calls.count(1)
    assert calls[:4] == [0, 1, 2, 3] and calls.count(0) == 1 and n >= 2
    assert calls.count(2) == calls.count(3) == n and planner.counts["backjumps"] == n
    # no culprit: back to the step before, as without backjump
    nobody, calls_nobody = follow(DecoupledOptions(backjump=True), set())
    plain, calls_plain = follow(DecoupledOptions(), {0})
    assert calls_nobody == calls_plain and calls_plain.count(2) > calls_plain.count(1)
    assert nobody.counts["no_culprit"] >= 1 and "backjumps" not in plain.counts


def test_culprits_are_the_latest_steps_that_moved_what_a_step_depends_on(tabletop_run):
    """A step depends on the latest earlier step that moved each movable object its action
    names (none: the object stands where it started); the goal's step on every object."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledPlanner
    problem, _ = tabletop_run
    planner = DecoupledPlanner(problem, seed=0)
    steps = _plan_steps(planner)
    movable = planner.tasks.task_planner().movable
    x, y = ({a.lower() for a in steps[k][0].args} & movable for k in (0, 3))
    (x,), (y,) = x, y
    assert x != y
    moved = [frozenset(), frozenset({x}), frozenset({x}), frozenset({y})]
    mode = problem.initial
    assert planner.culprits(steps, 3, mode, moved, []) == {2}
    assert planner.culprits(steps, 2, mode, moved, []) == set()
    assert planner.culprits(steps, 1, mode, moved, []) == {0}
    goal = steps + [(None, None)]
    assert planner.culprits(goal, 4, mode, moved + [frozenset({y})], []) == {1, 3}


def _sample_steps(planner, action, tr, q, idle, blocked=(),
                  none_valid=False) -> tuple[list, list]:
    """``planner.transition_samples`` of ``action`` from ``q`` in the initial mode, the
    other arm (``idle``) "colliding" at each configuration of ``blocked`` (every
    configuration, with ``none_valid``): (its configurations, the projections' starts)."""
    p = planner.p
    starts = []
    real_project, real_valid = p.project_raw, p.valid_batch

    def project(mode, action, S, iterations=None):
        starts.append(np.array(S))
        return real_project(mode, action, S, iterations)

    def valid(mode, Q):
        out = np.zeros(len(Q), bool) if none_valid else real_valid(mode, Q)
        for at in blocked:
            out &= ~np.all(Q[:, idle] == at[idle], axis=1)
        return out
    p.project_raw, p.valid_batch = project, valid
    try:
        return planner.transition_samples(p.initial, action, q, tr), starts
    finally:
        del p.project_raw, p.valid_batch


def test_a_step_puts_the_arm_its_action_does_not_use_back_where_it_started(blocks_d):
    """DecoupledPlanner.transition_samples with ``park_idle`` (a manifest's; off by default):
    after an action's first projection, its starts put the joints it never moves and that no
    joint it moves carries (a PR2's other arm) where the run started them; its own wrist
    roll, free about a top grasp's axis, is still sampled. Where the other arm there
    collides, the wider rounds try it where it is, then at their starts' values: the
    configurations returned still hold the precondition."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner

    p = blocks_d
    gp, names = p.ground, p.model.q_names
    off = DecoupledPlanner(p, seed=0)                   # off by default: a manifest's
    action = gp.find_action("pickup", "a", "table", "l_gripper_tool_frame")
    off.transition_samples(p.initial, action, p.q0,
                           off.tasks.transition(gp.init, action, gp.apply(gp.init, action)))
    assert not off.idle
    planner = DecoupledPlanner(p, seed=0, options=DecoupledOptions(sample_rounds=8,
                                                                   park_idle=True))
    for hand, other, block, support in (("l", "r", "a", "table"), ("r", "l", "c", "red-tray")):
        action = gp.find_action("pickup", block, support, f"{hand}_gripper_tool_frame")
        tr = planner.tasks.transition(gp.init, action, gp.apply(gp.init, action))
        planner.transition_samples(p.initial, action, p.q0, tr)
        idle = planner.idle[action.id]
        assert {names[j] for j in np.flatnonzero(idle)} == \
            {n for n in names if n.startswith(f"{other}_")}
        # the other arm elsewhere than where it started, collision-free
        Q = np.repeat(p.q0[None], 64, axis=0)
        Q[:, idle] = p.uniform(np.random.default_rng(1), 64)[:, idle]
        q = Q[np.flatnonzero(p.valid_batch(p.initial, Q))[0]]
        _, starts = _sample_steps(planner, action, tr, q, idle)
        assert all(np.all(S[:, idle] == p.q0[idle]) for S in starts)
        wrist = names.index(f"{hand}_wrist_roll_joint")
        assert len(set(starts[0][:, wrist])) > 1
        # back where it started collides: where it is
        out, starts = _sample_steps(planner, action, tr, q, idle, [p.q0])
        assert len(starts) > 1 and out and all(np.all(x[idle] == q[idle]) for x in out)
        assert all(p.holds(p.initial, action, x) for x in out)
        # ... and so does where it is: the starts' values
        out, _ = _sample_steps(planner, action, tr, q, idle, [p.q0, q])
        assert out and all(np.any(x[idle] != q[idle]) and np.any(x[idle] != p.q0[idle])
                           for x in out)
        assert all(p.holds(p.initial, action, x) for x in out)


def test_seed_starts_come_from_the_same_arms_valid_configurations(blocks_d):
    """DecoupledPlanner.transition_samples with ``seed_starts`` (a manifest's; off by
    default): in the rounds after a step's first (which found no valid configuration), the
    last ``seed_starts`` of the starts are valid configurations found
    before by actions that move the same joints (the same arm's), perturbed by SEED_NOISE of
    each joint's range; the other arm's actions draw on a pool of their own. Seeded, a grasp
    projects to valid configurations several times as often: a top grasp holds about its
    axis at any angle, but the open gripper clears a block only face on."""
    from tmpc.runtime.planners.decoupled.planner import (SEED_NOISE, SEED_POOL,
                                                         DecoupledOptions, DecoupledPlanner)

    p = blocks_d
    gp = p.ground
    span = np.asarray(p.upper) - np.asarray(p.lower)

    def step(planner, name, *args):
        action = gp.find_action(name, *args)
        return action, planner.tasks.transition(gp.init, action, gp.apply(gp.init, action))

    def farthest_from_pool(planner, starts):
        pool = next(iter(planner.pool.values()))
        return [min(np.abs(p.difference(s, x) / span).max() for x in pool) for s in starts]

    def valid_yield(planner, action, rounds=12):
        found = 0
        for _ in range(rounds):
            starts = planner.starts_around(p.q0, planner.rng)
            planner.seeded(action.id, starts)
            Qp, holds, _ = p.project_raw(p.initial, action, starts,
                                         iterations=planner.opt.projection_iterations)
            found += int(p.valid_batch(p.initial, Qp[holds]).sum()) if holds.any() else 0
        return found

    seeded = DecoupledPlanner(p, seed=0, options=DecoupledOptions(seed_starts=8,
                                                                  sample_rounds=8))
    plain = DecoupledPlanner(p, seed=0, options=DecoupledOptions(sample_rounds=8))
    unstack, tr = step(seeded, "unstack", "d", "b", "l_gripper_tool_frame")
    for _ in range(10):
        seeded.transition_samples(p.initial, unstack, p.q0, tr)
        plain.transition_samples(p.initial, unstack, p.q0, tr)
        if seeded.pool:
            break
    assert not plain.pool
    (key, pool), = seeded.pool.items()
    assert 0 < len(pool) <= SEED_POOL and all(p.holds(p.initial, unstack, x) for x in pool)
    assert key == seeded.moves[unstack.id].tobytes()
    # another action of the same arm: its last 8 starts are the pool's, perturbed
    pickup, tr = step(seeded, "pickup", "d", "table", "l_gripper_tool_frame")
    for planner in (seeded, plain):
        planner.transition_samples(p.initial, pickup, p.q0, tr)
    assert seeded.moves[pickup.id].tobytes() == key
    # ... in the rounds after a first that found nothing valid (here: nothing is)
    for planner in (seeded, plain):
        out, starts = _sample_steps(planner, pickup, tr, p.q0, np.zeros(len(p.q0), bool),
                                    none_valid=True)
        assert out == []
        assert len(starts) == 8
        assert min(farthest_from_pool(seeded, starts[0][-8:])) > 6 * SEED_NOISE
        for S in starts[1:]:
            far = farthest_from_pool(seeded, S[-8:])
            assert max(far) < 6 * SEED_NOISE if planner is seeded else min(far) > 6 * SEED_NOISE
    # the other arm: a pool of its own
    other, tr = step(seeded, "pickup", "c", "table", "r_gripper_tool_frame")
    seeded.transition_samples(p.initial, other, p.q0, tr)
    assert seeded.moves[other.id].tobytes() != key
    # seeded, valid grasps come several times as often
    with_seeds, without = valid_yield(seeded, pickup), valid_yield(plain, pickup)
    assert with_seeds > 2 * without + 3, (with_seeds, without)


def test_seed_starts_and_projection_iterations_come_from_the_manifest():
    """A manifest's ``[planner] seed_starts`` and ``projection_iterations`` reach the
    decoupled planner; seed_starts above 8 (half a round's starts) is E851."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledPlanner

    class Problem:
        world = type("World", (), {"config": type("Config", (), {
            "params": (("seed_starts", 8), ("projection_iterations", 45))})()})()

    opt = DecoupledPlanner.from_options(Problem(), 0, {}).opt
    assert (opt.seed_starts, opt.projection_iterations) == (8, 45)
    Problem.world.config.params = (("seed_starts", 9),)
    with pytest.raises(InputError) as err:
        DecoupledPlanner.from_options(Problem(), 0, {})
    assert err.value.diagnostics[0].code == "E851"


def test_park_first_moves_the_idle_arm_alone_then_the_rest(blocks_d):
    """DecoupledPlanner.motion with ``park_first`` (and ``park_idle``; a manifest's, off by
    default): a motion whose end puts the arm its action does not use back where the run
    started it plans that arm's motion first, alone (the configuration between: the start
    with that arm at its end's values), then the rest. The path is free and passes through
    that configuration; without the option, or when that configuration collides, there is
    none. With ``retreat_sideways`` the end's retreat moves the action's own hand."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner

    p = blocks_d
    gp, mode = p.ground, p.initial
    opts = DecoupledOptions(park_idle=True, park_first=True, retreat_sideways=True)
    planner = DecoupledPlanner(p, seed=0, options=opts)
    planner.motion_space()
    action = gp.find_action("pickup", "a", "table", "l_gripper_tool_frame")
    tr = planner.tasks.transition(gp.init, action, gp.apply(gp.init, action))
    planner.transition_samples(mode, action, p.q0, tr)       # learns the idle arm
    b = planner.transition_samples(mode, action, p.q0, tr)[0]
    idle = planner.idle[action.id]
    assert np.all(b[idle] == p.q0[idle])
    # the right arm elsewhere, collision-free: the motion's start
    Q = np.repeat(p.q0[None], 64, axis=0)
    Q[:, idle] = p.uniform(np.random.default_rng(3), 64)[:, idle]
    a = Q[np.flatnonzero(p.valid_batch(mode, Q))[0]]
    mid = planner.parked_between(mode, a, b, action)
    assert mid is not None
    assert np.all(mid[idle] == b[idle]) and np.all(mid[~idle] == a[~idle])
    for other in (DecoupledPlanner(p, seed=0, options=DecoupledOptions(park_idle=True)),
                  DecoupledPlanner(p, seed=0, options=DecoupledOptions(park_first=True))):
        other.idle = planner.idle
        assert other.parked_between(mode, a, b, action) is None
    assert planner.parked_between(mode, a, b, None) is None
    # that configuration colliding: none
    p.valid_batch = lambda m, X: np.zeros(len(X), bool)
    try:
        assert planner.parked_between(mode, a, b, action) is None
    finally:
        del p.valid_batch
    calls = []
    real_plan = planner.plan

    def plan(mode, x, y, budget, seed, fixed=None):     # budget: one Budget, shared
        calls.append((x, y, real_plan(mode, x, y, budget, seed, fixed)))
        return calls[-1][2]
    planner.plan = plan
    path = planner.motion(mode, a, b, time.perf_counter() + 30, None, action)
    assert path is not None and planner.counts.get("parked_first") == 1
    assert np.allclose(path[0], a) and np.allclose(path[-1], b)
    assert p.motions_valid(mode, path[:-1], path[1:], 0.05, ends=True).all()
    # first the right arm alone, to where it started; then the left arm and the torso
    (x0, y0, first), (x1, _, rest) = calls
    assert np.all(y0[idle] == b[idle]) and np.all(y0[~idle] == x0[~idle])
    assert np.all(first[:, ~idle] == x0[~idle]) and np.all(x1 == y0)
    assert np.allclose(rest[:, idle], b[idle]) and not np.allclose(x0[idle], b[idle])
    # the end's retreat is the left hand's: after the planner's path, the right arm stays
    # and the left hand moves
    tail = path[next(i for i in range(len(path) - 1, -1, -1)
                     if np.allclose(path[i], rest[-1])):]
    assert len(tail) > 1 and np.allclose(tail[:, idle], b[idle])
    hand = p.model.frames.index("l_gripper_tool_frame")
    ends = p.frames_of(tail[[0, -1]])
    assert np.linalg.norm(ends[0].p[hand] - ends[1].p[hand]) > 1e-3


def test_spread_placements_tries_the_roomiest_release_first(blocks_d):
    """With ``spread_placements`` (a manifest's, off by default) a release's configurations
    come the roomiest first (the released block's sideways distance to the blocks beside it;
    the table it stands on left out), the aimed starts move the block the way its room grows,
    and moving a block towards another shrinks its room."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    from tmpc.runtime.planners.spread import AIM, GRAIN
    from tmpc.runtime.problem import Mode

    p = blocks_d
    gp = p.ground
    assert DecoupledPlanner(p, seed=0).room is None
    planner = DecoupledPlanner(p, seed=0, options=DecoupledOptions(spread_placements=True))
    room = planner.room
    pick = gp.find_action("pickup", "a", "table", "l_gripper_tool_frame")
    sym = gp.apply(gp.init, pick)
    q = planner.transition_samples(p.initial, pick, p.q0,
                                   planner.tasks.transition(gp.init, pick, sym))[0]
    held = p.successor_mode(p.initial, pick, q, 1)
    put = gp.find_action("putdown", "a", "table", "l_gripper_tool_frame")
    assert room.released(p.initial, pick) == [] and room.released(held, put) == ["a"]
    tr = planner.tasks.transition(held.sym, put, gp.apply(held.sym, put))
    out = planner.transition_samples(held, put, q, tr)
    assert len(out) >= 2
    rooms = room.rooms(held, put, np.array(out))
    assert np.all(np.diff(np.floor(rooms / GRAIN)) <= 0)
    # the table under the block is no neighbour; the other blocks are
    T = room.poses(held, "a", np.array(out[:1]))

    def alone(*names):
        return Mode(0, held.sym, {k: held.poses[k] for k in names}, {})

    assert room.room_at(alone("table"), "a", T) is None
    beside = {k: room.room_at(alone("table", k), "a", T) for k in held.poses if k != "table"}
    near = min((k for k, r in beside.items() if r is not None), key=lambda k: beside[k][0])
    toward = T.copy()
    toward[0, :2, 3] += 0.3 * (held.poses[near][:2, 3] - T[0, :2, 3])
    assert room.room_at(held, "a", toward)[0] < room.room_at(held, "a", T)[0]
    # aimed starts: the block about AIM further, where it has more room
    A = room.aimed(held, put, np.array(out[:4]))
    TA = room.poses(held, "a", A)
    T4 = room.poses(held, "a", np.array(out[:4]))
    moved = np.linalg.norm(TA[:, :2, 3] - T4[:, :2, 3], axis=1)
    assert np.all(np.abs(moved - AIM) < 0.5 * AIM)
    assert np.all(room.room_at(held, "a", TA) > room.room_at(held, "a", T4))
    # the aimed configurations are added unless ``aim_placements`` is false
    for aim in (True, False):
        other = DecoupledPlanner(p, seed=0, options=DecoupledOptions(spread_placements=True,
                                                                     aim_placements=aim))
        calls = []
        real = other.room.around
        other.room.around = lambda *a, real=real: calls.append(a) or real(*a)
        other.transition_samples(held, put, q, tr)
        assert bool(calls) is aim


def test_a_step_out_of_reach_with_no_culprit_ends_the_plan(tabletop_run):
    """With ``give_up_missed`` (and ``backjump``), a step whose configurations are exhausted,
    with no culprit, whose transition never held and came no closer than a real miss, is
    sampled again until it failed RULE_FAILURES times, and then the plan ends: no earlier
    step's other configurations can bring it within reach. Without the option, or when the
    attempts came close, the search goes back to the step before."""
    import math

    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    from tmpc.runtime.planners.optimal.tasks import MISS, RULE_FAILURES
    problem, _ = tabletop_run

    def follow(options, distance):
        planner = DecoupledPlanner(problem, seed=0, options=options)
        steps = _plan_steps(planner)
        last = steps[3][0]
        calls: list[int] = []
        real = planner.transition_samples

        def sampling(mode, action, q, tr, keep=None):
            calls.append(next(i for i, (a, _) in enumerate(steps) if a is action))
            if action is last:                 # 48 attempts a visit, none held
                for _ in range(48):
                    tr.record_failure(mode, q, False, distance)
                planner.collided_now = []
                return []
            return real(mode, action, q, tr, keep)

        planner.transition_samples = sampling
        planner.culprits = lambda steps, i, mode, moved, collided: set()
        assert planner.follow(steps, math.inf) is None
        return planner, calls, steps[3][1]

    far = 5 * MISS
    planner, calls, tr = follow(DecoupledOptions(backjump=True, give_up_missed=True), far)
    assert calls == [0, 1, 2, 3, 3] and tr.failures == RULE_FAILURES
    assert planner.counts["missed_ends"] == 1 and tr.missed
    # without the option: back to the step before, each of its configurations again
    _, plain, _ = follow(DecoupledOptions(backjump=True), far)
    assert plain.count(2) > 1 and plain.count(3) > 2
    # close attempts are no miss: more configurations of the steps before may get there
    near, calls_near, tr_near = follow(DecoupledOptions(backjump=True, give_up_missed=True),
                                       MISS / 2)
    assert not tr_near.missed and calls_near == plain and "missed_ends" not in near.counts


def _grasp_action(p, hand: str, x: str):
    """A ground action of ``p`` whose only positive geometric literal is the grasp of ``x``
    by ``hand``."""
    for a in p.ground.actions:
        geo = [lit for lit in a.pre_geometric if lit.positive]
        if len(geo) == 1 and geo[0].predicate == "grasp" and \
                [s.lower() for s in geo[0].args] == [hand, x]:
            return a, geo[0]
    raise AssertionError(f"no grasp of {x} by {hand}")


def test_a_grasp_out_of_reach_probes_the_same_grasp_of_the_objects_not_moved(blocks_d):
    """With ``probe_reach``, a grasp that never held and missed (the right arm and `d`, on
    the left of Blocks World D's PR2) has the same grasp of each other block probed where it
    stands: a miss there too rules it out until the block moves (the greedy task planner's
    rule). Checked against 400 projections per block: ruled out are exactly the blocks the
    right arm misses from 400 starts (`b`, under `d`), not those it reaches (`a`, `c`);
    blocks the plan moved are not probed."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    from tmpc.runtime.planners.optimal.tasks import MISS, RULE_FAILURES
    p, r = blocks_d, "r_gripper_tool_frame"

    def missed(x: str) -> bool:
        action, _ = _grasp_action(p, r, x)
        _, holds, dist = p.project_raw(p.initial, action,
                                       p.uniform(np.random.default_rng(5), 400))
        return not holds.any() and dist.min() >= MISS

    def probe(prefix):
        planner = DecoupledPlanner(p, seed=0, options=DecoupledOptions(probe_reach=True))
        tasks = planner.tasks
        action, lit = _grasp_action(p, r, "d")
        tr = tasks.transition(p.ground.init, action, p.ground.apply(p.ground.init, action))
        Q, holds, dist = p.project_raw(p.initial, action,
                                       p.uniform(np.random.default_rng(0), RULE_FAILURES))
        assert not holds.any() and dist.min() >= MISS     # the right arm misses `d`
        for q, d in zip(Q, dist):
            tr.record_failure(p.initial, q, False, float(d))
        assert tr.missed
        tasks.probe_alike(prefix, tr, lit)
        rules = tasks.task_planner().greedy.rules
        return {x for x in "abc" if rules.get(("grasp", (r, x), True))}, planner.counts

    ruled, counts = probe([])
    assert ruled == {x for x in "abc" if missed(x)} == {"b"}
    assert counts["probes"] == 3 and counts["probe_rules"] == 1
    # `a` moved by the plan so far: not probed (where it stands now is another question)
    move_a = p.ground.find_action("pickup", "a", "blue-tray", "l_gripper_tool_frame")
    ruled, counts = probe([move_a])
    assert ruled == {"b"} and counts["probes"] == 2


def test_a_failed_motion_of_a_whole_chain_is_planned_again_on_a_larger_budget(tabletop_run):
    """With ``lazy_motions`` and ``chain_retry``, a motion of a chain whose transitions all
    hold that fails is planned once more, on ``chain_retry`` times the motion budget (its
    checks), before the search backtracks; the plan validates. Without it (1, the default)
    the chain is cut there (the lazy-motions test above)."""
    from tmpc.runtime.planners.decoupled.planner import DecoupledOptions, DecoupledPlanner
    problem, _ = tabletop_run
    opts = DecoupledOptions(lazy_motions=True, chain_retry=4.0)
    planner = DecoupledPlanner(problem, seed=0, options=opts)
    scales: list[float] = []
    checks: list[int] = []
    motion, plan = planner.motion, planner.plan

    def moving(mode, q0, q1, deadline, before=None, after=None, scale=1.0):
        scales.append(scale)
        if len(scales) == 2:                  # the second motion fails on its own budget
            return None
        return motion(mode, q0, q1, deadline, before, after, scale)

    def planning(mode, a, b, budget, seed, fixed=None):
        checks.append(budget.checks_left())
        return plan(mode, a, b, budget, seed, fixed)

    planner.motion, planner.plan = moving, planning
    result = planner.solve(60.0)
    assert result.status == "solved" and planner.counts["chain_retries"] == 1
    steps = len([a for _, _, a in result.path if a is not None])
    assert scales == [1.0, 1.0, 4.0] + [1.0] * (steps - 2)
    # the retry's motion plans had four times the checks of the others
    assert max(checks) > 3 * opts.motion_checks >= 3 * min(checks)
    _, report = _validate(problem, result, "decoupled")
    assert report.valid, report.text()
    assert DecoupledOptions().chain_retry == 1.0
