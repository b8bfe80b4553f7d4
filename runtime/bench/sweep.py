"""`tmpc bench INPUT... [--planners unified] [--seeds N] [--time-limit S] [-o RESULTS.json]
[--ompl-log RESULTS.log] [--validate]`: planners × seeds on each problem (docs/bench.md).

Each problem is loaded, checked and compiled **once** (its setup and compile seconds are reported
apart from planning); every planner × seed then runs on that compiled problem with a fresh planner
object. A run records its status, planning seconds, plan length, path length in configuration
space, the time split (the problem's timers, differenced around the run), tree size, and the
process's memory (current RSS before and after the run — growth across runs shows a leak — and
the peak RSS so far), with the load average before and after (other processes share the cores).
With ``--validate`` every solved plan is checked by the independent validator; an invalid plan is
a planner bug and is reported loudly with its reproducer.

Outputs: a markdown table on stdout (one row per problem × planner), the JSON of every run
(``-o``, ``tmpc-bench/1``, rewritten atomically after every run, so a killed sweep loses at most
the run in flight) and OMPL's benchmark log (``--ompl-log``; one experiment per file, so with
several problems one file per problem), which ``ompl_benchmark_statistics.py`` turns into the
SQLite database Planner Arena reads. Ctrl-C stops the sweep; what was collected is still written
(exit 130).

Exit codes: 0 the sweep ran; 1 bad input (nothing planned if it is found before the sweep; a
problem that fails its pre-checks in the sweep is reported and skipped); 2 usage; 70 a planner
crashed or a plan failed validation (a bug: the reproducer is printed); 130 interrupted.
"""

from __future__ import annotations

import math
import os
import platform
import resource
import sys
import tempfile
import time
import traceback
from dataclasses import asdict, is_dataclass, replace
from datetime import datetime
from pathlib import Path

import numpy as np

from tmpc.compiler.artifact import open_world
from tmpc.lang.diagnostics import InputError, TmpcError, error, render, sort_key, use_color
from tmpc.lang.fileio import atomic_write_text, unwritable
from tmpc.runtime.bench.physics import physics_record, physics_table
from tmpc.runtime.planners import make_planner
from tmpc.runtime.plans import action_text, file_digest, plan_document, write_json_atomic
from tmpc.runtime.problem import PlanningProblem
from tmpc.runtime.validate import validate_plan

FORMAT = "tmpc-bench/1"
#: the timers a run's time split reports (PlanningProblem.timers); the rest of a run is "other"
SPLIT = ("sampling", "projection", "collision", "heuristic", "compile")
#: an anytime planner's best cost is recorded at these seconds of planning
COST_TIMES = (1, 5, 10, 30, 60)
#: OMPL's planner status enum (ompl::base::PlannerStatus, in its order): a log's ``status ENUM``
#: is an index into it, so our runs mix with OMPL's own in one database
OMPL_STATUS = ("Unknown status", "Invalid start", "Invalid goal", "Unrecognized goal type",
               "Timeout", "Approximate solution", "Exact solution", "Crash", "Abort", "Infeasible")
STATUS_INDEX = {"solved": 6, "partial": 4, "interrupted": 8, "crash": 7}
MIB = 1024.0 * 1024.0


class Stop(Exception):
    """Ctrl-C reached a planner (it returned ``interrupted``): end the sweep."""


def check_output(path) -> None:
    """An output file must be writable before hours of planning are spent (E830)."""
    why = unwritable(path)
    if why:
        raise InputError(error("E830", f"cannot write {path}: {why}", None))


def problem_names(inputs) -> list[str]:
    """A short name per input (its file stem, or its folder's name for a ``run.toml`` in a folder
    of its own, as examples/lagriffoul/<instance>/run.toml; made unique; no whitespace: OMPL's
    log reader takes the experiment name as one token)."""
    out: list[str] = []
    for path in inputs:
        p = Path(path)
        stem = p.parent.name if p.name == "run.toml" and p.parent.name else p.stem
        base = "_".join(stem.split()) or "problem"
        name, k = base, 2
        while name in out:
            name, k = f"{base}-{k}", k + 1
        out.append(name)
    return out


# ---- the sweep -----------------------------------------------------------------------------------
class Bench:
    """Runs and records a sweep; ``doc`` is the JSON written with ``-o``."""

    def __init__(self, args, planners: list[str], names: list[str]):
        self.args = args
        self.planners = planners
        self.names = names
        self.debug = bool(getattr(args, "debug", False))
        self.interrupted = False
        self.bugs: list[str] = []          # reproducers of crashes and invalid plans
        self.errors = 0                    # problems that failed their pre-checks
        self.t0 = time.perf_counter()
        self.problems: list[dict] = []
        self.runs: list[dict] = []
        self.options: dict[str, dict] = {}
        self.started = datetime.now().replace(microsecond=0).isoformat()
        self.load_start = list(os.getloadavg())

    # ---- one problem -------------------------------------------------------------------------
    def problem(self, path, name: str, problem=None) -> None:
        """Set up ``path`` (or use the given compiled ``problem``) and run every planner × seed."""
        rec = {"name": name, "input": str(path), "digest": file_digest(path), "error": None,
               "load_before": list(os.getloadavg())}
        t0 = time.perf_counter()
        if problem is None:
            problem = build_problem(path, rec)
        rec.update(setup_seconds=round(time.perf_counter() - t0, 4),
                   compile_seconds=round(problem.timers.compile, 4),
                   dof=int(problem.model.dof), ground_actions=len(problem.ground.actions),
                   rss_after_setup_mib=round(rss_mib(), 1),
                   peak_rss_after_setup_mib=round(peak_rss_mib(), 1), seconds=None)
        self.problems.append(rec)
        sys.stderr.write(f"{name}: setup {rec['setup_seconds']:.1f} s (compile "
                         f"{rec['compile_seconds']:.1f} s), {rec['dof']} dof, "
                         f"{rec['ground_actions']} ground actions\n")
        try:
            for planner in self.planners:
                for seed in range(self.args.seeds):
                    run = self.run(problem, rec, planner, seed)
                    self.runs.append(run)
                    self.save()
                    if run["status"] == "interrupted" or run.get("interrupted"):
                        raise Stop     # Ctrl-C, even one that landed as the goal was found
        finally:
            rec["seconds"] = round(time.perf_counter() - t0, 4)
            rec["load_after"] = list(os.getloadavg())

    def failed_problem(self, path, name: str, exc) -> None:
        """A problem whose pre-checks failed: diagnostics on stderr, recorded, sweep goes on."""
        for d in sorted(exc.diagnostics, key=sort_key):
            sys.stderr.write(render(d, exc.files, use_color(sys.stderr)) + "\n\n")
        self.errors += 1
        self.problems.append({"name": name, "input": str(path), "error": "; ".join(
            f"{d.code}: {d.message}" for d in exc.diagnostics)})
        self.save()

    # ---- one run -----------------------------------------------------------------------------
    def run(self, problem, prec: dict, planner: str, seed: int, params: dict | None = None) -> dict:
        """One planner × seed on a set-up problem; ``params`` are planner overrides (a sweep's
        point), recorded when given."""
        rec: dict = {"problem": prec["name"], "planner": planner, "seed": seed}
        if params is not None:
            rec["params"] = dict(params)
        overrides = {"heuristic_bias": getattr(self.args, "heuristic_bias", None)}
        overrides.update(params or {})
        algo = make_planner(planner, problem, seed, overrides)
        opt = getattr(algo, "opt", None)
        if is_dataclass(opt):
            self.options.setdefault(planner, asdict(opt))
        timers0 = dict(vars(problem.timers))
        rec["rss_before_mib"] = round(rss_mib(), 1)
        rec["load_before"] = list(os.getloadavg())
        t = time.perf_counter()
        try:
            result = algo.solve(self.args.time_limit)
        except Exception as exc:                       # a crash is data; the sweep goes on
            if self.debug:
                raise
            rec.update(status="crash", solved=False, error=repr(exc),
                       traceback=traceback.format_exc(),
                       solve_seconds=round(time.perf_counter() - t, 4))
            self._memory(rec)
            self._bug(rec, prec, f"crashed: {exc!r}")
            return rec
        wall = time.perf_counter() - t
        self._memory(rec)
        s = result.stats
        split = {k: round(vars(problem.timers).get(k, 0.0) - timers0.get(k, 0.0), 4)
                 for k in SPLIT}
        split["other"] = round(max(0.0, wall - sum(split.values())), 4)
        Q = np.array([q for q, _, _ in result.path]) if result.path else np.zeros((0, 0))
        length = float(np.linalg.norm(problem.difference(Q[1:], Q[:-1]), axis=-1).sum()) \
            if len(Q) > 1 else 0.0
        rec.update(
            status=result.status, solved=result.status == "solved",
            interrupted=bool(s.get("interrupted")),
            solve_seconds=round(wall, 4), search_seconds=s.get("seconds"),
            shortcut_seconds=s.get("shortcut_seconds"),
            actions=[action_text(a) for _, _, a in result.path if a is not None],
            states=len(result.path), path_length=round(length, 4), time=split,
            nodes=s.get("nodes"), modes=s.get("modes"), transitions=s.get("transitions"),
            iterations=s.get("iterations"), counts={k: v for k, v in s.items()
                                                    if isinstance(v, (int, float))})
        rec["n_actions"] = len(rec["actions"])
        trace = s.get("cost_trace")
        if trace is not None:                          # an anytime planner
            rec["first_solution_seconds"] = s.get("first_solution_seconds")
            rec["cost"] = s.get("cost")
            rec["cost_trace"] = trace
            rec["cost_at"] = {str(t): cost_at(trace, t) for t in COST_TIMES
                              if t <= self.args.time_limit}
        rec["valid"] = None
        if self.args.validate and rec["solved"]:
            self._validate(problem, prec, result, rec)
        if getattr(self.args, "simulate", False) and rec["solved"]:
            rec["physics"] = physics_record(problem.world, plan_document(
                problem, result, planner=planner, seed=seed, input_path=prec["input"],
                setup_seconds=prec.get("setup_seconds", 0)))
        if not getattr(self.args, "quiet", False):
            self._progress(rec)
        return rec

    def _memory(self, rec: dict) -> None:
        rec["rss_after_mib"] = round(rss_mib(), 1)
        rec["peak_rss_mib"] = round(max(peak_rss_mib(), rec["rss_after_mib"]), 1)
        rec["load_after"] = list(os.getloadavg())

    def _validate(self, problem, prec: dict, result, rec: dict) -> None:
        doc = plan_document(problem, result, planner=rec["planner"], seed=rec["seed"],
                            input_path=prec["input"], setup_seconds=prec.get("setup_seconds", 0))
        t = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix="tmpc-bench-") as d:
            plan = Path(d) / "plan.json"
            write_json_atomic(plan, doc)
            try:
                report = validate_plan(problem.world, str(plan))
                rec["valid"] = report.valid
                rec["violations"] = [v.text() for v in report.violations[:10]]
                # released objects not resting on a support: valid unless --strict, but the
                # suite's target is none (docs/benchmarks.md)
                rec["warnings"] = [f"W830: {w.text()}" for w in report.warnings[:10]]
            except TmpcError as exc:                   # the planner wrote a malformed plan
                rec["valid"] = False
                rec["violations"] = [f"{d.code}: {d.message}" for d in exc.diagnostics]
                rec["warnings"] = []
        rec["validate_seconds"] = round(time.perf_counter() - t, 4)
        if not rec["valid"]:
            kept = self._keep_plan(doc, rec, "invalid")
            self._bug(rec, prec, "INVALID PLAN: " + "; ".join(rec["violations"][:3])
                      + (f" (plan kept in {kept})" if kept else ""))
        elif rec["warnings"]:          # valid, but the warning must stay checkable later
            self._keep_plan(doc, rec, "warned")

    def _keep_plan(self, doc: dict, rec: dict, kind: str) -> str | None:
        """An invalid plan, or a valid one with warnings, is evidence: keep it beside the
        results (else in a temp directory)."""
        name = f"{kind}-{rec['problem']}-{rec['planner']}-{rec['seed']}.plan.json"
        try:
            base = Path(self.args.output).parent if self.args.output else \
                Path(tempfile.mkdtemp(prefix="tmpc-bench-"))
            write_json_atomic(base / name, doc)
            rec["plan_file"] = str(base / name)
            return rec["plan_file"]
        except (OSError, TmpcError):      # E828 from the write
            return None

    def _bug(self, rec: dict, prec: dict, what: str) -> None:
        repro = (f"tmpc run {prec['input']} --planner {rec['planner']} --seed {rec['seed']} "
                 f"--time-limit {self.args.time_limit:g}")
        rec["reproducer"] = repro
        self.bugs.append(f"{rec['problem']} {rec['planner']} seed {rec['seed']}: {what}\n"
                         f"    reproduce: {repro}")
        sys.stderr.write(f"\n*** BUG: {self.bugs[-1]}\n\n")

    def _progress(self, rec: dict) -> None:
        v = {None: "", True: ", valid", False: ", INVALID"}[rec["valid"]]
        sys.stderr.write(f"  {rec['problem']} {rec['planner']} seed {rec['seed']}: "
                         f"{rec['status']} in {rec['solve_seconds']:.2f} s, "
                         f"{rec['n_actions']} actions, {rec['nodes']} nodes{v}; "
                         f"RSS {rec['rss_after_mib']:.0f} MiB\n")

    # ---- outputs -----------------------------------------------------------------------------
    def document(self, status: str) -> dict:
        return {
            "format": FORMAT,
            "status": status,
            "command": self.command(),
            "settings": {"planners": self.planners, "seeds": self.args.seeds,
                         "time_limit": self.args.time_limit, "validate": bool(self.args.validate)},
            "host": host_info(),
            "started": self.started,
            "seconds": round(time.perf_counter() - self.t0, 2),
            "load": {"start": self.load_start, "now": list(os.getloadavg())},
            "planner_options": self.options,
            "problems": self.problems,
            "runs": self.runs,
            "summary": self.summary(),
            "bugs": self.bugs,
        }

    def command(self) -> list[str]:
        """The command line that reproduces this sweep (outputs left out)."""
        a = self.args
        return ["tmpc", "bench", *map(str, a.inputs), "--planners", ",".join(self.planners),
                "--seeds", str(a.seeds), "--time-limit", f"{a.time_limit:g}",
                *(["--validate"] if a.validate else []),
                *(["--simulate"] if getattr(a, "simulate", False) else [])]

    def save(self, status: str = "running") -> None:
        if self.args.output:
            write_json_atomic(self.args.output, self.document(status))
        if self.args.ompl_log:
            self.write_ompl_logs()

    def finish(self) -> None:
        self.save("interrupted" if self.interrupted else "complete")
        if self.args.output:
            sys.stderr.write(f"wrote {self.args.output}\n")
        for path in self.ompl_log_paths().values():
            sys.stderr.write(f"wrote {path}\n")
        for b in self.bugs:
            sys.stderr.write(f"*** BUG: {b}\n")

    def ompl_log_paths(self) -> dict[str, Path]:
        """Log file per problem: the given path for one input, else ``STEM-NAME.SUFFIX``."""
        if not self.args.ompl_log:
            return {}
        p = Path(self.args.ompl_log)
        done = [r["name"] for r in self.problems if not r.get("error")]
        if len(self.names) == 1:
            return {n: p for n in done}
        return {n: p.with_name(f"{p.stem}-{n}{p.suffix or '.log'}") for n in done}

    def write_ompl_logs(self) -> None:
        recs = {r["name"]: r for r in self.problems}
        for name, path in self.ompl_log_paths().items():
            runs = [r for r in self.runs if r["problem"] == name]
            atomic_write_text(path, ompl_log(recs[name], runs, self.planners, self.options,
                                             self.args, self.started))

    def summary(self) -> list[dict]:
        rows = []
        for prec in self.problems:
            for planner in self.planners:
                # a run cut short by Ctrl-C measured nothing: it is in the JSON and the log,
                # not in the statistics
                runs = [r for r in self.runs if r["problem"] == prec["name"]
                        and r["planner"] == planner and r["status"] != "interrupted"]
                if runs:
                    rows.append(summarize(prec, planner, runs, self.args.time_limit))
        return rows

    def table(self) -> str:
        physics = physics_table(self.runs)
        return markdown_table(self.summary(), self.args.time_limit) + (
            "\n" + physics if physics else "")


def build_problem(path, rec: dict, config_params=None):
    """Load, check and compile a problem once (`tmpc run`'s pre-checks; TmpcError if bad).
    ``config_params``: the run configuration's planner parameters, for an artifact (which keeps
    the problem, not the configuration's ``[planner]`` section)."""
    t = time.perf_counter()
    world = open_world(path)
    if config_params is not None and world.config is not None:
        world.config = replace(world.config, params=tuple(tuple(p) for p in config_params))
    rec["load_seconds"] = round(time.perf_counter() - t, 4)
    problem = PlanningProblem(world)
    problem.check_goal_reachable()
    problem.check_start()
    rec["warm_up_seconds"] = round(problem.warm_up(np.random.default_rng(0)), 4)
    return problem


# ---- statistics ----------------------------------------------------------------------------------
def quantile(values: list[float], q: float) -> float:
    """Linear-interpolation quantile; ``inf`` (an unsolved run) propagates where it weighs."""
    v = sorted(values)
    if not v:
        return math.nan
    pos = q * (len(v) - 1)
    lo, hi = math.floor(pos), math.ceil(pos)
    if lo == hi or v[lo] == v[hi]:
        return v[lo]
    if math.isinf(v[hi]):
        return math.inf
    return v[lo] + (v[hi] - v[lo]) * (pos - lo)


def summarize(prec: dict, planner: str, runs: list[dict], limit: float) -> dict:
    """One table row. Times count an unsolved run as infinitely long (a median above the limit
    means fewer than half solved); plan and path lengths are over solved runs; the time split is
    the mean share of each activity in a run's planning time."""
    solved = [r for r in runs if r["solved"]]
    # an anytime planner runs to the limit: its time is that of its first solution
    times = [r.get("first_solution_seconds") or r["solve_seconds"] if r["solved"] else math.inf
             for r in runs]
    finished = [r for r in runs if r["status"] != "crash" and r.get("solve_seconds")]
    shares = {k: round(float(np.mean([r["time"][k] / r["solve_seconds"] for r in finished])), 4)
              if finished else None for k in (*SPLIT, "other")}
    rss = [r["rss_after_mib"] for r in runs]
    return {
        "problem": prec["name"], "planner": planner, "runs": len(runs), "solved": len(solved),
        "success_rate": round(len(solved) / len(runs), 4),
        "median_seconds": _num(quantile(times, 0.5)),
        "q1_seconds": _num(quantile(times, 0.25)), "q3_seconds": _num(quantile(times, 0.75)),
        "median_actions": _num(float(np.median([r["n_actions"] for r in solved]))
                               if solved else math.nan),
        "median_path_length": _num(float(np.median([r["path_length"] for r in solved]))
                                   if solved else math.nan),
        "time_shares": shares,
        "setup_seconds": prec.get("setup_seconds"),
        "peak_rss_mib": max(r["peak_rss_mib"] for r in runs),
        "rss_growth_mib": round(rss[-1] - runs[0]["rss_before_mib"], 1),
        "validated": sum(r.get("valid") is not None for r in runs),
        "invalid": sum(r.get("valid") is False for r in runs),
        "crashed": sum(r["status"] == "crash" for r in runs),
        "mean_load": round(float(np.mean([r["load_before"][0] for r in runs])), 2),
        "median_cost_at": ({t: _num(quantile([math.inf if r["cost_at"].get(t) is None
                                              else r["cost_at"][t] for r in runs], 0.5))
                            for t in runs[0]["cost_at"]} if "cost_at" in runs[0] else None),
    }


def cost_at(trace: list, t: float) -> float | None:
    """The best cost found within ``t`` seconds of planning (None: no solution yet)."""
    got = [c for s, c in trace if s <= t]
    return min(got) if got else None


def _num(x: float):
    """JSON has no inf/nan: None for an undefined value, the string "inf" above the limit."""
    if math.isnan(x):
        return None
    return "inf" if math.isinf(x) else round(x, 4)


def markdown_table(rows: list[dict], limit: float) -> str:
    def t(x):
        return "—" if x is None else (f"> {limit:g}" if x == "inf" else f"{x:.2f}")

    head = ("| problem | planner | solved | median time (s) | IQR (s) | median actions | "
            "median path length | time split: sampling / projection / collision / heuristic / "
            "compile / other (%) | setup (s) | peak RSS (MiB) | RSS growth (MiB) | invalid | "
            "load |")
    lines = [head, "|" + "---|" * head.count(" | ") + "---|"]
    for r in rows:
        sh = r["time_shares"]
        split = " / ".join("—" if sh[k] is None else f"{100 * sh[k]:.0f}"
                           for k in (*SPLIT, "other"))
        ma = "—" if r["median_actions"] is None else f"{r['median_actions']:g}"
        pl = "—" if r["median_path_length"] is None else f"{r['median_path_length']:.1f}"
        inv = f"{r['invalid']}/{r['validated']}" if r["validated"] else "not checked"
        if r["crashed"]:
            inv += f", {r['crashed']} crashed"
        setup = "—" if r["setup_seconds"] is None else f"{r['setup_seconds']:.1f}"
        lines.append(f"| {r['problem']} | {r['planner']} | {r['solved']}/{r['runs']} | "
                     f"{t(r['median_seconds'])} | {t(r['q1_seconds'])}–{t(r['q3_seconds'])} | "
                     f"{ma} | {pl} | {split} | {setup} | {r['peak_rss_mib']:.0f} | "
                     f"{r['rss_growth_mib']:+.0f} | {inv} | {r['mean_load']:.1f} |")
    anytime = [r for r in rows if r.get("median_cost_at")]
    if anytime:
        times = list(anytime[0]["median_cost_at"])
        lines += ["", "| problem | planner | " + " | ".join(
            f"median cost at {t} s" for t in times) + " |",
            "|---|---|" + "---|" * len(times)]
        for r in anytime:
            lines.append(f"| {r['problem']} | {r['planner']} | " + " | ".join(
                "—" if r["median_cost_at"].get(t) in (None, "inf") else
                f"{r['median_cost_at'][t]:.2f}" for t in times) + " |")
    return "\n".join(lines)


# ---- OMPL's benchmark log ------------------------------------------------------------------------
#: per-run properties: (name as OMPL's log spells it, type, value from a run record). Names follow
#: OMPL's own where the meaning is the same (`time` is the search, `simplification time` the rest
#: of the solve call: Planner Arena adds them for the total; `memory` is the RSS growth in MiB).
RUN_PROPERTIES = (
    ("time", "REAL", lambda r: r.get("search_seconds", r.get("solve_seconds"))),
    ("simplification time", "REAL",
     lambda r: None if r.get("search_seconds") is None
     else max(0.0, r["solve_seconds"] - r["search_seconds"])),
    ("memory", "REAL", lambda r: r["rss_after_mib"] - r["rss_before_mib"]),
    ("status", "ENUM", lambda r: STATUS_INDEX.get(r["status"], 0)),
    ("solved", "BOOLEAN", lambda r: r["solved"]),
    ("correct solution", "BOOLEAN", lambda r: r.get("valid")),
    ("solution length", "REAL", lambda r: r.get("path_length") if r["solved"] else None),
    ("solution segments", "INTEGER", lambda r: r["states"] - 1 if r["solved"] else None),
    ("plan actions", "INTEGER", lambda r: r.get("n_actions") if r["solved"] else None),
    ("graph states", "INTEGER", lambda r: r.get("nodes")),
    ("modes", "INTEGER", lambda r: r.get("modes")),
    ("transitions", "INTEGER", lambda r: r.get("transitions")),
    ("iterations", "INTEGER", lambda r: r.get("iterations")),
    ("seed", "INTEGER", lambda r: r["seed"]),
    *((f"{k} time", "REAL", (lambda k: lambda r: r["time"][k] if "time" in r else None)(k))
      for k in (*SPLIT, "other")),
    ("peak rss", "REAL", lambda r: r["peak_rss_mib"]),
    ("rss before", "REAL", lambda r: r["rss_before_mib"]),
    ("rss after", "REAL", lambda r: r["rss_after_mib"]),
    ("load before", "REAL", lambda r: r["load_before"][0]),
    ("load after", "REAL", lambda r: r["load_after"][0]),
    ("validation time", "REAL", lambda r: r.get("validate_seconds")),
)


def _log_value(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, int):
        return str(v)
    v = float(v)
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf"
    return format(v, ".9g")


def ompl_log(prec: dict, runs: list[dict], planners: list[str], options: dict, args,
             started: str) -> str:
    """One problem's runs in OMPL's benchmark log format (docs/bench.md lists the grammar)."""
    host = host_info()
    exp_props = [("dof", "INTEGER", prec.get("dof")),
                 ("ground_actions", "INTEGER", prec.get("ground_actions")),
                 ("setup_seconds", "REAL", prec.get("setup_seconds")),
                 ("compile_seconds", "REAL", prec.get("compile_seconds")),
                 ("cpus", "INTEGER", host["cpus"]),
                 ("load_before", "REAL", prec.get("load_before", [None])[0]),
                 ("load_after", "REAL", (prec.get("load_after") or [None])[0])]
    exp_props = [(n, t, v) for n, t, v in exp_props if v is not None]
    setup = [f"input {prec['input']}", f"digest {prec.get('digest')}",
             f"seeds 0..{args.seeds - 1}", f"validate {bool(args.validate)}"]
    cpu = [f"{host['cpu']}", f"{host['cpus']} cpus", f"python {host['python']}"]
    total = prec.get("seconds") or 0.0
    out = [f"tmpc version {host['tmpc']}",
           f"Experiment {prec['name']}",
           f"{len(exp_props)} experiment properties",
           *(f"{n} {t} = {_log_value(v)}" for n, t, v in exp_props),
           f"Running on {'_'.join(host['hostname'].split()) or 'UNKNOWN'}",
           f"Starting at {started}",
           "<<<|", *setup, "|>>>",
           "<<<|", *cpu, "|>>>",
           "0 is the random seed",
           f"{args.time_limit:g} seconds per run",
           "0 MB per run",
           f"{args.seeds} runs per planner",
           f"{_log_value(total)} seconds spent to collect the data",
           "1 enum type",
           "status|" + "|".join(OMPL_STATUS)]
    done = [p for p in planners if any(r["planner"] == p for r in runs)]
    out.append(f"{len(done)} planners")
    for p in done:
        common = sorted((options.get(p) or {}).items())
        mine = [r for r in runs if r["planner"] == p]
        props = sorted(RUN_PROPERTIES, key=lambda x: x[0])
        out += [p, f"{len(common)} common properties",
                *(f"{k} = {v}" for k, v in common),
                f"{len(props)} properties for each run",
                *(f"{n} {t}" for n, t, _ in props),
                f"{len(mine)} runs",
                *("".join(_log_value(get(r)) + "; " for _, _, get in props) for r in mine),
                "."]
    return "\n".join(out) + "\n"


# ---- the machine ---------------------------------------------------------------------------------
def rss_mib() -> float:
    """Current resident set size (MiB): /proc/self/statm, else the peak."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / MIB
    except (OSError, ValueError, IndexError):
        return peak_rss_mib()


def peak_rss_mib() -> float:
    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kib / (1024.0 * 1024.0 if sys.platform == "darwin" else 1024.0)


_HOST: dict | None = None


def host_info() -> dict:
    global _HOST
    if _HOST is None:
        from importlib.metadata import PackageNotFoundError, version
        cpu = platform.processor() or platform.machine()
        try:
            with open("/proc/cpuinfo") as f:
                cpu = next((ln.split(":", 1)[1].strip() for ln in f
                            if ln.startswith("model name")), cpu)
        except OSError:
            pass
        try:
            tmpc = version("tmpc")
        except PackageNotFoundError:
            tmpc = "unknown"
        _HOST = {"hostname": platform.node(), "cpu": cpu, "cpus": os.cpu_count(),
                 "python": platform.python_version(), "tmpc": tmpc}
    return _HOST


__all__ = ["Bench", "ompl_log", "summarize", "markdown_table", "quantile"]
