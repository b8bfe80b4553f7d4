"""`tmpc run INPUT [--planner NAME] [--seed N] [--time-limit S] [-o plan.json] [--html plan.html]`.

Loads the world (run configuration or artifact), grounds and compiles the problem, checks that it
can be planned at all (start collision-free, every object of the geometric atoms in the scene,
the goal relaxed-reachable), runs the planner and writes the plan (docs/plan-format.md). Exit 0
with a plan; exit 3 when the time limit or Ctrl-C came first — the best progress is still
written, with status ``partial``.
"""

from __future__ import annotations

import sys
import time

import numpy as np

EXIT_OK, EXIT_NOT_FOUND = 0, 3
DEFAULT_TIME_LIMIT = 120.0

#: planners by name: (factory(problem, seed, args) -> object with .solve(time_limit, progress),
#: one-line description)
PLANNERS = {
    "unified": "composite-space RRT with the Algorithm 1 sampler (thesis ch. 2, planet)",
}


def make_planner(name: str, problem, seed: int, args):
    from tmpc.lang.diagnostics import InputError, error
    if name == "unified":
        from .unified import UnifiedOptions, UnifiedPlanner
        params = dict(problem.world.config.params) if problem.world.config else {}
        bias = args.heuristic_bias if getattr(args, "heuristic_bias", None) is not None \
            else params.get("coin_bias", UnifiedOptions.heuristic_bias)
        if not 0.0 <= bias <= 1.0:
            raise InputError(error("E825", f"heuristic bias {bias} must be within [0, 1]", None))
        opts = UnifiedOptions(heuristic_bias=float(bias),
                              gamma=float(params.get("success_scale", UnifiedOptions.gamma)),
                              goal_weight=float(params.get("goal_weight",
                                                           UnifiedOptions.goal_weight)))
        return UnifiedPlanner(problem, seed=seed, options=opts)
    raise InputError(error("E826", f"unknown planner `{name}`", None,
                           "planners: " + ", ".join(sorted(PLANNERS))))


def plan_problem(input_path, planner: str = "unified", seed: int = 0, time_limit: float = 120.0,
                 args=None, progress=None):
    """Load (``input_path``: a path or a loaded :class:`World`), check and plan; returns
    (problem, result, setup seconds)."""
    from .tmp_problem import TmpProblem
    from .world import World, load_world
    t0 = time.perf_counter()
    world = input_path if isinstance(input_path, World) else load_world(input_path)
    problem = TmpProblem(world)
    problem.check_goal_reachable()
    problem.check_start()
    algo = make_planner(planner, problem, seed, args)
    problem.warm_up(np.random.default_rng(seed))
    setup = time.perf_counter() - t0
    result = algo.solve(time_limit, progress)
    return problem, result, setup


def run_run(args) -> int:
    from .plan_output import legacy_states, plan_document, write_json_atomic
    from .world import load_world
    world = load_world(args.input)
    # the command line wins; else the configuration's time limit and output (planet's TOML
    # `timeout`/`output`, a manifest's [planner] time_limit/output); else 120 s and no file
    config = world.config
    time_limit = args.time_limit if args.time_limit is not None else \
        (config.time_limit if config is not None and config.time_limit else DEFAULT_TIME_LIMIT)
    output = args.output or (str(config.output) if config is not None and config.output
                             else None)
    if not time_limit > 0:
        sys.stderr.write("tmpc run: the time limit must be > 0\n")
        return 2
    progress = None if args.quiet or not sys.stderr.isatty() else _Progress(time_limit)
    problem, result, setup = plan_problem(world, args.planner, args.seed, time_limit, args,
                                          progress)
    if progress is not None:
        progress.done()
    doc = plan_document(problem, result, planner=args.planner, seed=args.seed,
                        input_path=args.input, setup_seconds=setup)
    if output:
        data = legacy_states(doc, args.legacy_output) if args.legacy_output else doc
        write_json_atomic(output, data)
    if args.html or args.png:
        from .viewer import write_html, write_png
        if args.html:
            write_html(problem.world, doc, args.html)
        if args.png:
            write_png(problem.world, doc, args.png)
    _report(doc, result, setup)
    return EXIT_OK if result.status == "solved" else EXIT_NOT_FOUND


def _report(doc, result, setup: float) -> None:
    s = result.stats
    w = sys.stderr.write
    if result.status == "solved":
        w(f"solved: {len(doc['actions'])} actions, {len(doc['states'])} states in "
          f"{s['seconds']:.2f} s of planning ({setup:.2f} s setup)\n")
        for a in doc["actions"]:
            w(f"  {a}\n")
    else:
        w(f"no plan ({result.status}) after {s['seconds']:.2f} s; best progress: "
          f"{len(doc['actions'])} actions toward the goal\n")
    t = s["time"]
    w(f"nodes {s['nodes']}, modes {s['modes']}, transitions {s['transitions']}; time: "
      + ", ".join(f"{k} {v:.2f} s" for k, v in t.items()) + "\n")


class _Progress:
    """One status line on stderr, refreshed at most twice a second."""

    def __init__(self, limit: float):
        self.limit, self.t0, self.last = limit, time.perf_counter(), 0.0

    def __call__(self, planner) -> None:
        now = time.perf_counter()
        if now - self.last < 0.5:
            return
        self.last = now
        sys.stderr.write(f"\r  {now - self.t0:6.1f}/{self.limit:.0f} s  nodes "
                         f"{len(planner.node_mode):6d}  modes {len(planner.modes):4d}  "
                         f"transitions {planner.counts['transitions']:4d}\033[K")
        sys.stderr.flush()

    def done(self) -> None:
        sys.stderr.write("\r\033[K")
