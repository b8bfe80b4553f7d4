"""The thesis's three repair experiments (§3.6), as ``tmpc repair --experiment N`` runs them on
``examples/repair/``: the model, the hidden truth, the sampling and the stopping rule of each.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.repair.loop import LoopConfig, comparable, run_loop, structurally_correct


@dataclass(frozen=True)
class Experiment:
    number: int
    #: the run manifest under examples/repair/; its hidden truth is the same name + ".truth"
    manifest: str
    sampling: str
    trials: int
    stop_unexpected: int | None
    stop_expected_run: int | None
    what: str


EXPERIMENTS = {
    1: Experiment(1, "exp1.toml", "naive", 10, 5, None,
                  "(dist obj manip 0.5) -> truth (dist obj manip 0.1), naive sampling, 5 "
                  "unexpected observations"),
    2: Experiment(2, "exp2.toml", "active", 20, 10, None,
                  "(dist 0.1) -> truth (and (dist 0.1) (roll-aligned 0.1)), active sampling, 10 "
                  "unexpected observations"),
    3: Experiment(3, "exp3.toml", "active", 20, 100, 1000,
                  "(dist 0.7) -> truth (and (dist 0.1) (roll-aligned 0.1) (empty manip)), until "
                  "100 unexpected or 1,000 expected in a row"),
}


def manifest_path(n: int, given: str | None) -> Path:
    """The experiment's manifest: ``given``, else examples/repair/ in the working directory."""
    if n not in EXPERIMENTS:
        raise InputError(error("E847", f"no experiment {n}", None, "experiments are 1, 2, 3"))
    path = Path(given) if given else Path("examples/repair") / EXPERIMENTS[n].manifest
    if not path.is_file():
        raise InputError(error("E847", f"{path}: experiment {n}'s manifest is not there", None,
                               "run from a clone of tmpc, or pass the manifest: "
                               f"tmpc repair examples/repair/{EXPERIMENTS[n].manifest} "
                               f"--experiment {n}"))
    return path


def truth_text(manifest: Path) -> str:
    path = manifest.with_suffix(".truth")
    try:
        return path.read_text(encoding="utf-8").strip()
    except OSError as exc:
        raise InputError(error("E847", f"{path}: cannot read the hidden truth: {exc.strerror}",
                               None)) from None


def run_experiment(exp: Experiment, rw, store, truth, make_source, cfg: LoopConfig, trials: int,
                   seed: int, on_event=None) -> tuple[dict, list]:
    """Run (or resume) ``trials`` trials; returns report.json's content and each trial's
    :class:`tmpc.runtime.repair.loop.LoopResult`. ``cfg``'s sampling and unexpected-observation
    limit, when set, replace the experiment's (to study them); its other stopping rule is the
    experiment's."""
    cfg = replace(cfg, sampling=cfg.sampling or exp.sampling,
                  stop_unexpected=cfg.stop_unexpected or exp.stop_unexpected,
                  stop_expected_run=exp.stop_expected_run)
    rows, results = [], []
    for k in range(trials):
        res = run_loop(rw, store, k, make_source(cfg), rw.target.start, cfg, seed + k,
                       lambda kind, x, k=k: on_event(k, kind, x) if on_event else None)
        results.append(res)
        rows.append({"seed": seed + k, "final_formula": res.formula.text(),
                     "structurally_correct": structurally_correct(res.formula, truth),
                     "param_error": comparable(res.formula, truth),
                     "edits": sum(s.edits for s in res.repairs), "unexpected": res.unexpected,
                     "loop_seconds": [round(s.seconds, 4) for s in res.repairs],
                     "loop_cpu_seconds": [round(s.cpu_seconds, 4) for s in res.repairs],
                     "observations": len(res.observations), "status": res.status})
    return {"experiment": exp.number, "truth": truth.text(), "trials": rows}, results
