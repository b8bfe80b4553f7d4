"""`tmpc repair` (thesis ch. 3): templates against their DSL predicates and CPZs, the error and
its gradient, the edit search against brute force, the store (locking, resume after SIGKILL),
write-back, recorded observations and the CLI's errors."""

from __future__ import annotations

import itertools
import json
import math
import os
import signal
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.support import EXAMPLES, tmpc_here
from tmpc.runtime.repair import (
    LoopConfig,
    RepairWorld,
    Sampled,
    SimController,
    Store,
    parse_truth,
    rewrite,
    run_loop,
    target,
)
from tmpc.runtime.repair.model import TEMPLATES, Features, Formula, Instance, Literal, error
from tmpc.runtime.repair.search import Problem, optimise, search

EXP1 = EXAMPLES / "repair" / "exp1.toml"


@pytest.fixture(scope="module")
def rw():
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.compile import compile_world
    world = open_world(EXP1)
    compiled = compile_world(world)
    t = target(world.program, "pick", lambda n: compiled.model.frame(n) is not None)
    return RepairWorld(world, compiled, t)


def _truth(rw, text):
    return parse_truth(text, rw.target, rw.scope)


# ---- templates -----------------------------------------------------------------------------

def test_the_target_reads_the_model_and_lists_the_instances(rw):
    t = rw.target
    assert t.ground == "(pick panda_hand_tcp cube)"
    assert t.start.text() == "(dist ?c ?g 0.5)"
    names = {i.text() for i in t.instances}
    assert {"(dist ?c ?g)", "(roll-aligned ?c ?g)", "(pitch-aligned ?c ?g)",
            "(yaw-aligned ?c ?g)", "(empty ?g)", "(holding ?g ?c)"} <= names
    # the manipulator is the robot frame: no template with the cube as the manipulator
    assert "(dist ?g ?c)" not in names


def test_sampled_states_realise_their_coordinates_through_the_dsl_helpers(rw):
    from tmpc.runtime.repair.loop import feats_of_coords
    rng = np.random.default_rng(3)
    for _ in range(5):
        coords = rw.naive_coords(rng)
        state = rw.state(coords, rng)
        feats = rw.features(state)
        c = coords[("?c", "?g")]
        assert np.allclose(feats["(dist ?c ?g)"], c["offset"], atol=1e-9)
        for name in ("roll", "pitch", "yaw"):
            got = feats[f"({name}-aligned ?c ?g)"][0]
            assert math.isclose(got, c[f"relative-{name}"], abs_tol=1e-9), name
        direct = feats_of_coords(rw, [coords])
        for inst in rw.cont:
            assert math.isclose(direct.t[inst][0], TEMPLATES[inst.name].feature(
                np.array([feats[inst.text()]]))[0], abs_tol=1e-9)


@pytest.mark.parametrize("name,theta", [("dist", 0.3), ("roll-aligned", 0.4),
                                        ("pitch-aligned", 0.2), ("yaw-aligned", 0.7)])
def test_a_templates_cpz_and_closed_form_are_the_dsl_predicates_distance(rw, name, theta):
    from tmpc.compiler.cpz import distance
    from tmpc.compiler.state import state_from_json, world_poses
    from tmpc.lang.reader_formulas import parse_expr
    from tmpc.runtime.evaluate import Evaluator, Obj
    tpl = TEMPLATES[name]
    expr, _ = parse_expr(f"({name} cube panda_hand_tcp {theta})")
    rng = np.random.default_rng(7)
    rows, dsl = [], []
    for _ in range(12):
        state = rw.state(rw.naive_coords(rng), rng)
        s = state_from_json(state, rw.world.scene, rw.model, rw.world_state_base(), "s")
        frames = rw.compiled.fk(s.q)
        ev = Evaluator(rw.world.scene, rw.model, s.q, frames, world_poses(s, rw.model, frames),
                       rw.scope)
        dsl.append(ev.distance(expr))
        rows.append(np.atleast_1d(rw.features(state)[f"({name} ?c ?g)"]))
    g = np.array(rows)
    closed = np.maximum(tpl.feature(g) - theta, 0.0)
    assert np.allclose(closed, dsl, atol=1e-9)
    assert np.allclose(distance(tpl.cpz(theta), g), closed, atol=1e-5)
    del Obj


# ---- the error -------------------------------------------------------------------------------

def _synthetic(n, seed, truth_fn):
    rng = np.random.default_rng(seed)
    d, r = Instance("dist", ("?c", "?g")), Instance("roll-aligned", ("?c", "?g"))
    p = Instance("pitch-aligned", ("?c", "?g"))
    e = Instance("empty", ("?g",), True)
    t = {d: rng.uniform(0, 0.4, n), r: rng.uniform(0, math.pi, n), p: rng.uniform(0, 1.5, n)}
    truth = {e: rng.random(n) < 0.5}
    success = truth_fn(t[d], t[r], t[p], truth[e])
    return Features(t, truth, success), (d, r, p, e)


def test_the_jax_objective_is_the_numpy_error_and_its_gradient_is_right():
    feats, (d, r, p, e) = _synthetic(200, 0, lambda d, r, p, e: (d < 0.1) & (r < 0.3) & e)
    f = Formula((Literal(e, None, True),), ((Literal(d, 0.15), Literal(r, 0.2)),
                                             (Literal(p, 0.5),)))
    prob = Problem(feats, feats.take([]), [d, r, p, e])
    masks = prob.masks(f)
    for thetas in ([0.15, 0.2, 0.5], [0.05, 0.6, 0.1]):
        x = np.array(thetas)
        v, g = prob.value_and_grad(f, x, masks)
        assert math.isclose(v, float(error(f, feats, x)), rel_tol=1e-9, abs_tol=1e-12)
        for k in range(3):
            h = np.zeros(3)
            h[k] = 1e-6
            fd = (float(error(f, feats, x + h)) - float(error(f, feats, x - h))) / 2e-6
            assert math.isclose(g[k], fd, rel_tol=1e-4, abs_tol=1e-6), (k, g[k], fd)
    # misclassified observations are what it counts: the truth's own formula has none
    exact = Formula((Literal(e, None, True),), ((Literal(d, 0.1), Literal(r, 0.3)),))
    assert float(error(exact, feats)) == 0.0


def test_the_edit_search_finds_the_planted_formula_and_beats_brute_force():
    feats, (d, r, p, e) = _synthetic(400, 1, lambda d, r, p, e: (d < 0.1) & (r < 0.3) & e)
    held, fit = feats.take(range(300, 400)), feats.take(range(300))
    prob = Problem(fit, held, [d, r, p, e])
    res = search(prob, Formula((), ((Literal(d, 0.3),),)), time_limit=30, max_edits=3)
    best = res.best.formula
    assert best.key() == Formula((Literal(e, None, True),),
                                 ((Literal(d, 0.1), Literal(r, 0.3)),)).key()
    got = {lit.instance: lit.theta for lit in best.clauses[0]}
    assert res.best.error == 0.0
    # each parameter sits inside the gap the data leaves: above every success's feature, below
    # every failure's that the other literals let through
    for inst, other in ((d, r), (r, d)):
        others = fit.truth[e] & (fit.t[other] <= got[other])
        assert fit.t[inst][fit.success].max() < got[inst] < fit.t[inst][others
                                                                         & ~fit.success].min()
    # brute force over every formula of at most three literals (one clause): none has a lower
    # error than the search's answer
    lits = [(d, None), (r, None), (p, None), (e, True), (e, False)]
    for k in range(1, 4):
        for combo in itertools.combinations(lits, k):
            if sum(inst == e for inst, _ in combo) > 1:
                continue
            disc = tuple(Literal(i, None, pos) for i, pos in combo if i.discrete)
            cont = tuple(Literal(i, i.template.bounds[1] / 4) for i, _ in combo
                         if not i.discrete)
            f = optimise(prob, Formula(disc, (cont,)))
            assert float(error(f, fit)) >= res.best.error - 1e-9, f.text()


def _zero_error_interval(f, feats, k, grid):
    """The parameters k of ``f`` on ``grid`` where the error over ``feats`` is zero (the others
    held): brute force over the error itself."""
    th = f.thetas()
    ok = []
    for v in grid:
        x = th.copy()
        x[k] = v
        if float(error(f, feats, x)) == 0.0:
            ok.append(v)
    return min(ok), max(ok)


def test_refit_centres_each_parameter_in_its_zero_error_gap_over_every_observation():
    from tmpc.runtime.repair.loop import refit
    feats, (d, r, p, e) = _synthetic(600, 3, lambda d, r, p, e: (d < 0.1) & (r < 0.3) & e)
    # a formula of the right structure that explains the data, with its parameters anywhere in
    # their gaps: refit puts each in the middle of the gap (brute force over the error)
    f = Formula((Literal(e, None, True),), ((Literal(d, 0.1001), Literal(r, 0.2999)),))
    assert float(error(f, feats)) == 0.0
    g = refit(f, feats)
    assert float(error(g, feats)) == 0.0
    for k, hi in ((0, 0.4), (1, math.pi)):
        lo_k, hi_k = _zero_error_interval(g, feats, k, np.linspace(0, hi, 40001))
        assert abs(g.thetas()[k] - (lo_k + hi_k) / 2) <= hi / 40000, (k, g.thetas())
    assert refit(g, feats).thetas() == pytest.approx(g.thetas())      # a fixed point
    # what refit leaves alone: a formula that misclassifies (a repair's job), several clauses,
    # and a parameter nothing bounds from above
    wrong = f.with_thetas([0.2, 0.2999])
    assert refit(wrong, feats) is wrong
    two = Formula((Literal(e, None, True),), ((Literal(d, 0.1001), Literal(r, 0.2999)),
                                              (Literal(d, 0.05),)))
    assert refit(two, feats) is two
    only = feats.take(np.flatnonzero(feats.t[d] < 0.3))
    only = Features(only.t, only.truth, only.t[d] < 0.1)
    edge = only.t[d][only.success].max(), only.t[d][~only.success].min()
    tight = Formula((), ((Literal(d, edge[0] + 1e-9),),))
    assert refit(tight, only).thetas()[0] == pytest.approx(sum(edge) / 2)
    unbounded = Features(only.t, only.truth, np.ones(len(only), bool))
    loose = Formula((), ((Literal(d, 0.3),),))
    assert refit(loose, unbounded) is loose


def test_a_shrunk_distance_goes_back_to_the_models_value_when_a_band_explains_the_failures():
    """The staircase of a conjunction: a few observations (two successes near the object and
    aligned, failures misaligned at several distances) are classified right both by a shrunk
    distance with a band as wide as the angle's range and by the model's distance with a narrow
    band. ``anchored`` finds the latter, checked by brute force over the band; refit and a
    repair's centring use it, and the ranking prefers it (deviation from the model)."""
    from tmpc.runtime.repair.loop import anchor, refit
    from tmpc.runtime.repair.search import anchored, deviation, optimise
    _, (d, r, p, e) = _synthetic(1, 0, lambda d, r, p, e: d < 0)
    # (distance, roll, success): the truth is d < 0.1 and roll < 0.3
    obs = [(0.005, 0.05, True), (0.008, 0.2, True), (0.015, 0.5, False), (0.03, 1.0, False),
           (0.06, 0.4, False), (0.2, 0.1, False), (0.3, 0.05, False), (0.05, 2.0, False)]

    def feats_of(rows):
        n = len(rows)
        return Features({d: np.array([o[0] for o in rows]), r: np.array([o[1] for o in rows]),
                         p: np.zeros(n)}, {e: np.ones(n, bool)}, np.array([o[2] for o in rows]))

    feats = feats_of(obs)
    model = anchor(Formula((), ((Literal(d, 0.1),),)))
    wide = Formula((), ((Literal(d, 0.0135), Literal(r, 3.0)),))
    assert float(error(wide, feats)) == 0.0
    y = anchored(wide, feats, wide.thetas(), model)
    assert y is not None and y[0] == 0.1
    bands = np.linspace(0, math.pi, 31417)
    good = bands[[float(error(wide.with_thetas([0.1, b]), feats)) == 0.0 for b in bands]]
    assert good.min() == pytest.approx(0.2, abs=1e-3) and good.max() == pytest.approx(0.4,
                                                                                   abs=1e-3)
    assert y[1] == pytest.approx(0.3)                       # the middle of that gap
    assert deviation(wide.with_thetas(y), model) == 0.0 < deviation(wide, model)
    # the loop's refit and a repair's centring start there, then centre the distance in its
    # gap with the band at 0.3 (successes up to 0.008, failures from 0.2); without the model,
    # the distance stays shrunk
    assert refit(wide, feats, model).thetas() == pytest.approx([0.104, 0.3])
    assert refit(wide, feats).thetas()[0] < 0.015
    prob = Problem(feats, feats.take([]), [d, r, p, e], model)
    assert optimise(prob, wide).thetas() == pytest.approx([0.104, 0.3])
    # nothing to move to: a failure within the model's distance that no band excludes
    bad = feats_of(obs + [(0.08, 0.1, False)])
    assert float(error(wide, bad)) == 0.0
    assert anchored(wide, bad, wide.thetas(), model) is None
    assert refit(wide, bad, model).thetas()[0] < 0.015


# ---- the loop, the store, resume ----------------------------------------------------------------

def test_experiment_one_converges_to_the_truths_parameter(rw, tmp_path):
    truth = _truth(rw, "(dist ?c ?g 0.1)")
    cfg = LoopConfig(sampling="naive", stop_unexpected=5, stop_expected_run=None,
                     max_observations=1500)
    with Store(tmp_path / "s.sqlite", {"domain": "pick", "run": "t"}) as store:
        res = run_loop(rw, store, 0, Sampled(rw, SimController(rw, truth), cfg),
                       rw.target.start, cfg, seed=0)
        kept = store.observations(0)
    # one repair per unexpected observation; the expected ones in between refit the parameter
    # (with them, 1,500 naive draws may hold fewer than 5 surprises)
    assert 1 <= res.unexpected <= 5 and len(res.repairs) == res.unexpected and res.refits > 0
    (lit,), = res.formula.clauses
    assert lit.instance.name == "dist" and abs(lit.theta - 0.1) <= 0.01
    assert [o.state for o in kept] == [o.state for o in res.observations]


def test_a_store_is_locked_and_knows_its_domain(tmp_path):
    from tmpc.lang.diagnostics import InputError
    path = tmp_path / "s.sqlite"
    with Store(path, {"domain": "pick", "action": "(pick a b)"}):
        code = ("import sys; from tmpc.runtime.repair import Store\n"
                "from tmpc.lang.diagnostics import InputError\n"
                f"try:\n    Store({str(path)!r}, {{'domain': 'pick', 'action': '(pick a b)'}})\n"
                "except InputError as e:\n    print(e.diagnostics[0].code)\n")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert out.stdout.strip() == "E841", out.stderr
    with pytest.raises(InputError) as exc:
        Store(path, {"domain": "other", "action": "(pick a b)"})
    assert exc.value.diagnostics[0].code == "E842"
    (tmp_path / "junk.sqlite").write_bytes(b"not a database at all" * 100)
    with pytest.raises(InputError) as exc:
        Store(tmp_path / "junk.sqlite", {"domain": "pick"})
    assert exc.value.diagnostics[0].code == "E840"


def test_a_store_from_before_cpu_times_opens_and_keeps_its_repairs(tmp_path):
    """Stores written before repairs recorded CPU time gain the column (0 for old rows)."""
    from tmpc.runtime.repair.store import RepairStep

    path = tmp_path / "old.sqlite"
    with Store(path, {"domain": "pick"}) as store:
        store.add_repair(0, RepairStep(1, "(a)", "(b)", 0.5, "constraint", 1, 3, 0.2, [0.5],
                                       [], 0.1))
    db = sqlite3.connect(path)
    db.executescript("ALTER TABLE repairs DROP COLUMN cpu_seconds")       # the old schema
    db.close()
    with Store(path, {"domain": "pick"}) as store:
        store.add_repair(0, RepairStep(2, "(c)", "(a)", 0.0, "constraint", 1, 3, 0.3, [0.0],
                                       [], 0.25))
        assert [(s.observation, s.cpu_seconds) for s in store.repairs(0)] == [(1, 0.0), (2, 0.25)]


def test_sigkill_mid_loop_then_resume_keeps_every_observation(tmp_path):
    db = tmp_path / "s.sqlite"
    args = [sys.executable, "-m", "tmpc.runtime.cli", "repair", str(EXP1), "--action", "pick",
            "--controller", "sim:(and (dist ?c ?g 0.1) (roll-aligned ?c ?g 0.2))",
            "--db", str(db), "--max-observations", "150", "--seed", "4"]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    seen = 0
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:
        time.sleep(0.2)
        try:
            with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as c:
                seen = c.execute("SELECT COUNT(*) FROM observations").fetchone()[0]
        except sqlite3.Error:
            continue
        if seen >= 30:
            break
    assert proc.poll() is None, "the run ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    with sqlite3.connect(db) as c:
        before = c.execute("SELECT seq, state, success FROM observations ORDER BY seq").fetchall()
    assert len(before) >= 30
    # the runs after the kill in this process (a run's exit code, output and store are the
    # same; the kill needs the process above)
    rc, _, err = _run(*args[3:])
    assert rc == 2 or "E849" in err     # not without --resume
    rc, again, err = _run(*args[3:], "--resume")
    assert rc == 0, err
    with sqlite3.connect(db) as c:
        after = c.execute("SELECT seq, state, success FROM observations ORDER BY seq").fetchall()
        unexpected = c.execute("SELECT COUNT(*) FROM observations WHERE expected = 0"
                               ).fetchone()[0]
    assert after[:len(before)] == before
    assert [s for s, *_ in after] == list(range(len(after)))
    assert len(after) == 150 and unexpected >= 3
    # the resumed run draws what an uninterrupted one does
    fresh = tmp_path / "fresh.sqlite"
    rc, whole, err = _run(*[a if a != str(db) else str(fresh) for a in args[3:]])
    assert rc == 0, err
    with sqlite3.connect(fresh) as c:
        straight = c.execute("SELECT seq, state, success FROM observations ORDER BY seq"
                             ).fetchall()
    assert straight == after
    assert whole.splitlines()[0] == again.splitlines()[0]


# ---- write-back and recorded observations ----------------------------------------------------

def test_write_back_keeps_comments_and_checks(rw, tmp_path):
    from tmpc.lang.program import check_paths
    from tmpc.lang.source import SourceFile
    path = EXAMPLES / "repair" / "exp1.pddl"
    src = SourceFile(str(path), path.read_text())
    f = _truth(rw, "(and (empty ?g) (or (and (dist ?c ?g 0.1) (roll-aligned ?c ?g 0.05)) "
                   "(dist ?c ?g 0.02)))")
    text = rewrite(src, rw.target, f)
    assert "; where the controller can grasp the cube from" in text
    assert "(or (and (dist ?c ?g 0.1) (roll-aligned ?c ?g 0.05)) (dist ?c ?g 0.02))" in text
    assert "(and (empty ?g) (graspable ?c ?g))" in text
    out = tmp_path / "exp1.pddl"
    out.write_text(text)
    report = check_paths([str(out), str(EXAMPLES / "repair" / "problem.pddl")])
    assert not [d for d in report.diagnostics if d.is_error]


def test_recorded_observations_drive_repair_and_bad_lines_name_their_line(rw, tmp_path):
    rng = np.random.default_rng(0)
    truth = _truth(rw, "(dist ?c ?g 0.15)")
    sim = SimController(rw, truth)
    lines = []
    for _ in range(150):
        state = rw.state(rw.naive_coords(rng), rng)
        out = sim(state, rw.features(state))
        lines.append(json.dumps({"state": state, "action": "pick",
                                 "arguments": ["panda_hand_tcp", "cube"],
                                 "outcome": "success" if out.success else "failure",
                                 "result": out.result}))
    obs = tmp_path / "obs.jsonl"
    obs.write_text("\n".join(lines) + "\n")
    rc, got, err = _run("repair", EXP1, "--action", "pick", "--observations", obs,
                        "--db", tmp_path / "s.sqlite")
    assert rc == 0, err
    first = got.splitlines()[0]
    theta = float(first.rsplit(" ", 1)[1].rstrip(")"))
    assert "(dist ?c ?g" in first and abs(theta - 0.15) < 0.03, first
    lines[7] = '{"state": {}, "action": "pick", "arguments": ["panda_hand_tcp", "cube"]}'
    obs.write_text("\n".join(lines) + "\n")
    rc, err = _cli("repair", EXP1, "--action", "pick", "--observations", obs,
                   "--db", tmp_path / "t.sqlite")
    assert rc == 1 and f"{obs}:8:" in err and "E843" in err and "outcome" in err
    assert "Traceback" not in err
    lines[7] = json.dumps({"state": {"joints": {"no_such_joint": 1.0}}, "action": "pick",
                           "arguments": ["panda_hand_tcp", "cube"], "outcome": "failure"})
    obs.write_text("\n".join(lines) + "\n")
    rc, err = _cli("repair", EXP1, "--action", "pick", "--observations", obs,
                   "--db", tmp_path / "u.sqlite")
    assert rc == 1 and f"{obs}:8:" in err and "no_such_joint" in err


def _cli(*argv) -> tuple[int, str]:
    """``tmpc ARGV`` in this process: (exit code, stderr)."""
    rc, _, err = _run(*argv)
    return rc, err


def _run(*argv) -> tuple[int, str, str]:
    """``tmpc ARGV`` in this process: (exit code, stdout, stderr)."""
    got = tmpc_here(*argv)
    return got.returncode, got.stdout, got.stderr


@pytest.mark.parametrize("argv,code", [
    (["--action", "place", "--controller", "sim:(dist ?c ?g 0.1)"], "E844"),
    (["--action", "pick", "--controller", "sim:(dist ?g ?c 0.1)"], "E845"),
    (["--action", "pick", "--controller", "sim:(near ?c ?g 0.1)"], "E845"),
    (["--action", "pick", "--controller", "ros:arm"], "E846"),
    (["--action", "pick", "--controller", "py:no_such_module:fn"], "E846"),
])
def test_bad_repair_inputs_are_clear_errors(tmp_path, argv, code):
    rc, err = _cli("repair", EXP1, *argv, "--db", tmp_path / "s.sqlite")
    assert rc == 1 and code in err, err
    assert "Traceback" not in err


def test_a_store_from_another_domain_is_refused(tmp_path):
    db = str(tmp_path / "s.sqlite")
    with Store(db, {"domain": "elsewhere", "action": "(pick panda_hand_tcp cube)",
                    "parameters": "?g ?c", "run": "sim:(dist ?c ?g 0.1)"}):
        pass
    rc, err = _cli("repair", EXP1, "--action", "pick", "--controller", "sim:(dist ?c ?g 0.1)",
                   "--db", db)
    assert rc == 1 and "E842" in err and "elsewhere" in err


def test_the_experiment_command_writes_the_documented_report(tmp_path, monkeypatch):
    monkeypatch.chdir(EXAMPLES.parent)
    rc, _, err = _run("repair", "--experiment", "1", "--trials", "1", "--report", tmp_path / "r")
    assert rc == 0, err
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert report["experiment"] == 1
    (trial,) = report["trials"]
    assert set(trial) >= {"seed", "final_formula", "structurally_correct", "param_error",
                          "edits", "unexpected", "loop_seconds", "loop_cpu_seconds"}
    assert trial["structurally_correct"] is True and trial["param_error"] <= 0.01
    assert trial["unexpected"] == 5 and len(trial["loop_seconds"]) == 5
    assert len(trial["loop_cpu_seconds"]) == 5 and sum(trial["loop_cpu_seconds"]) > 0
    # error over edits, from the file alone: one record per repair, each a non-increasing
    # trace of best errors ending at the repair's error, which explains the observations (0)
    assert len(trial["repairs"]) == 5
    for r in trial["repairs"]:
        assert set(r) >= {"observation", "error", "edits", "trace", "param_error"}
        assert r["trace"] and r["trace"] == sorted(r["trace"], reverse=True)
        assert r["trace"][-1] == r["error"] and r["error"] <= 1e-9
    assert trial["repairs"][-1]["param_error"] == trial["param_error"]
    png = tmp_path / "r" / "experiment1.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
