"""`tmpc bench --simulate`: each solved plan timed (toppra) and replayed in MuJoCo, so a run's
record gains a ``physics`` entry and the summary a physics table (docs/physics.md)."""

from __future__ import annotations

import math
import time
from collections import defaultdict

import numpy as np

from tmpc.lang.diagnostics import TmpcError
from tmpc.runtime.simulate import simulate
from tmpc.runtime.timing import time_world_plan


def physics_record(world, doc: dict) -> dict:
    """Time ``doc`` (a ``tmpc-plan/1`` object, changed in place) and replay it: settled (the
    ``--strict`` verdict), drifts, tilt, tracking error, speeds; ``error`` when it cannot."""
    t = time.perf_counter()
    try:
        block = time_world_plan(world, doc)
        report = simulate(world, doc)
    except TmpcError as exc:
        return {"settled": None,
                "error": "; ".join(f"{d.code}: {d.message}" for d in exc.diagnostics)}
    ms = block["ms_per_motion"]
    return {"settled": report.ok(), "goal_holds": report.goal_holds,
            "max_drift": round(report.max_drift, 5),
            "drift": {k: round(v, 5) for k, v in report.drift.items()},
            "max_tilt": round(max(report.tilt.values(), default=0.0), 5),
            "max_displaced": round(max(report.displaced.values(), default=0.0), 5),
            "unstable": report.unstable,
            "max_tracking": round(report.max_tracking, 5), "contacts": len(report.contacts),
            "sim_seconds": report.sim_seconds, "wall_seconds": round(report.wall_seconds, 4),
            "real_time_factor": round(report.real_time_factor, 2), "motions": len(ms),
            "max_ms_per_motion": round(max(ms, default=0.0), 3),
            "median_ms_per_motion": round(float(np.median(ms)), 3) if ms else None,
            "seconds": round(time.perf_counter() - t, 3)}


def physics_table(recs: list[dict]) -> str:
    """A Markdown row per problem and planner of the runs with a ``physics`` entry ("" when
    none has one): settled plans, the largest and the median drift, the largest tilt, the
    median real-time factor and the timing's milliseconds per motion."""
    rows = defaultdict(list)
    for r in recs:
        if isinstance(r.get("physics"), dict):
            rows[(r["problem"], r["planner"])].append(r["physics"])
    if not rows:
        return ""
    lines = ["| problem | planner | settled | max drift mm | median drift mm | max tilt ° | "
             "median real-time factor | timing ms per motion (median / max) |",
             "|---|---|---|---|---|---|---|---|"]

    def med(xs):
        xs = [x for x in xs if x is not None]
        return float(np.median(xs)) if xs else math.nan

    for (problem, planner), ps in sorted(rows.items()):
        done = [p for p in ps if p.get("settled") is not None]
        drifts = [d for p in done for d in p["drift"].values()]
        f = (lambda x, k=1: "—" if math.isnan(x) else f"{x:.{k}f}")
        lines.append(
            f"| {problem} | {planner} | {sum(p['settled'] for p in done)}/{len(ps)} | "
            f"{f(1000 * max(drifts, default=math.nan))} | {f(1000 * med(drifts))} | "
            f"{f(math.degrees(max((p['max_tilt'] for p in done), default=math.nan)))} | "
            f"{f(med([p['real_time_factor'] for p in done]))} | "
            f"{f(med([p['median_ms_per_motion'] for p in done]), 2)} / "
            f"{f(max((p['max_ms_per_motion'] for p in done), default=math.nan), 2)} |")
    return "\n".join(lines) + "\n"
