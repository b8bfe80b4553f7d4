"""A timed plan as ROS ``trajectory_msgs/JointTrajectory``-shaped documents, one per motion,
with the grasp and release events between them (docs/robot-export.md); no ROS needed."""

from __future__ import annotations

import json

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_text

FORMAT = "tmpc-ros-joint-trajectory/1"


def duration_msg(seconds: float) -> dict:
    """``builtin_interfaces/Duration``: whole seconds and nanoseconds."""
    ns = int(round(seconds * 1e9))
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def duration_seconds(msg: dict) -> float:
    return msg["sec"] + msg["nanosec"] * 1e-9


def events(doc: dict, k: int) -> list[dict]:
    """What the action at state ``k`` does to the gripper: a grasp per object held after it and
    not before, a release per object held before and not after; else one plain action event."""
    states = doc["states"]
    before = (states[k].get("mode") or {}).get("held") or {}
    after = (states[k + 1].get("mode") or {}).get("held") or {} if k + 1 < len(states) else {}
    base = {"time": states[k]["t"], "state": k, "action": states[k]["action"]}
    out = [dict(base, event="grasp", object=o, frame=f) for o, f in sorted(after.items())
           if before.get(o) != f]
    out += [dict(base, event="release", object=o, frame=f) for o, f in sorted(before.items())
            if after.get(o) != f]
    return out or [dict(base, event="action")]


def ros_document(doc: dict, source: str = "") -> dict:
    """The export of a timed ``tmpc-plan/1`` object (with its ``timing`` block): ``steps`` in
    order, each a ``trajectory`` (a JointTrajectory, its ``time_from_start`` counted from the
    motion's ``start``) or an ``event`` (grasp, release, or another action)."""
    timing = doc.get("timing")
    if not isinstance(timing, dict) or any(s.get("t") is None for s in doc["states"]):
        raise InputError(error("E819", f"{source or 'the plan'} has no times", None,
                               "time it first: `tmpc time INPUT PLAN -o TIMED.json` or "
                               "`tmpc run INPUT --timed -o PLAN.json`"))
    names = list(timing["joint_names"])
    motions = {m["states"][0]: m for m in timing["motions"]}
    steps = []
    for k, state in enumerate(doc["states"]):
        m = motions.get(k)
        if m is not None:
            points = [{"positions": p, "velocities": v, "accelerations": a, "effort": [],
                       "time_from_start": duration_msg(t - m["start"])}
                      for t, p, v, a in zip(m["t"], m["positions"], m["velocities"],
                                            m["accelerations"])]
            steps.append({"type": "trajectory", "start": m["start"], "states": m["states"],
                          "trajectory": {"header": {"stamp": {"sec": 0, "nanosec": 0},
                                                    "frame_id": ""},
                                         "joint_names": names, "points": points}})
        if state.get("action") is not None:
            steps += [{"type": "event", **e} for e in events(doc, k)]
    return {"format": FORMAT, "plan": source, "duration": timing["duration"],
            "joint_names": names, "limits": timing["limits"], "steps": steps}


def write_ros(document: dict, path: str | None) -> str:
    """JSON, or YAML when ``path`` ends in .yaml/.yml; the text (written to ``path`` if any,
    atomically)."""
    yaml_out = path is not None and path.lower().endswith((".yaml", ".yml"))
    if yaml_out:
        import yaml

        class Dumper(yaml.SafeDumper):          # no &anchors: every list written out
            def ignore_aliases(self, data):
                return True
        text = yaml.dump(document, Dumper=Dumper, sort_keys=False, default_flow_style=None,
                         width=100)
    else:
        text = json.dumps(document, indent=1) + "\n"
    if path is not None:
        try:
            atomic_write_text(path, text)
        except OSError as exc:
            raise InputError(error("E828", f"cannot write {path}: {exc.strerror or exc}", None,
                                   "check that the folder exists and is writable")) from None
    return text


def total_seconds(step: dict, point: dict) -> float:
    """A trajectory point's time in the plan: the motion's start plus its time from start."""
    return step["start"] + duration_seconds(point["time_from_start"])

