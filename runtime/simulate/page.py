"""The simulated motion as a viewer page: the replay's samples (robot joints, base, objects)
become the states of a plan that :mod:`tmpc.runtime.viewer` draws, played at the simulation's
own times (``tmpc simulate --html``)."""

from __future__ import annotations

import base64
import json
import math
from pathlib import Path

import numpy as np

from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_text
from tmpc.lang.source import SourceFile
from tmpc.runtime.plans import parse_plan
from tmpc.runtime.timing import BASE_JOINTS
from tmpc.runtime.validate import quat_from_matrix
from tmpc.runtime.viewer import html_page, page_data


def trace_document(doc: dict, trace) -> dict:
    """A ``tmpc-plan/1`` object whose states are the samples of ``trace`` (see
    :class:`tmpc.runtime.simulate.SimReport`): no actions, nothing held, every movable object
    where the simulation had it."""
    first = doc["states"][0]
    base0 = first.get("base_pose") or {"translation": [0.0, 0.0, 0.0],
                                       "rotation": [0.0, 0.0, 0.0, 1.0]}
    states = []
    for k, (t, joints, objects) in enumerate(trace):
        poses = dict(first.get("object_poses", {})) if k == 0 else {}
        for name, T in objects.items():
            poses[name] = {"translation": [round(float(v), 6) for v in T[:3, 3]],
                           "rotation": [round(float(v), 7) for v in quat_from_matrix(T[:3, :3])]}
        base = base0
        if all(n in joints for n in BASE_JOINTS):
            yaw = joints["base_yaw"]
            base = {"translation": [joints["base_x"], joints["base_y"],
                                    base0["translation"][2]],
                    "rotation": [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]}
        states.append({"joints": {n: v for n, v in joints.items() if n not in BASE_JOINTS},
                       "object_poses": poses, "base_pose": base, "action": None,
                       "mode": {"atoms": [], "held": {}}, "t": t})
    return {"format": "tmpc-plan/1", "status": doc.get("status", "solved"),
            "input": doc.get("input"), "states": states}


def write_sim_html(world, doc: dict, trace, path) -> int:
    """Write the page of the simulated motion to ``path`` (atomically); its size in bytes."""
    sim_doc = trace_document(doc, trace)
    plan = parse_plan(SourceFile("<simulated>", json.dumps(sim_doc)))
    src = Path(world.config.path if world.config is not None else world.scene.path)
    data = page_data(world, plan, f"tmpc simulate: {src.parent.name}/{src.name} "
                                  f"({trace[-1][0]:.1f} s simulated)")
    frames = [s["frame"] for s in data["states"]]
    times = [s[0] for s in trace]
    count = data["frames"]["count"]
    t = np.interp(np.arange(count), frames, times).astype("<f4")
    data["frames"]["t"] = base64.b64encode(t.tobytes()).decode("ascii")
    for s, tau in zip(data["states"], times):
        s["t"] = round(float(tau), 4)
    text = html_page(data)
    try:
        atomic_write_text(str(path), text)
    except OSError as exc:
        raise InputError(error("E835", f"cannot write {path}: {exc.strerror or exc}", None,
                               "check that the folder exists and is writable")) from None
    return len(text.encode("utf-8"))
