"""Timed plans (docs/robot-export.md): toppra's timing checked without toppra — times increase,
every sampled motion keeps its joints' velocity and acceleration limits by finite differences,
the waypoints are the plan's, and a segment's duration is the analytic time-optimal
(trapezoidal) one; the ROS-shaped export round-trips."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tests.support import TABLETOP
from tmpc.lang.source import SourceFile
from tmpc.runtime.plans import parse_plan, plan_document
from tmpc.runtime.timing import joint_limits, time_segment, time_world_plan


@pytest.fixture(scope="module")
def tabletop_doc(tabletop_world):
    from tmpc.runtime.solve import plan_problem
    problem, result, _ = plan_problem(tabletop_world, "unified", seed=0, time_limit=60.0)
    assert result.status == "solved"
    return plan_document(problem, result, planner="unified", seed=0,
                         input_path=str(TABLETOP), setup_seconds=0.0)


@pytest.fixture(scope="module")
def timed_tabletop(tabletop_world, tabletop_doc):
    doc = json.loads(json.dumps(tabletop_doc))
    time_world_plan(tabletop_world, doc)
    return doc


def trapezoid(distance: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> float:
    """The time-optimal rest-to-rest duration along a straight line (a reference, no toppra)."""
    moving = np.abs(distance) > 0
    sv = np.min(vmax[moving] / np.abs(distance[moving]))
    sa = np.min(amax[moving] / np.abs(distance[moving]))
    return 2 * math.sqrt(1 / sa) if sv * sv / sa >= 1 else 1 / sv + sv / sa


def check_limits(doc) -> None:
    timing = doc["timing"]
    names = timing["joint_names"]
    v = np.array([timing["limits"][n]["velocity"] for n in names])
    a = np.array([timing["limits"][n]["acceleration"] for n in names])
    for m in timing["motions"]:
        t, q = np.array(m["t"]), np.array(m["positions"])
        assert np.all(np.diff(t) > 0), "times must increase strictly within a motion"
        dq = np.diff(q, axis=0) / np.diff(t)[:, None]
        assert np.all(np.abs(dq) <= v * (1 + 1e-3) + 1e-9), np.abs(dq).max(0) / v
        mid = (t[1:] + t[:-1]) / 2
        ddq = np.diff(dq, axis=0) / np.diff(mid)[:, None]
        assert np.all(np.abs(ddq) <= a * (1 + 1e-2) + 1e-6), np.abs(ddq).max(0) / a
        # the sampled velocities agree with the positions' differences
        vel = np.array(m["velocities"])
        assert np.allclose((vel[1:] + vel[:-1]) / 2, dq, atol=0.05 * v.max())


def test_times_increase_and_limits_hold(timed_tabletop):
    ts = [s["t"] for s in timed_tabletop["states"]]
    assert ts[0] == 0 and all(b >= a for a, b in zip(ts, ts[1:])) and ts[-1] > 0
    for s, s2 in zip(timed_tabletop["states"], timed_tabletop["states"][1:]):
        if s["action"] is not None:
            assert s2["t"] == s["t"]                  # an action takes no time
    check_limits(timed_tabletop)


def test_waypoints_are_the_plans_and_durations_are_optimal(tabletop_world, timed_tabletop):
    timing = timed_tabletop["timing"]
    names = timing["joint_names"]
    states = timed_tabletop["states"]
    v = np.array([timing["limits"][n]["velocity"] for n in names])
    a = np.array([timing["limits"][n]["acceleration"] for n in names])
    for m in timing["motions"]:
        first, last = m["states"]
        for k in range(first, last + 1):
            i = m["t"].index(states[k]["t"]) if states[k]["t"] in m["t"] else None
            assert i is not None, f"state {k}'s time is not a sample"
            want = [states[k]["joints"][n] for n in names]
            assert m["positions"][i] == pytest.approx(want, abs=1e-12)
        for k in range(first, last):
            d = np.array([states[k + 1]["joints"][n] - states[k]["joints"][n] for n in names])
            if np.abs(d).max() > 0:
                want = trapezoid(d, v, a)
                assert states[k + 1]["t"] - states[k]["t"] == pytest.approx(want, rel=1e-3)


def test_limits_come_from_the_urdf(tabletop_world):
    lim = joint_limits(tabletop_world, ["panda_joint1", "panda_joint7"])
    assert lim["panda_joint1"].velocity == pytest.approx(2.175)      # panda.urdf's <limit>
    assert lim["panda_joint7"].velocity == pytest.approx(2.61)
    assert lim["panda_joint1"].acceleration_source == "default"
    lim = joint_limits(tabletop_world, ["panda_joint1"], max_accel=7.0)
    assert lim["panda_joint1"].acceleration == 7.0


def test_a_segment_against_the_analytic_profile():
    qa, qb = np.zeros(3), np.array([1.0, -0.2, 0.4])
    v, a = np.array([1.0, 2.0, 1.0]), np.array([2.0, 2.0, 0.5])
    duration, traj = time_segment(qa, qb, v, a)
    assert duration == pytest.approx(trapezoid(qb - qa, v, a), rel=1e-4)
    assert np.allclose(traj(np.array([duration]))[0], qb, atol=1e-9)


def test_a_mobile_base_is_timed(clutter_world, tmp_path):
    # a PR2 plan made by hand: the base drives 1 m and turns through +-pi (the short way)
    start = {"joints": {"torso_lift_joint": 0.1}, "action": None,
             "base_pose": {"translation": [0.0, 0.0, 0.0],
                           "rotation": [0, 0, math.sin(-3.0 / 2), math.cos(-3.0 / 2)]}}
    end = {"joints": {"torso_lift_joint": 0.2}, "action": None,
           "base_pose": {"translation": [1.0, 0.0, 0.0], "rotation": [0, 0, 1.0, 0.0]}}
    doc = {"format": "tmpc-plan/1", "states": [start, end]}
    block = time_world_plan(clutter_world, doc)
    assert block["joint_names"][-3:] == ["base_x", "base_y", "base_yaw"]
    yaw = np.array(block["motions"][0]["positions"])[:, -1]
    assert abs(yaw[-1] - yaw[0]) == pytest.approx(2 * math.pi - 3.0 - math.pi, abs=1e-9)
    check_limits(doc)


def test_timed_plans_read_and_bad_times_are_e818(timed_tabletop):
    plan = parse_plan(SourceFile("<plan>", json.dumps(timed_tabletop)))
    assert plan.timed and plan.states[-1].t == timed_tabletop["states"][-1]["t"]
    untimed = json.loads(json.dumps(timed_tabletop))
    for s in untimed["states"]:
        del s["t"]
    assert not parse_plan(SourceFile("<plan>", json.dumps(untimed))).timed
    from tmpc.lang.diagnostics import TmpcError
    for bad in (-1.0, "1", float("nan")):
        broken = json.loads(json.dumps(timed_tabletop))
        broken["states"][1]["t"] = bad
        with pytest.raises(TmpcError) as exc:
            parse_plan(SourceFile("<plan>", json.dumps(broken)))
        assert exc.value.diagnostics[0].code == "E818"
    broken = json.loads(json.dumps(timed_tabletop))
    broken["states"][-1]["t"] = 0.0
    with pytest.raises(TmpcError) as exc:
        parse_plan(SourceFile("<plan>", json.dumps(broken)))
    assert exc.value.diagnostics[0].code == "E818"


@pytest.mark.parametrize("suffix", ["json", "yaml"])
def test_the_export_round_trips(timed_tabletop, tmp_path, suffix):
    import yaml

    from tmpc.runtime.cli.main import main
    from tmpc.runtime.timing import total_seconds
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(timed_tabletop))
    out = tmp_path / f"traj.{suffix}"
    assert main(["export", str(plan), "--format", "ros-joint-trajectory", "-o", str(out)]) == 0
    text = out.read_text()
    doc = yaml.safe_load(text) if suffix == "yaml" else json.loads(text)
    if suffix == "yaml":
        assert "&id" not in text and not text.lstrip().startswith("{")
    states, timing = timed_tabletop["states"], timed_tabletop["timing"]
    trajectories = [s for s in doc["steps"] if s["type"] == "trajectory"]
    assert len(trajectories) == len(timing["motions"]) == 4
    # the plan's picks and places, in its order: (pick g cube s) grasps, (place ...) releases
    expected = [("grasp" if a.startswith("(pick") else "release", a.split()[2])
                for a in timed_tabletop["actions"]]
    assert len(expected) == 4
    assert [(s["event"], s["object"]) for s in doc["steps"] if s["type"] == "event"] == expected
    last = -1.0
    for step in doc["steps"]:
        if step["type"] == "event":
            assert step["time"] >= last - 1e-6
            last = step["time"]
            continue
        msg = step["trajectory"]
        names = msg["joint_names"]
        times = [total_seconds(step, p) for p in msg["points"]]
        assert times[0] >= last - 1e-6 and all(b > a for a, b in zip(times, times[1:]))
        last = times[-1]
        for p in msg["points"]:
            assert set(p) == {"positions", "velocities", "accelerations", "effort",
                              "time_from_start"}
            assert 0 <= p["time_from_start"]["nanosec"] < 10**9
            assert len(p["positions"]) == len(p["velocities"]) == len(names)
            for n, v in zip(names, p["velocities"]):
                assert abs(v) <= doc["limits"][n]["velocity"] * (1 + 1e-6)
        # the exported points themselves keep the limits, by finite differences (no toppra)
        t = np.array(times)
        q = np.array([p["positions"] for p in msg["points"]])
        vmax = np.array([doc["limits"][n]["velocity"] for n in names])
        amax = np.array([doc["limits"][n]["acceleration"] for n in names])
        dq = np.diff(q, axis=0) / np.diff(t)[:, None]
        assert np.all(np.abs(dq) <= vmax * (1 + 1e-3) + 1e-9)
        ddq = np.diff(dq, axis=0) / np.diff((t[1:] + t[:-1]) / 2)[:, None]
        assert np.all(np.abs(ddq) <= amax * (1 + 1e-2) + 1e-6)
        first, end = step["states"]
        for k in (first, end):          # the motion starts and ends at the plan's states
            p = msg["points"][0 if k == first else -1]
            assert p["positions"] == pytest.approx([states[k]["joints"][n] for n in names],
                                                   abs=1e-9)
            assert total_seconds(step, p) == pytest.approx(states[k]["t"], abs=1e-9)


def test_export_needs_times(tabletop_doc, tmp_path, capsys):
    from tmpc.runtime.cli.main import main
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(tabletop_doc))
    assert main(["export", str(plan), "--format", "ros-joint-trajectory"]) == 1
    assert "E819" in capsys.readouterr().err
