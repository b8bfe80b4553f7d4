"""Algorithm 2 (thesis §3.5): an anytime edit search over formulas, with the continuous
parameters re-optimised by gradient after every edit.

- **Edits**: add a literal (to a clause, or a discrete one), remove one, replace one by another
  instance, add or remove a clause. A search explores edits breadth-first to ``max_edits`` deep,
  keeping the ``beam`` lowest-error formulas of each depth, and stops at the first depth with a
  formula of (near) zero error, or when its time is up (the best so far is the answer).
- **Parameters**: L-BFGS-B on the error, its gradient from JAX (:func:`_objective`: one jitted
  function for every formula, whose structure enters as masks, so the search compiles once per
  observation-count bucket), from a few starts. The error is flat wherever nothing is
  misclassified, so each parameter is then moved to the middle of its zero-error interval (a
  maximum-margin tie-break: between the nearest observations of each outcome).
- **Ties** between formulas of equal error go to the lower error on held-back observations, then
  to the smaller change (a replacement counts as a removal and an addition, and so does a new
  clause: a repair keeps what the data does not contradict), then to the smaller formula; the
  ties are reported for a person to choose from.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
from scipy.optimize import minimize

from tmpc.compiler.jaxcfg import configured
from tmpc.runtime.repair.model import KAPPA, Features, Formula, Instance, Literal, error, predicts

#: an error this small counts as zero (squared metres/radians: 1e-4 mm^2)
ZERO = 1e-10
MAX_CLAUSES = 3


@dataclass(frozen=True)
class Candidate:
    formula: Formula
    error: float
    held_error: float
    edits: int
    #: how far its parameters are from the model's (relative to each template's range)
    deviation: float = 0.0

    def rank(self) -> tuple:
        return (round(self.error, 12), round(self.held_error, 12), self.changes,
                round(self.deviation, 9), self.formula.size)

    @property
    def changes(self) -> int:
        """How much the formula was changed: a replacement is a removal and an addition, and a
        new clause (a new disjunct of the set) counts as much."""
        return sum(2 if h.startswith(("replace", "add clause")) else 1
                   for h in self.formula.history)


@dataclass
class SearchResult:
    best: Candidate
    #: other formulas as good as the best on the data (equal error and held-back error)
    ties: list[Candidate]
    evaluated: int
    seconds: float
    #: best error after each evaluated edit (the thesis's error-over-edits curve)
    trace: list[float]


# ---------------------------------------------------------------------------------------------
# the objective in JAX: formulas as masks over a fixed instance table


@lru_cache(maxsize=None)
def _objective():
    jax = configured()
    import jax.numpy as jnp

    def err(theta, T, D, success, valid, member, active, pos, neg):
        # theta, member: (C, I); T: (N, I); D: (N, J) 0/1; pos/neg: (J,) literal present
        over = jnp.maximum(T[:, None, :] - theta[None], 0.0) ** 2           # (N, C, I)
        sq = jnp.sum(jnp.where(member[None], over, 0.0), axis=2)           # (N, C)
        sq = jnp.where(active[None], sq, jnp.inf)
        gap = jnp.where(member[None], jnp.maximum(theta[None] - T[:, None, :], 0.0), KAPPA)
        inner = jnp.minimum(jnp.min(gap, axis=2), KAPPA)                   # (N, C)
        inner = jnp.where(active[None] & (sq <= 0), inner, 0.0)
        viol = jnp.sum(jnp.where(pos[None], 1.0 - D, 0.0) + jnp.where(neg[None], D, 0.0), axis=1)
        out_sq = jnp.min(sq, axis=1) + KAPPA ** 2 * viol
        geo_in = jnp.max(inner, axis=1)
        e = jnp.where(success, out_sq, jnp.where(out_sq > 0, 0.0, geo_in) ** 2)
        return jnp.sum(jnp.where(valid, e, 0.0))

    return jax.jit(jax.value_and_grad(err))


class Problem:
    """The observations of one repair and the instances formulas may use, as padded arrays."""

    def __init__(self, feats: Features, held: Features, instances: list[Instance],
                 anchor: dict | None = None):
        self.feats, self.held = feats, held
        #: the model's own parameter of each instance it uses (where a parameter that nothing
        #: bounds from above goes back to: the least change to the model as written)
        self.anchor = dict(anchor or {})
        self.cont = sorted(i for i in instances if not i.discrete)
        self.disc = sorted(i for i in instances if i.discrete)
        n = len(feats)
        pad = 1 << max(4, (n - 1).bit_length())
        self.T = np.zeros((pad, max(1, len(self.cont))))
        for k, inst in enumerate(self.cont):
            self.T[:n, k] = feats.t[inst]
        self.D = np.zeros((pad, max(1, len(self.disc))))
        for k, inst in enumerate(self.disc):
            self.D[:n, k] = feats.truth[inst]
        self.success = np.zeros(pad, bool)
        self.success[:n] = feats.success
        self.valid = np.arange(pad) < n
        self.col = {inst: k for k, inst in enumerate(self.cont)}
        self.dcol = {inst: k for k, inst in enumerate(self.disc)}

    def masks(self, f: Formula):
        C, I = MAX_CLAUSES, self.T.shape[1]
        member = np.zeros((C, I), bool)
        active = np.zeros(C, bool)
        where = []
        for c, clause in enumerate(f.clauses):
            active[c] = True
            for lit in clause:
                member[c, self.col[lit.instance]] = True
                where.append((c, self.col[lit.instance]))
        pos = np.zeros(self.D.shape[1], bool)
        neg = np.zeros(self.D.shape[1], bool)
        for lit in f.discrete:
            (pos if lit.positive else neg)[self.dcol[lit.instance]] = True
        return member, active, pos, neg, where

    def value_and_grad(self, f: Formula, thetas: np.ndarray, masks) -> tuple[float, np.ndarray]:
        member, active, pos, neg, where = masks
        theta = np.zeros(member.shape)
        for (c, i), t in zip(where, thetas):
            theta[c, i] = t
        v, g = _objective()(theta, self.T, self.D, self.success, self.valid, member, active,
                            pos, neg)
        g = np.asarray(g)
        return float(v), np.array([g[c, i] for c, i in where])


def optimise(prob: Problem, f: Formula) -> Formula:
    """``f`` with its parameters at a minimum of the error, centred in their zero-error range."""
    x0 = f.thetas()
    if not len(x0):
        return f
    lits = [lit for c in f.clauses for lit in c]
    bounds = [lit.instance.template.bounds for lit in lits]
    masks = prob.masks(f)
    fun = lambda x: prob.value_and_grad(f, x, masks)                     # noqa: E731
    best_x, best_v = x0, fun(x0)[0]
    starts = [x0, x0 * 0.5, np.array([(lo + hi) / 4 for lo, hi in bounds])]
    for s in starts:
        if best_v <= ZERO:
            break
        r = minimize(fun, np.clip(s, *np.array(bounds).T), jac=True, method="L-BFGS-B",
                     bounds=bounds, options={"maxiter": 200})
        if r.fun < best_v - ZERO:
            best_x, best_v = r.x, float(r.fun)
    x = np.asarray(best_x, float)
    if best_v > ZERO:
        x = _sweep(prob, f, x, bounds)
    return simplify(f.with_thetas(_centre(prob, f, x, bounds)))


def simplify(f: Formula) -> Formula:
    """``f`` without the literals that hold everywhere (an angle band as wide as the angle's
    range): they change no prediction, and a person should not have to read them."""
    clauses = tuple(tuple(lit for lit in c if lit.theta < lit.instance.template.full)
                    for c in f.clauses)
    if all(clauses) or len(clauses) == 1:
        return replace(f, clauses=clauses)
    return replace(f, clauses=((),))     # a clause that holds everywhere: so does the DNF


def _cuts(prob: Problem, lit: Literal, lo: float, hi: float) -> np.ndarray:
    t = np.unique(np.clip(prob.feats.t[lit.instance], lo, hi))
    return np.concatenate([[lo], t, [hi]])


def _sweep(prob: Problem, f: Formula, x: np.ndarray, bounds, sweeps: int = 3) -> np.ndarray:
    """Coordinate descent with an exact line search: the error is piecewise in each parameter
    with breaks at the feature values, and L-BFGS-B can stop at a kink of it; trying every
    piece's ends and middle of one parameter at a time finds what the gradient missed."""
    lits = [lit for c in f.clauses for lit in c]
    best = float(error(f, prob.feats, x))
    for _ in range(sweeps):
        before = best
        for k, lit in enumerate(lits):
            cuts = _cuts(prob, lit, *bounds[k])
            trial = np.unique(np.concatenate([cuts, (cuts[:-1] + cuts[1:]) / 2,
                                              np.clip(cuts - 1e-9, *bounds[k]),
                                              np.clip(cuts + 1e-9, *bounds[k])]))
            for v in trial:
                y = x.copy()
                y[k] = v
                e = float(error(f, prob.feats, y))
                if e < best - ZERO:
                    best, x = e, y
        if best <= ZERO or best >= before - ZERO:
            break
    return x


class ClauseGaps:
    """A one-clause formula's literal k against ``feats``, the others held at parameters ``y``:
    the feature values of literal k over the successes and the failures the discrete literals
    and the other literals let through (its zero-error interval lies between them)."""

    def __init__(self, f: Formula, feats: Features):
        self.feats = feats
        self.holds = np.ones(len(feats), bool)
        for lit in f.discrete:
            self.holds &= feats.truth[lit.instance] == lit.positive
        self.T = [feats.t[lit.instance] for lit in f.clauses[0]]

    def __call__(self, k: int, y) -> tuple[np.ndarray, np.ndarray]:
        others = self.holds.copy()
        for j, t in enumerate(self.T):
            if j != k:
                others &= t <= y[j]
        ok = self.feats.success
        return self.T[k][others & ok], self.T[k][others & ~ok]


def deviation(f: Formula, anchor: dict) -> float:
    """How far ``f``'s parameters are from the model's (``anchor``), each difference over its
    template's range: the repair that keeps the model's values where the data allows ranks
    first among formulas as good and as small a change."""
    return sum(abs(lit.theta - anchor[lit.instance]) / lit.instance.template.bounds[1]
               for c in f.clauses for lit in c if lit.instance in anchor)


def anchored(f: Formula, feats: Features, th: np.ndarray, anchor: dict) -> np.ndarray | None:
    """Parameters of a one-clause ``f`` that classify every observation of ``feats`` right with
    each unbounded parameter the model has (a distance) at the model's value, the others
    narrowed to exclude the failures that then need them; None when there are none.

    A clause {t_k <= theta_k} is right iff each theta_k is at least the successes' t_k and each
    failure has some t_k above its theta_k. Coordinate-wise centring (:func:`_centre`, the
    loop's refit) keeps whichever corner of that staircase the search reached: after earlier
    repairs shrank a distance to explain failures that a new literal now explains, a shrunk
    distance and a wide band, where the model's distance and a narrow band explain them too.
    """
    if len(f.clauses) != 1 or not len(th):
        return None
    lits = f.clauses[0]
    pin = [lit.instance in anchor and math.isinf(lit.instance.template.full) for lit in lits]
    if not any(pin) or all(pin):
        return None
    gap = ClauseGaps(f, feats)
    y = np.asarray(th, float).copy()
    for k, lit in enumerate(lits):
        if pin[k]:
            y[k] = anchor[lit.instance]
    for _ in range(2):
        for k, lit in enumerate(lits):
            if pin[k]:
                continue
            wins, fails = gap(k, y)
            lo = float(wins.max()) if len(wins) else lit.instance.template.bounds[0]
            hi = float(fails.min()) if len(fails) else math.inf
            if lo >= hi:
                return None
            if not lo <= y[k] < hi:
                y[k] = (lo + min(hi, lit.instance.template.bounds[1])) / 2
    g = f.with_thetas(y)
    return y if (predicts(g, feats) == feats.success).all() else None


def _centre(prob: Problem, f: Formula, x: np.ndarray, bounds) -> np.ndarray:
    """Move each parameter to the middle of the interval around it where the error stays at
    its value (the error only changes where a feature value crosses the parameter); a clause
    that classifies every observation right first moves to the model's distances where it can
    (:func:`anchored`)."""
    x = x.copy()
    feats = prob.feats
    lits = [lit for c in f.clauses for lit in c]
    if prob.anchor and error(f, feats, x) <= ZERO:
        y = anchored(f, feats, x, prob.anchor)
        if y is not None:
            x = y
    for k, lit in enumerate(lits):
        base = error(f, feats, x)
        lo, hi = bounds[k]
        cuts = _cuts(prob, lit, lo, hi)
        # the error is piecewise in theta with breaks at the feature values: test every piece's
        # midpoint, then grow the interval of pieces around x[k] that keep the error
        mids = (cuts[:-1] + cuts[1:]) / 2
        ok = []
        for m in mids:
            y = x.copy()
            y[k] = m
            ok.append(error(f, feats, y) <= base + 1e-12)
        j = int(np.clip(np.searchsorted(cuts, x[k]) - 1, 0, len(mids) - 1))
        if not ok[j]:
            continue
        a = b = j
        while a > 0 and ok[a - 1]:
            a -= 1
        while b < len(mids) - 1 and ok[b + 1]:
            b += 1
        full = lit.instance.template.full
        if b == len(mids) - 1 and hi >= full:
            x[k] = full      # nothing above restricts it: the literal holds everywhere
        elif b == len(mids) - 1 and math.isinf(full):
            # nothing above restricts it, and the feature has no end (a distance): it goes back
            # to the model's value (else stays where the formula had it), the least change, not
            # halfway to the search bound. A parameter shrunk to explain failures that another
            # literal now explains is thus not left at its shrunk value.
            x[k] = max(prob.anchor.get(lit.instance, x[k]), (cuts[a] + cuts[a + 1]) / 2)
        else:
            x[k] = (cuts[a] + cuts[b + 1]) / 2
    return x


# ---------------------------------------------------------------------------------------------
# edits


def _initial(prob: Problem, f: Formula, inst: Instance, clause: tuple[Literal, ...]) -> float:
    """A new literal's first parameter: just wide enough for the successes the clause holds."""
    feats = prob.feats
    trial = replace(f, clauses=(clause,))
    admitted = predicts(trial, feats)
    inside = admitted & feats.success
    lo, hi = inst.template.bounds
    if inside.any():
        return float(min(hi, feats.t[inst][inside].max() * 1.01 + 1e-6))
    return float(min(hi, max(lo, np.median(feats.t[inst][admitted]) if admitted.any()
                             else hi / 4)))


def edits(prob: Problem, f: Formula):
    """(description, formula) for every single edit of ``f``."""
    used_disc = {lit.instance for lit in f.discrete}
    for inst in prob.disc:
        if inst not in used_disc:
            for positive in (True, False):
                lit = Literal(inst, None, positive)
                yield (f"add {lit.text()}", replace(f, discrete=f.discrete + (lit,)))
    for k, lit in enumerate(f.discrete):
        yield (f"remove {lit.text()}", replace(f, discrete=f.discrete[:k] + f.discrete[k + 1:]))
    for c, clause in enumerate(f.clauses):
        present = {lit.instance for lit in clause}

        def put(new_clause, c=c):
            return replace(f, clauses=f.clauses[:c] + (new_clause,) + f.clauses[c + 1:])
        for inst in prob.cont:
            if inst not in present:
                lit = Literal(inst, _initial(prob, f, inst, clause))
                yield (f"add {lit.instance.text()}", put(clause + (lit,)))
        for k, lit in enumerate(clause):
            rest = clause[:k] + clause[k + 1:]
            if rest or len(f.clauses) == 1:
                yield (f"remove {lit.instance.text()}", put(rest))
            for inst in prob.cont:
                if inst not in present:
                    new = Literal(inst, _initial(prob, f, inst, rest))
                    yield (f"replace {lit.instance.text()} by {inst.text()}",
                           put(rest[:k] + (new,) + rest[k:]))
        if len(f.clauses) > 1:
            yield (f"remove clause {c + 1}", replace(f, clauses=f.clauses[:c] + f.clauses[c + 1:]))
    if len(f.clauses) < MAX_CLAUSES:
        outside_success = ~predicts(f, prob.feats) & prob.feats.success
        for inst in prob.cont:
            t = prob.feats.t[inst][outside_success]
            theta = float(t.max() * 1.01) if len(t) else inst.template.bounds[1] / 4
            yield (f"add clause {inst.text()}",
                   replace(f, clauses=f.clauses + ((Literal(inst, theta),),)))


def search(prob: Problem, start: Formula, *, time_limit: float = 10.0, max_edits: int = 3,
           beam: int = 3) -> SearchResult:
    """The best formula within ``max_edits`` edits of ``start`` (anytime: the best found when
    the time is up)."""
    t0 = time.perf_counter()

    def evaluate(f: Formula, edits_made: int) -> Candidate:
        f = optimise(prob, f)
        held = float(error(f, prob.held)) if len(prob.held) else 0.0
        return Candidate(f, float(error(f, prob.feats)), held, edits_made,
                         deviation(f, prob.anchor))

    first = evaluate(start, 0)
    seen = {first.formula.key()}
    everything = [first]
    trace = [first.error]
    level = [first]
    for depth in range(1, max_edits + 1):
        if min(c.error for c in everything) <= ZERO or time.perf_counter() - t0 > time_limit:
            break
        nxt = []
        for cand in level:
            for what, f in edits(prob, cand.formula):
                if f.key() in seen or f.size == 0:
                    continue
                seen.add(f.key())
                c = evaluate(replace(f, history=cand.formula.history + (what,)), depth)
                nxt.append(c)
                everything.append(c)
                trace.append(min(trace[-1], c.error))
                if time.perf_counter() - t0 > time_limit:
                    break
            if time.perf_counter() - t0 > time_limit:
                break
        level = heapq.nsmallest(beam, nxt, key=Candidate.rank)
        if not level:
            break
    ranked = sorted(everything, key=Candidate.rank)
    best = ranked[0]
    ties = [c for c in ranked[1:] if c.error <= best.error + ZERO
            and c.held_error <= best.held_error + ZERO][:5]
    return SearchResult(best, ties, len(everything), time.perf_counter() - t0, trace)
