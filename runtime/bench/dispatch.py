"""A distributed sweep: every (problem, planner, seed, parameter point) is one task on a backend
(a local process pool or Ray), results stream back as they finish.

The coordinator opens each problem once (``tmpc run``'s artifact cache compiles a run
configuration into its artifact), runs the pre-checks (a problem failing them is reported and
skipped, as in the one-process sweep), puts the artifact on the backend once, and submits the
runs the results file does not have yet (``--resume``), keeping ``workers`` in flight. Each
finished run is appended to the results file (``-o R.jsonl``) and fed to a :class:`Bench`, which
prints the table and writes ``tmpc-bench/1`` JSON (``-o R.json``) and OMPL logs as before; a
sweep over parameters labels each point's runs ``planner[name=value,...]`` there. Ctrl-C cancels
the runs in flight; every finished run is kept.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from types import SimpleNamespace

from tmpc.compiler.artifact import digest
from tmpc.compiler.export import open_for_run
from tmpc.lang.diagnostics import TmpcError
from tmpc.runtime.bench.backends import BACKENDS, LostRun
from tmpc.runtime.bench.params import param_points
from tmpc.runtime.bench.progress import Progress
from tmpc.runtime.bench.results import FINISHED, ResultsFile, run_key
from tmpc.runtime.bench.sweep import Bench
from tmpc.runtime.problem import PlanningProblem, register_run_kernels

#: seconds between checks for finished runs (and for Ctrl-C)
POLL = 0.25


class Dispatch:
    """One distributed sweep. ``run()`` returns normally or raises KeyboardInterrupt; the
    results are in ``self.bench`` (and the files) either way."""

    def __init__(self, args, planners: list[str], names: list[str], grid: dict):
        self.args = args
        self.planners, self.names = planners, names
        self.points = param_points(grid)
        self.swept = bool(grid)
        jsonl = args.output if args.output and str(args.output).endswith(".jsonl") else None
        self.results = ResultsFile(jsonl, bool(args.resume)) if jsonl else None
        labels = [label(p, q, self.swept) for p in planners for q in self.points]
        self.bench = Bench(SimpleNamespace(**{**vars(args), "output": None if jsonl else
                                              args.output}), labels, names)
        self.backend = None
        self.lost = 0

    # ---- problems ------------------------------------------------------------------------
    def prepare(self, path, name: str) -> dict | None:
        """Artifact, pre-checks and record of one problem (None: it failed, and is recorded)."""
        prec = {"name": name, "input": str(path), "error": None}
        t = time.perf_counter()
        try:
            world = open_compiled(path)
            problem = PlanningProblem(world)
            problem.check_goal_reachable()
            problem.check_start()
        except TmpcError as exc:
            self.bench.failed_problem(path, name, exc)
            return None
        art = Path(world.artifact[0])
        data = art.read_bytes()
        prec.update(digest=digest(data), artifact=str(art),
                    setup_seconds=round(time.perf_counter() - t, 4), compile_seconds=0.0,
                    dof=int(problem.model.dof), ground_actions=len(problem.ground.actions),
                    config_params=[list(p) for p in world.config.params]
                    if world.config is not None else None)
        self.bench.problems.append(prec)
        return {"prec": prec, "data": data}

    def tasks(self, prec: dict) -> list[dict]:
        out = []
        for planner in self.planners:
            for point in self.points:
                for seed in range(self.args.seeds):
                    task = {"problem": prec["name"], "input": prec["input"],
                            "digest": prec["digest"], "planner": planner, "seed": seed,
                            "params": point, "time_limit": self.args.time_limit,
                            "validate": bool(self.args.validate),
                            "config_params": prec["config_params"],
                            "output": str(self.args.output) if self.args.output else None}
                    if self.results is None or run_key(task) not in self.results.done:
                        out.append(task)
        return out

    # ---- the loop ------------------------------------------------------------------------
    def run(self) -> None:
        prepared = [p for p in (self.prepare(path, name) for path, name in
                                zip(self.args.inputs, self.names)) if p is not None]
        self._replay_resumed()
        queue = [(p, t) for p in prepared for t in self.tasks(p["prec"])]
        total_all = len(prepared) * len(self.planners) * len(self.points) * self.args.seeds
        cls = BACKENDS[self.args.backend]
        self.backend = cls(self.args.workers, getattr(self.args, "address", None),
                           getattr(self.args, "task_memory", None))
        progress = Progress(len(queue), total_all - len(queue))
        handles: dict[str, object] = {}
        try:
            queue.reverse()
            while queue or self.backend.flight:
                while queue and len(self.backend.flight) < self.backend.workers:
                    p, task = queue.pop()
                    digest = p["prec"]["digest"]
                    if digest not in handles:               # into the object store once
                        handles[digest] = self.backend.put(p["prec"]["artifact"], p["data"])
                    self.backend.submit(handles[digest], task)
                progress.running(len(self.backend.flight))
                for task, rec in self.backend.wait(POLL):
                    self.finished(task, rec, progress)
        except KeyboardInterrupt:
            self.backend.cancel()
            raise
        finally:
            progress.close()
            self.backend.close()
            if self.results is not None:
                self.results.close()

    def finished(self, task: dict, rec, progress: Progress) -> None:
        if isinstance(rec, LostRun):
            self.lost += 1
            sys.stderr.write(f"lost: {task['problem']} {task['planner']} seed {task['seed']} "
                             f"{task['params'] or ''}: {rec} (--resume runs it again)\n")
            progress.update({**task, "status": "lost"}, failed=True)
            return
        if self.results is not None:
            self.results.append(rec)
        self._feed(rec)
        progress.update(rec, failed=rec.get("status") not in FINISHED
                        or rec.get("status") == "crash" or rec.get("valid") is False)

    def _replay_resumed(self) -> None:
        """A resumed file's finished runs count in the table and the JSON too."""
        if self.results is None:
            return
        names = {p["name"] for p in self.bench.problems}
        for rec in self.results.records:
            if rec.get("problem") in names and rec.get("status") in FINISHED:
                self._feed(rec)

    def _feed(self, rec: dict) -> None:
        if rec.get("status") not in FINISHED:
            return
        row = dict(rec, planner=label(rec["planner"], rec.get("params") or {}, self.swept))
        if "solve_seconds" not in row:
            return
        self.bench.runs.append(row)
        if rec.get("reproducer"):
            self.bench.bugs.append(f"{rec['problem']} {row['planner']} seed {rec['seed']}: "
                                   f"{rec.get('error') or 'invalid plan'}\n"
                                   f"    reproduce: {rec['reproducer']}")
        if self.bench.args.output or self.bench.args.ompl_log:
            self.bench.save()


def open_compiled(path):
    """The world of ``path`` with its artifact (``world.artifact``): an artifact as it is, a run
    configuration through ``tmpc run``'s artifact cache (compiled into it when missing)."""
    world, how = open_for_run(path, register_run_kernels)
    if world.artifact is None and how == "compiled":      # just compiled: open the cache's
        world, how = open_for_run(path, register_run_kernels)
    return world


def label(planner: str, params: dict, swept: bool = True) -> str:
    """A planner at a parameter point, as the table and the OMPL log name it."""
    if not swept or not params:
        return planner
    return planner + "[" + ",".join(f"{k}={v}" for k, v in params.items()) + "]"
