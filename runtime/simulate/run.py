"""Replaying a timed plan in MuJoCo: position actuators track the timed joints, a grasp welds
the object to the holding frame from the pick to the release, then the world settles; the
report gives each released object's drift, unexpected contacts, the tracking error and whether
the goal holds in the settled world (docs/physics.md)."""

from __future__ import annotations

import json
import re
import time

import numpy as np

from tmpc.lang.source import SourceFile
from tmpc.runtime.plans import parse_plan
from tmpc.runtime.simulate.model import GRASPED_BITS, SCENE_BITS, TRACKING_HZ, build_model, \
    fail, joint_children, mimics, set_gains
from tmpc.runtime.simulate.report import DRIFT_LIMIT, SimReport
from tmpc.runtime.timing import BASE_JOINTS, base_pose_values, events
from tmpc.runtime.validate import quat_from_matrix, validate_plan

#: contacts deeper than this are reported (m)
CONTACT_DEPTH = 0.002
#: a released object touches the robot again once no gripper geom is within this (m)
LET_GO = 0.001
#: a goal atom's distance in the settled world up to this still holds (m or rad)
GOAL_SLACK = 0.005
#: s between the samples of the motion kept for ``--html``
TRACE_DT = 0.04

__all__ = ["simulate", "DRIFT_LIMIT", "CONTACT_DEPTH"]


def simulate(world, doc: dict, settle: float = 1.0, trace: bool = False) -> SimReport:
    """Replay ``doc`` (a timed ``tmpc-plan/1`` object) in ``world`` (opened with its program
    for the goal check); ``trace``: keep samples of the motion in the report."""
    import mujoco
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)    # the report says it, no MUJOCO_LOG.TXT
    try:
        return _simulate(world, doc, settle, trace)
    finally:
        mujoco.set_mju_user_warning(previous)


def _simulate(world, doc: dict, settle: float, trace: bool) -> SimReport:
    import mujoco
    plan = parse_plan(SourceFile("<plan>", json.dumps(doc)))
    timing = doc["timing"]
    names = list(timing["joint_names"])
    mobile = any(n in BASE_JOINTS for n in names) or bool(
        world.scene.robot is not None and world.scene.robot.mobile_base)
    sim = build_model(world, plan.states[0].objects, plan.states[0].base, mobile)
    model = sim.model
    data = mujoco.MjData(model)
    jid = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, i): i for i in range(model.njnt)}
    missing = [n for n in names if n not in jid]
    if missing:
        raise fail(f"the robot model has no joints {missing}")
    act = {n: i for i, n in enumerate(sim.joints)}
    qadr = np.array([model.jnt_qposadr[jid[n]] for n in sim.joints], int)
    ref0 = _start_values(doc, sim, plan.states[0].base)
    timed = np.array([act[n] for n in names], int)
    follow = [(act[n], act[m], k, off) for n, (m, k, off) in mimics(world).items()
              if n in act and m in act]
    ts, qs, vs, accs = _timeline(doc, names, ref0[timed])
    body = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i): i for i in range(model.nbody)}
    for joint, child in joint_children(world).items():     # frames named by their joint
        if child in body:
            body.setdefault(joint, body[child])
    objects = {o: body[f"obj:{o}"] for o in sim.movable}
    geoms = {o: [g for g in range(model.ngeom) if model.geom_bodyid[g] == b]
             for o, b in objects.items()}
    timeline = _events(doc)
    data.qpos[qadr] = ref0
    mujoco.mj_forward(model, data)
    lead = set_gains(sim, data)
    held: dict[str, str] = {}
    letting_go: dict[str, tuple[float, list[int]]] = {}
    released: dict[str, np.ndarray | None] = {}
    report = SimReport()
    duration = float(timing["duration"])
    steps = int(np.ceil((duration + settle) / model.opt.timestep))
    contacts: dict[tuple[str, str], dict] = {}
    at = np.arange(steps) * model.opt.timestep
    q_ref = np.stack([np.interp(at, ts, qs[:, j]) for j in range(len(names))], 1)
    v_ref = np.stack([np.interp(at, ts, vs[:, j]) for j in range(len(names))], 1)
    # the timing's acceleration, held over each sample interval (piecewise constant, as toppra's)
    a_ref = accs[np.clip(np.searchsorted(ts, at, side="right") - 1, 0, len(ts) - 1)]
    a_ref[at >= ts[-1]] = 0.0
    inertial = 1.0 / (2 * np.pi * TRACKING_HZ) ** 2
    names_of = {i: n for n, i in body.items()}
    tracking = np.zeros(len(names))
    next_trace = 0.0
    wall = time.perf_counter()
    for step in range(steps):
        t = data.time
        while timeline and timeline[0]["time"] <= t:
            e = timeline.pop(0)
            o = e.get("object")
            if e["event"] == "approach" and o in objects and o not in held:
                letting_go.pop(o, None)
                for g in geoms[o]:
                    model.geom_contype[g], model.geom_conaffinity[g] = GRASPED_BITS
            elif e["event"] == "grasp" and o in objects and e["frame"] in body:
                after = plan.states[e["state"] + 1].objects.get(o)
                if after is not None:
                    off = float(np.linalg.norm(_pose(data, objects[o])[:3, 3] - after[:3, 3]))
                    report.displaced[o] = max(report.displaced.get(o, 0.0), off)
                _grasp(model, data, sim.welds[o], body[e["frame"]],
                       after if after is not None else _pose(data, objects[o]), geoms[o])
                held[o] = e["frame"]
                model.body_gravcomp[objects[o]] = 1.0     # the grip carries its weight
                letting_go.pop(o, None)
            elif e["event"] == "release" and o in held:
                data.eq_active[sim.welds[o]] = 0
                model.body_gravcomp[objects[o]] = 0.0
                letting_go[o] = (_retreat_end(doc, e["time"]),
                                 _gripper_geoms(model, body[held.pop(o)]))
                released[o] = None
        ref = ref0.copy()
        vel = np.zeros_like(ref0)
        acc = np.zeros_like(ref0)
        ref[timed], vel[timed], acc[timed] = q_ref[step], v_ref[step], a_ref[step]
        for a, m, k, off in follow:
            ref[a], vel[a] = k * ref[m] + off, k * vel[m]
        if t <= duration:
            tracking = np.maximum(tracking, np.abs(data.qpos[qadr[timed]] - ref[timed]))
        data.ctrl[:] = ref + lead * vel + inertial * acc
        if trace and t >= next_trace - 1e-9:
            report.trace.append(_sample(data, sim, qadr, objects))
            next_trace += TRACE_DT
        mujoco.mj_step(model, data)
        for o in [o for o, p in released.items() if p is None]:
            released[o] = _pose(data, objects[o])
        if letting_go and step % 5 == 0:
            for o in [o for o, (end, g) in letting_go.items()
                      if t >= end and _apart(model, data, g, geoms[o])]:
                letting_go.pop(o)
                for g in geoms[o]:
                    model.geom_contype[g], model.geom_conaffinity[g] = SCENE_BITS
        _contacts(model, data, names_of, sim.movable, held, contacts)
    if trace:
        report.trace.append(_sample(data, sim, qadr, objects))
    for o in held:
        model.body_gravcomp[objects[o]] = 0.0
    for o in letting_go:                   # leave the model as built
        for g in geoms[o]:
            model.geom_contype[g], model.geom_conaffinity[g] = SCENE_BITS
    report.wall_seconds = time.perf_counter() - wall
    report.unstable = int(data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number)
    report.sim_seconds = round(data.time, 4)
    report.tracking = {n: float(e) for n, e in zip(names, tracking)}
    settled = {o: _pose(data, b) for o, b in objects.items()}
    for obj, T0 in released.items():
        T1 = settled[obj]
        report.drift[obj] = float(np.linalg.norm(T1[:3, 3] - T0[:3, 3]))
        c = (np.trace(T0[:3, :3].T @ T1[:3, :3]) - 1) / 2
        report.tilt[obj] = float(np.arccos(np.clip(c, -1.0, 1.0)))
    report.contacts = sorted(contacts.values(), key=lambda c: c["time"])
    report.settled_poses = {o: T[:3, 3].round(5).tolist() for o, T in settled.items()}
    report.goal_holds, report.goal_failures = _goal(world, doc, settled)
    return report


def _events(doc) -> list[dict]:
    """The plan's grasp and release events in time order, each grasp preceded by an
    ``approach`` at the start of the motion that brings the hand to the object."""
    out = []
    spans = sorted((m["t"][-1], m["start"]) for m in doc["timing"]["motions"])
    for k, s in enumerate(doc["states"]):
        if s.get("action") is None:
            continue
        for e in events(doc, k):
            if e["event"] == "grasp":
                begun = [start for end, start in spans if end <= e["time"] + 1e-9]
                out.append(dict(e, event="approach", time=begun[-1] if begun else 0.0))
            out.append(e)
    return sorted(out, key=lambda e: e["time"])


def _start_values(doc, sim, base) -> np.ndarray:
    """Every actuated joint's value at the plan's first state (the base's x, y, yaw from its
    pose; a joint the plan does not name at 0, the URDF's reference)."""
    first = doc["states"][0].get("joints", {})
    values = dict(zip(BASE_JOINTS, base_pose_values(doc["states"][0])))
    return np.array([float(first.get(n, values.get(n, 0.0))) for n in sim.joints])


def _grasp(model, data, weld: int, frame: int, T_obj: np.ndarray, geoms) -> None:
    """Weld an object to ``frame`` at the pose ``T_obj`` the plan gives it in the grasp (an
    object that lies elsewhere is pulled there: the plan's grasp is what the robot does)."""
    rel = np.linalg.inv(_pose(data, frame)) @ T_obj
    model.eq_obj1id[weld] = frame
    model.eq_data[weld, :3] = 0.0
    model.eq_data[weld, 3:6] = rel[:3, 3]
    model.eq_data[weld, 6:10] = _wxyz(rel)
    model.eq_data[weld, 10] = 1.0
    data.eq_active[weld] = 1
    for g in geoms:
        model.geom_contype[g], model.geom_conaffinity[g] = GRASPED_BITS


def _retreat_end(doc, t: float) -> float:
    """When the first motion starting at or after ``t`` (the hand's retreat) ends."""
    ends = [m["t"][-1] for m in doc["timing"]["motions"] if m["start"] >= t - 1e-6]
    return min(ends, default=t)


def _gripper_geoms(model, frame: int) -> list[int]:
    """The geoms of the holding frame's parent link and everything below it (hand, fingers)."""
    top = model.body_parentid[frame] or frame
    below = set()
    for b in range(model.nbody):
        a = b
        while a > 0 and a != top:
            a = model.body_parentid[a]
        if a == top:
            below.add(b)
    return [g for g in range(model.ngeom) if model.geom_bodyid[g] in below]


def _apart(model, data, gripper, geoms) -> bool:
    import mujoco
    return all(mujoco.mj_geomDistance(model, data, a, b, LET_GO, None) >= LET_GO
               for a in gripper for b in geoms)


def _sample(data, sim, qadr, objects):
    return (round(float(data.time), 4), dict(zip(sim.joints, data.qpos[qadr].tolist())),
            {o: _pose(data, b) for o, b in objects.items()})


def _timeline(doc, names, q0):
    """Every sample of every motion in plan time (rests between motions included): times,
    positions, velocities, accelerations."""
    ts, qs, vs, accs = [], [], [], []
    for m in doc["timing"]["motions"]:
        ts += m["t"]
        qs += m["positions"]
        vs += m["velocities"]
        accs += m["accelerations"]
    if not ts:
        zero = np.zeros((1, len(names)))
        return np.array([0.0]), np.array([q0]), zero, zero
    ts = np.array(ts)
    order = np.argsort(ts, kind="stable")
    return ts[order], np.array(qs)[order], np.array(vs)[order], np.array(accs)[order]


def _pose(data, body: int) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = data.xmat[body].reshape(3, 3)
    T[:3, 3] = data.xpos[body]
    return T


def _wxyz(T: np.ndarray) -> list[float]:
    x, y, z, w = quat_from_matrix(T[:3, :3])
    return [w, x, y, z]


def _contacts(model, data, names, movable, held, found) -> None:
    """Deep contacts of the robot with a static object, and of a carried object with anything
    but the robot (``names``: body id -> name)."""
    if data.ncon == 0:
        return
    deep = np.flatnonzero(data.contact.dist[:data.ncon] < -CONTACT_DEPTH)
    for i in deep:
        c = data.contact[i]
        a = names.get(model.geom_bodyid[c.geom1], "world")
        b = names.get(model.geom_bodyid[c.geom2], "world")
        kinds = [_kind(n, movable, held) for n in (a, b)]
        unexpected = ({"robot", "static"} == set(kinds)) or (
            "carried" in kinds and "robot" not in kinds)
        if unexpected:
            key = tuple(sorted((a, b)))
            entry = found.setdefault(key, {"a": key[0], "b": key[1], "time": data.time,
                                           "depth": 0.0})
            entry["depth"] = max(entry["depth"], -float(c.dist))


def _kind(name: str, movable, held) -> str:
    if name == "world":
        return "static"
    if not name.startswith("obj:"):
        return "robot"
    obj = name[4:]
    return "carried" if obj in held else "movable" if obj in movable else "static"


def _goal(world, doc, settled) -> tuple[bool | None, list[str]]:
    """The validator's goal check at the last state with the settled object poses."""
    if world.program is None:
        return None, []
    changed = json.loads(json.dumps(doc))
    last = changed["states"][-1]
    for obj, T in settled.items():
        key = next((k for k in last.get("object_poses", {}) if k.lower() == obj.lower()), obj)
        last.setdefault("object_poses", {})[key] = {
            "translation": T[:3, 3].tolist(), "rotation": list(quat_from_matrix(T[:3, :3]))}
    report = validate_plan(world, parse_plan(SourceFile("<settled>", json.dumps(changed))))
    fails = [v.text() for v in report.violations if v.kind == "goal"]
    return not [f for f in fails if not _within_slack(f)], fails


def _within_slack(failure: str) -> bool:
    """A geometric goal atom missed by at most :data:`GOAL_SLACK` (its distance, which the
    validator's message gives) after settling still counts: an object let go at the edge of
    a predicate's band settles a few millimetres past it."""
    m = re.search(r"distance ([0-9.eE+-]+)", failure)
    try:
        return m is not None and float(m.group(1)) <= GOAL_SLACK
    except ValueError:
        return False
