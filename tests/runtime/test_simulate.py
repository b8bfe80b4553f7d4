"""`tmpc simulate` (MuJoCo, headless): a good tabletop plan settles with every drift under 5 mm
and keeps its goal while position actuators track it; the same plan with its releases lifted
5 cm, or with a cube released over the tray's edge, is caught by --strict; the simulated
motion is written as a viewer page whose last frame is the settled world."""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest

from tests.support import TABLETOP

pytest.importorskip("mujoco")


@pytest.fixture(scope="module")
def timed_plan(tabletop_world):
    from tmpc.runtime.plans import plan_document
    from tmpc.runtime.solve import plan_problem
    from tmpc.runtime.timing import time_world_plan
    problem, result, _ = plan_problem(tabletop_world, "unified", seed=0, time_limit=60.0)
    assert result.status == "solved"
    doc = plan_document(problem, result, planner="unified", seed=0, input_path=str(TABLETOP),
                        setup_seconds=0.0)
    time_world_plan(tabletop_world, doc)
    return doc


@pytest.fixture(scope="module")
def good_report(tabletop_world, timed_plan):
    from tmpc.runtime.simulate import simulate
    return simulate(tabletop_world, timed_plan, trace=True)


def test_a_good_plan_settles(good_report):
    report = good_report
    assert set(report.drift) == {"red_cube", "blue_cube"}
    assert max(report.drift.values()) < 0.005, report.text()
    assert max(report.tilt.values()) < np.radians(5), report.text()
    assert report.goal_holds, report.text()
    assert report.ok()
    # the actuators follow the timing: within 2 mrad of every timed joint's reference
    assert report.tracking and 0 < report.max_tracking < 0.002, report.tracking
    assert report.contacts == []


def _released_past(doc, obj, k, point):
    """``doc`` with ``obj`` held so that the release at state ``k`` leaves it at ``point``: the
    grasp's offset moved rigidly with the hand (the held object turns with it)."""
    from tmpc.runtime.validate import quat_matrix
    out = json.loads(json.dumps(doc))
    pose = doc["states"][k]["object_poses"][obj]
    R_release = quat_matrix(pose["rotation"])
    shift = np.asarray(point) - np.asarray(pose["translation"])
    for s in out["states"]:
        if obj in (s["mode"]["held"] or {}):
            p = s["object_poses"][obj]
            d = quat_matrix(p["rotation"]) @ R_release.T @ shift
            p["translation"] = [a + b for a, b in zip(p["translation"], d)]
    return out


def test_a_release_lifted_5_cm_is_caught(timed_plan, tmp_path):
    from tmpc.runtime.cli.main import main
    doc = json.loads(json.dumps(timed_plan))
    for s in doc["states"]:                      # every held object carried 5 cm higher
        for obj in (s["mode"]["held"] or {}):
            s["object_poses"][obj]["translation"][2] += 0.05
    plan = tmp_path / "lifted.json"
    plan.write_text(json.dumps(doc))
    assert main(["simulate", str(TABLETOP), str(plan), "--strict", "--json"]) == 1
    good = tmp_path / "good.json"
    good.write_text(json.dumps(timed_plan))
    assert main(["simulate", str(TABLETOP), str(good), "--strict"]) == 0


def test_a_release_on_the_edge_of_the_tray_is_caught(tabletop_world, timed_plan):
    """The blue cube let go with its centre 2 cm past the tray's edge (x 0.55): it tips."""
    from tmpc.runtime.simulate import simulate
    k = next(i for i, s in enumerate(timed_plan["states"])
             if (s.get("action") or "").startswith("(place") and "blue_cube" in s["action"])
    p = timed_plan["states"][k]["object_poses"]["blue_cube"]["translation"]
    report = simulate(tabletop_world, _released_past(timed_plan, "blue_cube", k,
                                                     (0.57, p[1], p[2])))
    assert not report.ok(), report.text()
    assert report.drift["blue_cube"] > 0.01 or report.tilt["blue_cube"] > np.radians(5)


def test_the_simulated_motion_as_a_page(tabletop_world, timed_plan, good_report, tmp_path):
    from tmpc.runtime.simulate import write_sim_html
    out = tmp_path / "sim.html"
    size = write_sim_html(tabletop_world, timed_plan, good_report.trace, out)
    text = out.read_text()
    assert size == len(text.encode()) and "tmpc simulate" in text
    data = json.loads(re.search(r'<script id="plan-data" type="application/json">(.*?)</script>',
                                text, re.S).group(1))
    frames = data["frames"]
    t = np.frombuffer(base64.b64decode(frames["t"]), "<f4")
    assert len(t) == frames["count"] >= len(good_report.trace)
    assert np.all(np.diff(t) > 0) and t[-1] == pytest.approx(good_report.sim_seconds, abs=1e-3)
    pos = np.frombuffer(base64.b64decode(frames["pos"]), "<f4").reshape(len(t), -1, 3)
    node = next(lb["node"] for lb in data["labels"] if lb["name"] == "red_cube")
    assert pos[-1, node] == pytest.approx(good_report.settled_poses["red_cube"], abs=1e-4)
    assert pos[0, node] == pytest.approx([0.5, 0.15, 0.425], abs=1e-3)


def test_an_unwritable_page_is_e835(tabletop_world, timed_plan, good_report, tmp_path):
    from tmpc.lang.diagnostics import TmpcError
    from tmpc.runtime.simulate import write_sim_html
    with pytest.raises(TmpcError) as exc:
        write_sim_html(tabletop_world, timed_plan, good_report.trace[:3],
                       tmp_path / "missing" / "sim.html")
    assert exc.value.diagnostics[0].code == "E835"


def test_bench_simulate_records_and_tabulates_physics(tabletop_world, timed_plan):
    """`tmpc bench --simulate`'s record of a run and its physics table."""
    from tmpc.runtime.bench.physics import physics_record, physics_table
    doc = json.loads(json.dumps(timed_plan))
    for s in doc["states"]:
        s.pop("t", None)
    doc.pop("timing")
    rec = physics_record(tabletop_world, doc)
    assert rec["settled"] is True and set(rec["drift"]) == {"red_cube", "blue_cube"}
    assert 0 < rec["max_drift"] < 0.005 and rec["motions"] == 4 and rec["real_time_factor"] > 1
    bad = dict(rec, settled=False, drift={"red_cube": 0.05}, max_drift=0.05)
    recs = [{"problem": "tabletop", "planner": "unified", "physics": p} for p in (rec, bad)]
    recs.append({"problem": "tabletop", "planner": "unified", "physics": {"settled": None,
                                                                        "error": "E833: x"}})
    rows = physics_table(recs).splitlines()
    assert rows[0].startswith("| problem | planner | settled | max drift mm")
    assert rows[2].startswith("| tabletop | unified | 1/3 | 50.0 |")
    assert physics_table([{"problem": "p", "planner": "u"}]) == ""


def test_the_tower_of_three_cubes_stands(tmp_path):
    """examples/tower: c on b on a, planned and timed by `tmpc run --timed`, stands in MuJoCo
    (`rests-on` keeps each cube's centre over the one below, in that cube's own frame)."""
    from tests.support import ROOT
    from tmpc.runtime.cli.main import main
    tower = ROOT / "examples" / "tower" / "tower.toml"
    plan = tmp_path / "tower.json"
    assert main(["run", str(tower), "--seed", "2", "--timed", "-q", "-o", str(plan)]) == 0
    assert main(["simulate", str(tower), str(plan), "--strict"]) == 0
