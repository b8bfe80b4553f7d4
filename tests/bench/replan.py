"""Replanning benchmark (issue 41): per problem, the first plan() and three more from the start in
one process (overhead before planning, plan() total); then a 20-step loop on clutter pb_4: execute
one action, perturb the observed movable objects' positions by up to 1 cm (x, y), replan, and
validate each plan independently from its observed start.

    python tests/bench/replan.py [--loop-only] [--steps 20]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import tmpc

TMIT = Path(__file__).resolve().parents[3] / "shared" / "baselines" / "tmit-star" / "data" / \
    "problems"
PROBLEMS = [("clutter", f"clutter_pb_{i}") for i in (1, 2, 3, 4)] + \
    [("shelves", f"shelves_pb_{i}") for i in (2, 3, 4)]


def spec(family: str, name: str) -> Path:
    return TMIT / family / "problems" / f"{name}.json"


def replans(path: Path, n: int = 3) -> dict:
    t = time.perf_counter()
    world = tmpc.load(path)
    load = time.perf_counter() - t
    t = time.perf_counter()
    first = world.plan(seed=0, time_limit=60.0, first_solution=True)
    first_s = time.perf_counter() - t
    totals, overheads = [], []
    for k in range(n):
        t = time.perf_counter()
        p = world.plan(seed=k + 1, time_limit=60.0, first_solution=True)
        totals.append(time.perf_counter() - t)
        overheads.append(world.last_overhead)
        assert p.solved
    return {"load": load, "first": first_s, "solved": first.solved,
            "replan_median": statistics.median(totals),
            "overhead_median_ms": 1000 * statistics.median(overheads)}


def loop(path: Path, steps: int, seed: int = 0) -> dict:
    world = tmpc.load(path)
    rng = np.random.default_rng(seed)
    plan = world.plan(seed=0, time_limit=60.0, first_solution=True)
    assert plan.solved
    times, overheads, solved, valid = [], [], 0, 0
    for step in range(steps):
        states = plan.states
        # execute one action: the state after the first action's effects
        k = next((i + 1 for i, s in enumerate(states) if s["action"] is not None), None)
        if k is None:
            break                                   # the goal is reached
        observed = dict(states[k])
        held = set(observed["mode"]["held"])
        poses = {}
        for name, pose in observed["object_poses"].items():
            pose = {"translation": list(pose["translation"]), "rotation": pose["rotation"]}
            if name not in held and name in movable(world):
                d = rng.uniform(-1, 1, 2)
                d *= min(1.0, 0.01 / max(np.linalg.norm(d), 1e-9)) * rng.uniform(0, 1)
                pose["translation"][0] += float(d[0])
                pose["translation"][1] += float(d[1])
            poses[name] = pose
        observed["object_poses"] = poses
        t = time.perf_counter()
        plan = world.plan(seed=step + 1, time_limit=60.0, first_solution=True, start=observed)
        times.append(time.perf_counter() - t)
        overheads.append(world.last_overhead)
        if not plan.solved:
            print(f"  step {step}: no plan ({plan.explanation['summary']})", file=sys.stderr)
            break
        solved += 1
        report = world.validate(plan)           # from its own (observed) first state
        valid += report.valid
        if not report.valid:
            print(f"  step {step}: invalid: {report.summary()}", file=sys.stderr)
    return {"steps": len(times), "solved": solved, "valid": valid,
            "replan_median": statistics.median(times) if times else None,
            "overhead_median_ms": 1000 * statistics.median(overheads) if overheads else None}


def movable(world) -> set[str]:
    return {o.name for o in world.world.scene.objects if o.movable}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--loop-only", action="store_true")
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args()
    if not args.loop_only:
        for family, name in PROBLEMS:
            print(name, replans(spec(family, name)), flush=True)
    print("loop clutter_pb_4", loop(spec("clutter", "clutter_pb_4"), args.steps), flush=True)


if __name__ == "__main__":
    main()
