"""`tmpc repair`: repair an action's geometric precondition from observed executions
(docs/repair.md).

    tmpc repair INPUT --action NAME (--controller sim:TRUTH | --controller py:MOD:FN |
                                     --observations FILE) --db STORE [--resume] [--write]
    tmpc repair [INPUT] --experiment N [--trials T] --report DIR [--db STORE] [--resume]
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from tmpc.compiler.artifact import open_world
from tmpc.compiler.compile import compile_world
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.fileio import atomic_write_text
from tmpc.lang.source import SourceFile
from tmpc.runtime.cli.exits import EXIT_OK
from tmpc.runtime.repair import (
    EXPERIMENTS,
    LoopConfig,
    PyController,
    Recorded,
    RepairWorld,
    Sampled,
    SimController,
    Store,
    diff,
    manifest_path,
    parse_truth,
    rewrite,
    run_experiment,
    run_loop,
    target,
    truth_text,
    write_report,
)


def _say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _setup(path, action: str):
    world = open_world(path)
    if world.program is None or world.program.problem is None:
        raise InputError(error("E585", "`tmpc repair` needs a run configuration (domain, "
                               "problem and scene)", None))
    compiled = compile_world(world)
    if compiled.model is None:
        raise InputError(error("E584", "the scene has no robot to execute the action", None))
    t = target(world.program, action, lambda name: compiled.model.frame(name) is not None)
    return world, RepairWorld(world, compiled, t)


def _meta(rw, extra: str) -> dict:
    t = rw.target
    return {"domain": t.domain_name, "action": t.ground,
            "parameters": " ".join(f"{p.name.text}" for p in t.action.params), "run": extra}


def _fresh_or_resume(store: Store, resume: bool) -> None:
    if store.trials() and not resume:
        raise InputError(error("E849", f"{store.path} already holds observations", None,
                               "pass --resume to continue from them, or give a new --db"))


def _config(args) -> LoopConfig:
    default = "active" if args.experiment is None else None     # experiments: the thesis's
    return LoopConfig(sampling=args.sampling or default, search_seconds=args.search_seconds,
                      max_edits=args.max_edits, stop_unexpected=args.stop_unexpected,
                      stop_expected_run=args.stop_expected,
                      max_observations=args.max_observations, time_limit=args.time_limit,
                      refit=args.refit)


def _progress(kind: str, x, trial: int | None = None) -> None:
    if kind != "repair":
        return
    head = f"trial {trial}: " if trial is not None else ""
    shown = re.sub(r"\d+\.\d{5,}", lambda m: f"{float(m.group()):.4f}", x.formula)
    _say(f"{head}repair after observation {x.observation}: {shown}  "
         f"[{x.hypothesis}, error {x.error:.3g}, {x.edits} edits, {x.evaluated} formulas, "
         f"{x.seconds:.2f} s]")


def run_repair(args) -> int:
    if args.experiment is not None:
        return _experiment(args)
    if args.input is None or args.action is None:
        raise InputError(error("E846", "`tmpc repair` needs INPUT and --action (or "
                               "--experiment N)", None))
    if (args.controller is None) == (args.observations is None):
        raise InputError(error("E846", "give one of --controller sim:TRUTH, --controller "
                               "py:MODULE:FUNCTION or --observations FILE", None))
    if args.db is None:
        raise InputError(error("E846", "--db STORE is needed: every observation is kept there",
                               None, "e.g. --db repair.sqlite"))
    world, rw = _setup(args.input, args.action)
    scope = world.program.scope
    cfg = _config(args)
    if args.observations is not None:
        source, how = Recorded(rw, args.observations), f"observations {args.observations}"
    else:
        kind, _, spec = args.controller.partition(":")
        if kind == "sim":
            text = Path(spec[1:]).read_text(encoding="utf-8") if spec.startswith("@") else spec
            controller = SimController(rw, parse_truth(text, rw.target, scope))
        elif kind == "py":
            controller = PyController(rw, spec)
        else:
            raise InputError(error("E846", f"--controller {args.controller}: the kinds are "
                                   "sim:TRUTH and py:MODULE:FUNCTION", None))
        source, how = Sampled(rw, controller, cfg), args.controller
    with Store(args.db, _meta(rw, how)) as store:
        _fresh_or_resume(store, args.resume)
        res = run_loop(rw, store, 0, source, rw.target.start, cfg, args.seed, _progress)
    print(f"repaired precondition of {rw.target.ground}: {res.formula.text()}")
    print(f"  {len(res.observations)} observations, {res.unexpected} unexpected, "
          f"{len(res.repairs)} repairs; stopped: {res.status}")
    for tie in res.ties:
        print(f"  as good on the data: {tie}")
    domain_path = str(world.program.domain.span.path)
    src = SourceFile(domain_path, Path(domain_path).read_text(encoding="utf-8"))
    new = rewrite(src, rw.target, res.formula)
    patch = diff(domain_path, src.text, new)
    print(patch or "  (the domain already says this)", end="" if patch else "\n")
    if args.write and patch:
        atomic_write_text(domain_path, new)
        print(f"wrote {domain_path}")
    if args.report:
        truth = controller.truth if args.controller and args.controller.startswith("sim:") \
            else res.formula
        report = {"experiment": None, "truth": truth.text(), "trials": []}
        write_report(args.report, report, [res], truth,
                     lambda text: parse_truth(text, rw.target, scope))
    return EXIT_OK


def _experiment(args) -> int:
    exp = EXPERIMENTS.get(args.experiment)
    manifest = manifest_path(args.experiment, args.input)
    if args.report is None:
        raise InputError(error("E846", "--experiment needs --report DIR", None))
    world, rw = _setup(manifest, "pick")
    scope = world.program.scope
    truth = parse_truth(truth_text(manifest), rw.target, scope)
    trials = args.trials or exp.trials
    cfg = _config(args)
    db = args.db or str(Path(args.report) / "store.sqlite")
    Path(args.report).mkdir(parents=True, exist_ok=True)
    _say(f"experiment {exp.number}: {exp.what}; {trials} trials, store {db}"
         + (f" (stopping at {args.stop_unexpected} unexpected)" if args.stop_unexpected else ""))
    with Store(db, _meta(rw, f"experiment {exp.number}")) as store:
        _fresh_or_resume(store, args.resume)
        report, results = run_experiment(
            exp, rw, store, truth, lambda c: Sampled(rw, SimController(rw, truth), c),
            cfg, trials, args.seed, lambda k, kind, x: _progress(kind, x, k))
    files = write_report(args.report, report, results, truth,
                         lambda text: parse_truth(text, rw.target, scope))
    ok = sum(r["structurally_correct"] for r in report["trials"])
    print(f"experiment {exp.number}: {ok}/{trials} trials structurally correct")
    for r in report["trials"]:
        pe = "—" if r["param_error"] is None else f"{r['param_error']:.4f}"
        print(f"  seed {r['seed']}: {r['final_formula']}  (parameter error {pe}, "
              f"{r['unexpected']} unexpected, {r['observations']} observations)")
    for f in files:
        print(f"wrote {f}")
    return EXIT_OK

