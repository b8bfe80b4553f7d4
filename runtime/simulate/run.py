"""Replaying a timed plan in MuJoCo: the robot follows the timed joints, a grasp holds the object
at the frame from the pick to the release, then the world settles; the report gives each
released object's drift, unexpected contacts and whether the goal holds in the settled world."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import numpy as np

from tmpc.lang.source import SourceFile
from tmpc.runtime.plans import parse_plan
from tmpc.runtime.simulate.model import build_model, fail
from tmpc.runtime.timing import BASE_JOINTS, events
from tmpc.runtime.validate import quat_from_matrix, validate_plan

#: a drift above this fails ``--strict`` (m)
DRIFT_LIMIT = 0.01
#: contacts deeper than this are reported (m)
CONTACT_DEPTH = 0.002


@dataclass
class SimReport:
    drift: dict[str, float] = field(default_factory=dict)
    tilt: dict[str, float] = field(default_factory=dict)
    contacts: list[dict] = field(default_factory=list)
    goal_holds: bool | None = None
    goal_failures: list[str] = field(default_factory=list)
    sim_seconds: float = 0.0
    wall_seconds: float = 0.0
    settled_poses: dict[str, list[float]] = field(default_factory=dict)

    @property
    def real_time_factor(self) -> float:
        return self.sim_seconds / self.wall_seconds if self.wall_seconds > 0 else float("inf")

    def ok(self) -> bool:
        return all(d <= DRIFT_LIMIT for d in self.drift.values()) and self.goal_holds is not False

    def as_json(self) -> dict:
        return {"ok": self.ok(), "drift": self.drift, "tilt": self.tilt,
                "contacts": self.contacts, "goal_holds": self.goal_holds,
                "goal_failures": self.goal_failures, "sim_seconds": self.sim_seconds,
                "wall_seconds": round(self.wall_seconds, 4),
                "real_time_factor": round(self.real_time_factor, 2),
                "settled_poses": self.settled_poses}

    def text(self) -> str:
        lines = [f"{'ok' if self.ok() else 'FAILED'}: {len(self.drift)} released objects "
                 f"settled for the plan's {self.sim_seconds:.2f} s simulated in "
                 f"{self.wall_seconds:.2f} s ({self.real_time_factor:.1f}x real time)"]
        for name, d in sorted(self.drift.items()):
            flag = "  (> 1 cm)" if d > DRIFT_LIMIT else ""
            lines.append(f"  {name}: drift {1000 * d:.1f} mm, tilt "
                         f"{np.degrees(self.tilt[name]):.1f} deg{flag}")
        for c in self.contacts:
            lines.append(f"  contact {c['a']} - {c['b']} at {c['time']:.2f} s, "
                         f"{1000 * c['depth']:.1f} mm deep")
        if self.goal_holds is not None:
            lines.append("  goal holds after settling" if self.goal_holds else
                         "  goal no longer holds: " + "; ".join(self.goal_failures))
        return "\n".join(lines)


def simulate(world, doc: dict, settle: float = 1.0) -> SimReport:
    """Replay ``doc`` (a timed ``tmpc-plan/1`` object) in ``world`` (opened with its program
    for the goal check)."""
    import mujoco
    plan = parse_plan(SourceFile("<plan>", json.dumps(doc)))
    timing = doc["timing"]
    names = timing["joint_names"]
    if any(n in BASE_JOINTS for n in names):
        raise fail("the plan moves the mobile base, which `tmpc simulate` does not drive yet")
    model, _root, movable = build_model(world, plan.states[0].objects, plan.states[0].base)
    data = mujoco.MjData(model)
    jid = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, i): i for i in range(model.njnt)}
    missing = [n for n in names if n not in jid]
    if missing:
        raise fail(f"the robot model has no joints {missing}")
    fixed = {n: v for n, v in doc["states"][0]["joints"].items() if n in jid and n not in names}
    addr = np.array([model.jnt_qposadr[jid[n]] for n in names], int)
    vaddr = np.array([model.jnt_dofadr[jid[n]] for n in names], int)
    fixed_addr = [(model.jnt_qposadr[jid[n]], model.jnt_dofadr[jid[n]], v)
                  for n, v in fixed.items()]
    ts, qs, vs = _timeline(doc, names)
    body = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i): i for i in range(model.nbody)}
    free = {o: (model.jnt_qposadr[model.body_jntadr[body[f"obj:{o}"]]],
                model.jnt_dofadr[model.body_jntadr[body[f"obj:{o}"]]]) for o in movable}
    timeline = [e for k, s in enumerate(doc["states"]) if s.get("action") is not None
                for e in events(doc, k)]
    for q0, d0, v in fixed_addr:
        data.qpos[q0] = v
    data.qpos[addr] = qs[0]
    mujoco.mj_forward(model, data)
    held: dict[str, tuple[int, np.ndarray]] = {}
    released: dict[str, np.ndarray] = {}
    report = SimReport()
    end = float(timing["duration"]) + settle
    steps = int(np.ceil(end / model.opt.timestep))
    contacts: dict[tuple[str, str], dict] = {}
    wall = time.perf_counter()
    for _ in range(steps):
        t = data.time
        while timeline and timeline[0]["time"] <= t:
            e = timeline.pop(0)
            if e["event"] == "grasp" and e["object"] in free and e["frame"] in body:
                after = plan.states[e["state"] + 1].objects.get(e["object"])
                T_obj = after if after is not None else _pose(data, body[f"obj:{e['object']}"])
                T_frame = _pose(data, body[e["frame"]])
                held[e["object"]] = (body[e["frame"]], np.linalg.inv(T_frame) @ T_obj)
            elif e["event"] == "release" and e["object"] in held:
                held.pop(e["object"])
                released[e["object"]] = None
        for q0, d0, v in fixed_addr:
            data.qpos[q0], data.qvel[d0] = v, 0.0
        data.qpos[addr] = [np.interp(t, ts, qs[:, j]) for j in range(len(names))]
        data.qvel[vaddr] = [np.interp(t, ts, vs[:, j]) for j in range(len(names))]
        for obj, (frame, offset) in held.items():
            T = _pose(data, frame) @ offset
            q0, d0 = free[obj]
            data.qpos[q0:q0 + 3] = T[:3, 3]
            data.qpos[q0 + 3:q0 + 7] = _wxyz(T)
            data.qvel[d0:d0 + 6] = 0.0
        mujoco.mj_step(model, data)
        for obj in [o for o, p in released.items() if p is None]:
            released[obj] = _pose(data, body[f"obj:{obj}"])
        _contacts(model, data, body, movable, held, contacts)
    report.wall_seconds = time.perf_counter() - wall
    report.sim_seconds = round(data.time, 4)
    settled = {o: _pose(data, body[f"obj:{o}"]) for o in movable}
    for obj, T0 in released.items():
        T1 = settled[obj]
        report.drift[obj] = float(np.linalg.norm(T1[:3, 3] - T0[:3, 3]))
        c = (np.trace(T0[:3, :3].T @ T1[:3, :3]) - 1) / 2
        report.tilt[obj] = float(np.arccos(np.clip(c, -1.0, 1.0)))
    report.contacts = sorted(contacts.values(), key=lambda c: c["time"])
    report.settled_poses = {o: T[:3, 3].round(5).tolist() for o, T in settled.items()}
    report.goal_holds, report.goal_failures = _goal(world, doc, settled)
    return report


def _timeline(doc, names):
    """Every sample of every motion in plan time (rests between motions included)."""
    ts, qs, vs = [], [], []
    for m in doc["timing"]["motions"]:
        ts += m["t"]
        qs += m["positions"]
        vs += m["velocities"]
    if not ts:
        q0 = [doc["states"][0]["joints"].get(n, 0.0) for n in names]
        return np.array([0.0]), np.array([q0]), np.zeros((1, len(names)))
    ts = np.array(ts)
    order = np.argsort(ts, kind="stable")
    return ts[order], np.array(qs)[order], np.array(vs)[order]


def _pose(data, body: int) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = data.xmat[body].reshape(3, 3)
    T[:3, 3] = data.xpos[body]
    return T


def _wxyz(T: np.ndarray) -> list[float]:
    x, y, z, w = quat_from_matrix(T[:3, :3])
    return [w, x, y, z]


def _contacts(model, data, body, movable, held, found) -> None:
    """Deep contacts of the robot with a static object, and of a carried object with anything
    but the robot."""
    import mujoco
    names = {i: n for n, i in body.items()}
    for c in data.contact[:data.ncon]:
        if c.dist > -CONTACT_DEPTH:
            continue
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
    del mujoco


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
    return not fails, fails
