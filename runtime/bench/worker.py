"""The unit of a distributed sweep: one (problem, planner, seed, parameter point) run, in a worker
process (a local pool's or a Ray task's).

:func:`run_task` takes the problem's compiled artifact (``tmpc compile``'s ``.tmpa`` bytes, or a
path to them) and the run's description, and returns the run's JSON record: :meth:`Bench.run`'s
measurements (the same code as the one-process sweep) plus the fields results files promise
(``params``, ``valid``, ``actions``, ``planning_seconds``, ``setup_seconds``, ``cost``,
``worker``). A worker keeps the problems it set up, by artifact digest, so consecutive runs on
one problem load and warm it up once (``setup_cached``). It keeps one: a sweep sends a problem's
runs together, so the previous problem and what JAX compiled for it are dropped before the next
is set up (three clutter problems in turn, warm caches: 740 MB at the third keeping them all,
713 MB dropping them). A worker's peak still grows when it compiles kernels itself (a cold
cache: XLA's compiler memory is not all given back), so a sweep's peak RSS column is the
worker's, over the problems it ran. Module-level and importable: Ray and a ``spawn`` process
pool both call it by name.
"""

from __future__ import annotations

import gc
import os
import platform
import time
from pathlib import Path
from types import SimpleNamespace

from tmpc.compiler.cache import cache_root
from tmpc.compiler.jaxcfg import configured
from tmpc.lang.diagnostics import TmpcError
from tmpc.lang.fileio import atomic_write_bytes
from tmpc.runtime.bench.sweep import Bench, build_problem

#: artifact digest -> (PlanningProblem, problem record); one worker process's problems
_PROBLEMS: dict[str, tuple] = {}
#: problems a worker keeps; the oldest set-up problem is dropped beyond this
KEEP = 1


def run_task(artifact, task: dict) -> dict:
    """Run ``task`` (keys ``problem``, ``input``, ``digest``, ``planner``, ``seed``, ``params``,
    ``time_limit``, ``validate``, ``config_params``) on ``artifact`` (bytes or a path); the
    record is JSON-able. A problem that fails to set up here gives a record with status
    ``error`` (the coordinator checked it before, so this is rare: a damaged copy)."""
    worker = f"{platform.node()}:{os.getpid()}"
    t = time.perf_counter()
    try:
        problem, prec, cached = _problem(artifact, task)
        bench = _bench(task)
        rec = bench.run(problem, prec, task["planner"], task["seed"], task.get("params") or {})
    except TmpcError as exc:
        return {**_key(task), "status": "error", "solved": False, "valid": None, "actions": [],
                "error": "; ".join(f"{d.code}: {d.message}" for d in exc.diagnostics),
                "planning_seconds": None, "setup_seconds": None, "cost": None,
                "worker": worker}
    rec.update(_key(task))
    rec.update(planning_seconds=rec.get("solve_seconds"), setup_seconds=prec["setup_seconds"],
               setup_cached=cached, dof=prec["dof"], ground_actions=prec["ground_actions"],
               worker=worker, time_limit=task["time_limit"],
               task_seconds=round(time.perf_counter() - t, 4))
    rec.setdefault("actions", [])
    rec.setdefault("valid", None)
    if "cost" not in rec:               # not anytime: the cost is the path length
        rec["cost"] = rec.get("path_length") if rec.get("solved") else None
    return rec


def _key(task: dict) -> dict:
    return {"problem": task["problem"], "planner": task["planner"], "seed": task["seed"],
            "params": dict(task.get("params") or {})}


def _bench(task: dict):
    args = SimpleNamespace(time_limit=task["time_limit"], validate=task["validate"],
                           output=task.get("output"), seeds=1, debug=False, quiet=True,
                           heuristic_bias=None)
    return Bench(args, [task["planner"]], [task["problem"]])


def _problem(artifact, task: dict):
    """The set-up problem of ``artifact`` (from this worker's cache when it has it)."""
    digest = task["digest"]
    if digest in _PROBLEMS:
        problem, prec = _PROBLEMS[digest]
        return problem, prec, True
    _drop_problems()
    path = _local_copy(artifact, digest)
    prec = {"name": task["problem"], "input": task["input"]}
    t = time.perf_counter()
    problem = build_problem(path, prec, task.get("config_params"))
    prec.update(setup_seconds=round(time.perf_counter() - t, 4), dof=int(problem.model.dof),
                ground_actions=len(problem.ground.actions))
    _PROBLEMS[digest] = (problem, prec)
    return problem, prec, False


def _drop_problems() -> None:
    """Forget all but the newest KEEP - 1 set-up problems, and what JAX compiled for them."""
    if len(_PROBLEMS) < KEEP:
        return
    while len(_PROBLEMS) >= KEEP:
        _PROBLEMS.pop(next(iter(_PROBLEMS)))
    gc.collect()
    configured().clear_caches()


def _local_copy(artifact, digest: str) -> Path:
    """A path to the artifact's bytes: the path given, else a copy in the user cache."""
    if not isinstance(artifact, (bytes, bytearray, memoryview)):
        return Path(artifact)
    path = cache_root() / "bench" / f"{digest[:32]}.tmpa"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, bytes(artifact))
    return path

