"""The repair loop (thesis Fig. 3.2) and the thesis's experiments.

Each turn draws a state (naively, or by active counterexample sampling from the difference of
the last two formulas, §3.5.1), executes the action with the controller, stores the observation
(committed before use), and compares the outcome with the model. An unexpected outcome starts a
repair: the constraint hypothesis (the edit search of :mod:`tmpc.runtime.repair.search` on the
unexpected observations and as many expected ones, the nearest to the boundary, with a held-back
set for ties) and the effect hypothesis (the action applies as modelled but its effects are what was
observed) are scored in the same error, and the lower one is kept; the constraint wins ties.
Every random draw of turn ``k`` comes from ``default_rng([seed, trial, k])``, so a resumed loop
draws what an uninterrupted one would have.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from tmpc.lang.diagnostics import TmpcError
from tmpc.runtime.repair.domain import parse_truth
from tmpc.runtime.repair.model import (
    KAPPA,
    TEMPLATES,
    Features,
    Formula,
    predicts,
    signed,
)
from tmpc.runtime.repair.model import error as formula_error
from tmpc.runtime.repair.search import ZERO, ClauseGaps, Problem, anchored, search
from tmpc.runtime.repair.store import Observation, RepairStep, Store
from tmpc.runtime.repair.world import read_observations


@dataclass
class LoopConfig:
    sampling: str = "active"          # "naive" | "active"
    #: under active sampling, the probability of a naive draw anyway (§3.5.1)
    naive_probability: float = 0.2
    #: a counterexample must be this far outside the other formula (m / rad), against
    #: tolerance flip-flops at the boundary (docs/math.md §C.3c)
    margin: float = 1e-3
    #: active sampling also probes the current boundary: states inside the formula with every
    #: parameter grown by this fraction but outside it, and inside it but outside it shrunk
    probe: float = 0.25
    search_seconds: float = 10.0
    max_edits: int = 3
    stop_unexpected: int | None = None
    stop_expected_run: int | None = 1000
    max_observations: int = 5000
    time_limit: float | None = None
    #: keep the parameters at the maximum-margin fit of every observation between repairs
    #: (:func:`refit`); off: only repairs move them, as in the thesis
    refit: bool = True


@dataclass
class LoopResult:
    formula: Formula
    observations: list[Observation]
    repairs: list[RepairStep]
    status: str
    ties: list[str] = field(default_factory=list)
    #: parameter refits between repairs (:func:`refit`); ``repairs`` holds the repairs only
    refits: int = 0

    @property
    def unexpected(self) -> int:
        return sum(not o.expected for o in self.observations)


def feats_of_coords(rw, coords: list[dict]) -> Features:
    """Features straight from drawn coordinates (equal to the DSL helpers' values at the state
    built from them; tests/runtime/test_repair.py checks that)."""
    t, truth = {}, {}
    for inst in rw.cont:
        tpl = TEMPLATES[inst.name]
        vals = np.array([np.atleast_1d(c[inst.args][tpl.coords]) for c in coords], float)
        t[inst] = tpl.feature(vals)
    for inst in rw.disc:
        truth[inst] = np.array([bool(c[inst]) for c in coords])
    return Features(t, truth, np.zeros(len(coords), bool))


def _without_each(f: Formula) -> list[Formula]:
    """``f`` with one literal dropped, for each literal."""
    out = [replace(f, discrete=f.discrete[:k] + f.discrete[k + 1:])
           for k in range(len(f.discrete))]
    for c, clause in enumerate(f.clauses):
        for k in range(len(clause)):
            out.append(replace(f, clauses=f.clauses[:c] + (clause[:k] + clause[k + 1:],)
                               + f.clauses[c + 1:]))
    return out


def _differ(a: Formula, b: Formula) -> bool:
    return a.key() != b.key() or not np.allclose(a.thetas(), b.thetas())


class Sampled:
    """States drawn by the loop and executed by a controller (sim or py)."""

    recorded = False

    def __init__(self, rw, controller, cfg: LoopConfig):
        self.rw, self.controller, self.cfg = rw, controller, cfg

    def draw(self, rng, previous: Formula, current: Formula,
             rivals: tuple[Formula, ...] = ()) -> tuple[dict, str]:
        """Naive coordinates, or under active sampling a counterexample candidate: a point of
        one formula at least ``margin`` outside the other, for the last repair's old and new
        formulas and for the new one and each formula that fit the data as well (the tie a
        counterexample can break)."""
        rw, cfg = self.rw, self.cfg
        pairs = [(a, b) for r in (previous, *rivals) if _differ(r, current)
                 for a, b in ((r, current), (current, r))]
        if len(current.thetas()):
            # and the current boundary itself: just outside it, and just inside it
            th = current.thetas()
            pairs += [(current.with_thetas(th * (1 + cfg.probe)), current),
                      (current, current.with_thetas(th * (1 - cfg.probe)))]
        # and each literal's necessity: states the formula without it admits and it does not
        pairs += [(g, current) for g in _without_each(current)]
        if cfg.sampling == "active" and pairs and rng.random() >= cfg.naive_probability:
            for j in rng.permutation(len(pairs)):
                inside, other = pairs[j]
                cs = rw.clause_coords(inside, rng)
                f = feats_of_coords(rw, cs)
                hit = np.flatnonzero(predicts(inside, f) & (signed(other, f) > cfg.margin))
                if len(hit):
                    return cs[hit[0]], "active"
        return rw.naive_coords(rng), "naive"

    def next(self, seq: int, rng, previous: Formula, current: Formula,
             rivals: tuple[Formula, ...] = ()) -> Observation | None:
        coords, how = self.draw(rng, previous, current, rivals)
        state = self.rw.state(coords, rng)
        feats = self.rw.features(state)
        out = self.controller(state, feats)
        t = self.rw.target
        return Observation(t.action.name.text, tuple(t.binding.values()), state, out.success,
                           out.result, feats, True, how, seq)


class Recorded:
    """Observations read from a JSON-lines file, in order (``--observations FILE``)."""

    recorded = True
    #: lines up to this one are already in the store (a resumed run)
    skip = 0

    def __init__(self, rw, path: str):
        self.rw, self.items = rw, read_observations(path, rw)
        self.path = path

    def next(self, seq: int, rng, previous: Formula, current: Formula,
             rivals: tuple[Formula, ...] = ()) -> Observation | None:
        for n, state, success, result, bad in self.items:
            if n <= self.skip:
                continue
            try:
                feats = self.rw.features(state, "state")
            except TmpcError as exc:      # a state the world cannot read: name the line
                raise bad(exc.diagnostics[0].message) from None
            t = self.rw.target
            return Observation(t.action.name.text, tuple(t.binding.values()), state, success,
                               result, feats, True, f"file:{n}", n)
        return None


# ---------------------------------------------------------------------------------------------
# one repair


def _atoms(s: dict) -> set:
    return set((s.get("mode") or {}).get("atoms", []))


def _delta(o: Observation) -> tuple:
    """The observed effects: (atoms added, atoms deleted)."""
    a, b = _atoms(o.state), _atoms(o.result)
    return (tuple(sorted(b - a)), tuple(sorted(a - b)))


def _explains(effect: tuple, o: Observation) -> bool:
    """Whether effects ``(add, delete)`` turn the observation's state into its result."""
    return (_atoms(o.state) - set(effect[1])) | set(effect[0]) == _atoms(o.result)


def repair_once(rw, observations: list[Observation], current: Formula, rng, cfg: LoopConfig,
                effect: tuple) -> tuple[Formula, RepairStep, tuple]:
    """Repair ``current`` against every observation so far; returns the new formula, the step
    to store and the effect hypothesis in force."""
    t0, cpu0 = time.perf_counter(), time.process_time()
    feats = rw.features_of(observations)
    wrong = predicts(current, feats) != feats.success
    unexpected = list(np.flatnonzero(wrong))
    rest = np.flatnonzero(~wrong)
    # |E| = |U| expected observations, the nearest to the current boundary (ties at random);
    # held back: up to twice as many others, for tie-breaks
    sd = np.abs(signed(current, feats))[rest]
    order = rest[np.lexsort((rng.random(len(rest)), sd))]
    fit = unexpected + list(order[:len(unexpected)])
    others = order[len(unexpected):]
    held = list(rng.permutation(others)[:max(20, 2 * len(unexpected))])
    result = None
    model = anchor(rw.target.start)
    for _round in range(4):
        prob = Problem(feats.take(fit), feats.take(held) if held else feats.take([]),
                       rw.target.instances, model)
        result = search(prob, current, time_limit=cfg.search_seconds, max_edits=cfg.max_edits)
        miss = np.flatnonzero(predicts(result.best.formula, feats) != feats.success)
        new = [i for i in miss if i not in set(fit)]
        if not new:
            break
        fit = fit + new[:max(8, len(unexpected))]
        held = [i for i in held if i not in set(fit)]
    best = result.best.formula
    constraint_error = float(formula_error(best, feats))
    # effect hypothesis: the latest unexpected observation's effects are the action's
    latest = observations[unexpected[-1]] if unexpected else observations[-1]
    hyp = _delta(latest)
    applies = predicts(current, feats)
    effect_error = KAPPA ** 2 * sum(
        (not _explains(hyp, o)) if a else o.success for o, a in zip(observations, applies))
    if effect_error < constraint_error - ZERO and hyp != effect:
        kept, err, effect = current, effect_error, hyp
        hypothesis = "effects " + json.dumps({"add": list(hyp[0]), "delete": list(hyp[1])})
    else:
        kept, hypothesis, err = best, "constraint", constraint_error
    step = RepairStep(observations[-1].seq, kept.text(True), current.text(True), err,
                      hypothesis, len(best.history), result.evaluated, time.perf_counter() - t0,
                      result.trace, [c.formula.text(True) for c in result.ties[:5]],
                      time.process_time() - cpu0)
    return kept, step, effect


def anchor(model: Formula) -> dict:
    """The model's parameter of each instance it uses."""
    return {lit.instance: lit.theta for c in model.clauses for lit in c}


def refit(f: Formula, feats: Features, anchors: dict | None = None) -> Formula:
    """``f`` with each continuous parameter of its one clause moved to the middle of its
    zero-error interval over **every** observation, the others held (maximum margin; two
    sweeps, as the literals' intervals depend on each other). A repair centres the parameters
    on the observations it fits; between repairs, the expected observations that land in a
    parameter's gap narrow it too, so active sampling's probes of the boundary bisect it
    without waiting for an unexpected outcome. ``f`` itself when it has several clauses, no
    parameter, or misclassifies an observation (that is a repair's job).

    ``anchors`` (the model's parameters): a distance goes back to the model's value when the
    observations allow it, the other literals narrowed to keep every observation right
    (:func:`~tmpc.runtime.repair.search.anchored`), and one that nothing bounds from above
    goes back to it too (the least change to the model as written)."""
    th = f.thetas()
    if len(f.clauses) != 1 or not len(th) or (predicts(f, feats) != feats.success).any():
        return f
    th = th.copy()
    if anchors:
        moved = anchored(f, feats, th, anchors)
        if moved is not None:
            th = moved
    gap = ClauseGaps(f, feats)
    for _ in range(2):
        for k, lit in enumerate(f.clauses[0]):
            wins, fails = gap(k, th)
            lo_b, hi_b = lit.instance.template.bounds
            lo = max(float(wins.max()) if len(wins) else lo_b, lo_b)
            if not len(fails):
                # nothing outside restricts it: the model's value where the successes allow it
                # (the least change), else where the repair put it
                back = (anchors or {}).get(lit.instance)
                if back is not None and math.isinf(lit.instance.template.full) and back > lo:
                    th[k] = min(back, hi_b)
                continue
            hi = min(float(fails.min()), hi_b)
            if lo <= th[k] < hi:
                th[k] = (lo + hi) / 2
    return f.with_thetas(th) if not np.array_equal(th, f.thetas()) else f


def _append(a: Features | None, b: Features) -> Features:
    if a is None:
        return b
    return Features({k: np.concatenate([v, b.t[k]]) for k, v in a.t.items()},
                    {k: np.concatenate([v, b.truth[k]]) for k, v in a.truth.items()},
                    np.concatenate([a.success, b.success]))


# ---------------------------------------------------------------------------------------------
# the loop


def run_loop(rw, store: Store, trial: int, source, start: Formula, cfg: LoopConfig, seed: int,
             on_event=None) -> LoopResult:
    """Run (or resume, from what ``store`` holds for ``trial``) the repair loop."""
    scope = rw.scope
    anchors = anchor(rw.target.start)
    observations = store.observations(trial)
    steps = store.repairs(trial)
    current = parse_truth(steps[-1].formula, rw.target, scope) if steps else start
    previous = parse_truth(steps[-1].previous, rw.target, scope) if steps else start
    effect = rw.ground_effects()
    for st in steps:
        if st.hypothesis.startswith("effects "):
            got = json.loads(st.hypothesis[len("effects "):])
            effect = (tuple(got["add"]), tuple(got["delete"]))
    rivals = tuple(parse_truth(t, rw.target, scope) for t in steps[-1].ties) if steps else ()
    if source.recorded:
        source.skip = max((o.seq for o in observations), default=0)
    t0 = time.perf_counter()
    status = "observations limit"
    feats = None                 # features of every observation, kept between repairs
    run = 0
    for o in reversed(observations):
        if not o.expected:
            break
        run += 1
    def repair():
        """Repair after the latest observation; its draws come from a stream of their own, so
        a repair redone on resume (killed after the observation was stored) draws the same."""
        rng = np.random.default_rng([seed, trial, len(observations) - 1, 1])
        new, step, eff = repair_once(rw, observations, current, rng, cfg, effect)
        store.add_repair(trial, step)
        steps.append(step)
        if on_event is not None:
            on_event("repair", step)
        return current, new, tuple(parse_truth(t, rw.target, scope) for t in step.ties), eff

    def refit_after(seq: int, feats: Features) -> Formula:
        """The current formula refitted after observation ``seq`` (:func:`refit`); a move is
        stored as a step (hypothesis "refit"), so a resumed loop continues from it."""
        moved = refit(current, feats, anchors)
        if moved is not current:
            step = RepairStep(seq, moved.text(True), previous.text(True), 0.0, "refit", 0, 1,
                              0.0, [0.0], steps[-1].ties if steps else [])
            store.add_repair(trial, step)
            steps.append(step)
            if on_event is not None:
                on_event("refit", step)
        return moved

    if observations and not observations[-1].expected and \
            (not steps or steps[-1].observation != observations[-1].seq):
        previous, current, rivals, effect = repair()
    elif observations and cfg.refit and (not steps or steps[-1].observation !=
                                         observations[-1].seq):
        # killed between an expected observation and its refit: redo it (deterministic)
        current = refit_after(observations[-1].seq, rw.features_of(observations))
    while len(observations) < cfg.max_observations:
        unexpected = sum(not o.expected for o in observations)
        if cfg.stop_unexpected is not None and unexpected >= cfg.stop_unexpected:
            status = "unexpected limit"
            break
        if cfg.stop_expected_run is not None and run >= cfg.stop_expected_run:
            status = "converged"
            break
        if cfg.time_limit is not None and time.perf_counter() - t0 > cfg.time_limit:
            status = "time limit"
            break
        k = len(observations)
        rng = np.random.default_rng([seed, trial, k])
        obs = source.next(k, rng, previous, current, rivals)
        if obs is None:
            status = "observations exhausted"
            break
        f = rw.features_of([obs])
        predicted = bool(predicts(current, f)[0])
        obs.expected = predicted == obs.success and (not obs.success or _explains(effect, obs))
        store.add_observation(trial, obs)
        observations.append(obs)
        if on_event is not None:
            on_event("observation", obs)
        if obs.expected:
            run += 1
            if cfg.refit:
                feats = _append(feats, f) if feats is not None and \
                    len(feats) == len(observations) - 1 else rw.features_of(observations)
                current = refit_after(obs.seq, feats)
            continue
        run = 0
        feats = None
        previous, current, rivals, effect = repair()
    ties = steps[-1].ties if steps else []
    return LoopResult(current, observations, [s for s in steps if s.hypothesis != "refit"],
                      status, ties, sum(s.hypothesis == "refit" for s in steps))


def comparable(f: Formula, truth: Formula) -> float | None:
    """The largest parameter difference when ``f`` has ``truth``'s structure, else None."""
    if f.key() != truth.key():
        return None
    a = {lit.instance: lit.theta for c in f.clauses for lit in c}
    b = {lit.instance: lit.theta for c in truth.clauses for lit in c}
    return max((abs(a[i] - b[i]) for i in b), default=0.0)


def structurally_correct(f: Formula, truth: Formula) -> bool:
    if f.key() != truth.key():
        return False
    a = {lit.instance: lit.theta for c in f.clauses for lit in c}
    return all(abs(a[lit.instance] - lit.theta) <= TEMPLATES[lit.instance.name].tolerance
               for c in truth.clauses for lit in c)

