"""Plans as JSON (docs/plan-format.md): ``tmpc-plan/1`` objects and the bare state arrays planet
and tmit-star wrote (LEGACY.md "Outputs").

Every state lists every movable joint (continuous ones included), the base pose, every scene
object's world pose (held objects where their frame carries them) and its mode; the action is on
the state where it is executed, and the next state has the same configuration in the successor
mode.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from tmpc.compiler.state import WorldState, state_to_json
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_text

FORMAT = "tmpc-plan/1"


def action_text(action) -> str:
    """An action as plans write it (a geometric symbol's variant as the action it was made
    from)."""
    return action.name


def plan_states(problem, path) -> list[dict]:
    """State dicts for ``path`` = [(q, mode, action executed there or None)]."""
    ground = problem.ground
    out = []
    frames = problem.frames_of(np.array([q for q, _, _ in path], float).reshape(len(path), -1))
    for (q, mode, action), fr in zip(path, frames):
        state = WorldState(np.asarray(q, float), mode.poses, mode.held)
        d = state_to_json(state, problem.model, fr)
        d.pop("mode", None)
        d["action"] = action_text(action) if action is not None else None
        d["mode"] = {"atoms": ground.shown_atoms(mode.sym),
                     "held": {obj: frame for obj, (frame, _) in sorted(mode.held.items())}}
        out.append(d)
    return out


def plan_document(problem, result, *, planner: str, seed: int, input_path: str,
                  setup_seconds: float) -> dict:
    states = plan_states(problem, result.path)
    return {
        "format": FORMAT,
        "status": result.status,
        "planner": planner,
        "seed": seed,
        "input": {"path": str(input_path), "digest": file_digest(input_path)},
        "actions": [s["action"] for s in states if s["action"] is not None],
        "stats": dict(result.stats, setup_seconds=round(setup_seconds, 4)),
        "states": states,
    }


def legacy_states(doc: dict, flavour: str) -> list[dict]:
    """The bare state array of planet (action ``[name, args...]``) or tmit-star (a string)."""
    out = []
    for s in doc["states"]:
        a = s.get("action")
        if a is not None:
            name, *args = a.strip("()").split()
            # planet: [name, args...]; tmit-star: "name(arg, arg)" (FACTS: its plan printer)
            a = [name, *args] if flavour == "planet" else f"{name}({', '.join(args)})"
        out.append({"joints": s["joints"], "base_pose": s["base_pose"],
                    "object_poses": s["object_poses"], "action": a})
    return out


def file_digest(path) -> str | None:
    try:
        return "sha256:" + hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


def write_json_atomic(path, data) -> None:
    """Write JSON to ``path`` atomically (lang.fileio: never half a file, usual permissions);
    an unwritable place is E828."""
    try:
        atomic_write_text(path, json.dumps(data, indent=1) + "\n")
    except OSError as exc:
        raise InputError(error("E828", f"cannot write {path}: {exc.strerror or exc}", None,
                               "check that the folder exists and is writable")) from None
