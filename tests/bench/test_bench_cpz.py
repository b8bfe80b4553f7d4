"""CPZ point-distance benchmark: batched JAX queries (points x starts in one jitted call; the
structure-specialised kernel, and the padded kernel every set shape shares) against one scipy
``least_squares`` solve per query with the same penalty continuation and starts.

Run with `pytest -m bench -s tests/bench/test_bench_cpz.py`; prints a table, asserts behaviour
only (both solvers give the same distances), never wall-clock.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.optimize import least_squares

from tmpc.compiler import cpz
from tmpc.compiler.cpz import CPZ, solve

pytestmark = pytest.mark.bench

SETS = {
    "ball (docs/math.md §C.4.2, n=3, p=4)": CPZ.ball([0.5, -0.2, 1.0], 0.3),
    "README set (§4.6, n=2, p=3)": CPZ.make(
        [0, 0], [[1, 0, 1, -1], [0, 1, 1, 1]], [[1, 0, 1, 2], [0, 1, 1, 0], [0, 0, 1, 1]],
        [[1, -0.5, 0.5]], [0.5], [[0, 1, 2], [1, 0, 0], [0, 1, 0]]),
}
STARTS = 16
RHOS = 10.0 ** np.arange(9)


def _mono_jac(a, E):
    """numpy ``m(a, E) (h,)`` and ``dm/da (h, p)``."""
    P = a[:, None] ** E
    J = np.empty((E.shape[1], len(a)))
    for k in range(len(a)):
        dk = np.where(E[k] > 0, E[k] * a[k] ** np.maximum(E[k] - 1, 0), 0.0)
        J[:, k] = dk * np.prod(np.delete(P, k, axis=0), axis=0)
    return P.prod(axis=0), J


def scipy_distance(S: CPZ, x, starts) -> float:
    """The per-query baseline: penalty continuation with bounded trf from each start."""
    best = np.inf
    for a in starts:
        for rho in RHOS:
            w = np.sqrt(rho)

            def fun(a):
                return np.concatenate([S.c + S.G @ _mono_jac(a, S.E)[0] - x,
                                       w * (S.A @ _mono_jac(a, S.R)[0] - S.b)])

            def jac(a):
                return np.vstack([S.G @ _mono_jac(a, S.E)[1], w * (S.A @ _mono_jac(a, S.R)[1])])

            a = least_squares(fun, a, jac=jac, bounds=(-1, 1), method="trf").x
        if np.linalg.norm(S.A @ _mono_jac(a, S.R)[0] - S.b) <= 1e-7:
            best = min(best, float(np.linalg.norm(S.c + S.G @ _mono_jac(a, S.E)[0] - x)))
    return best


def _points(S: CPZ, N: int) -> np.ndarray:
    lo, hi = cpz.interval_hull(S)
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    return np.random.default_rng(0).uniform(mid - 1.5 * half, mid + 1.5 * half, (N, S.n))


def _rate(S: CPZ, N: int) -> float:
    X = _points(S, N)
    cpz.distance(S, X[:300])  # warm (compile both batch sizes)
    t = time.perf_counter()
    cpz.distance(S, X, starts=STARTS)
    return N / (time.perf_counter() - t)


def test_cpz_distance_batched_vs_scipy(monkeypatch):
    rows = []
    for label, S in SETS.items():
        rates = {N: _rate(S, N) for N in (1000, 10000)}
        with monkeypatch.context() as m:
            m.setattr(solve, "unrolled_ok", lambda S: False)
            padded = _rate(S, 10000)
        X = _points(S, 100)
        starts = np.vstack([np.zeros(S.p),
                            np.random.default_rng(0).uniform(-1, 1, (STARTS - 1, S.p))])
        t = time.perf_counter()
        ref = np.array([scipy_distance(S, x, starts) for x in X])
        per_query = len(X) / (time.perf_counter() - t)
        d = cpz.distance(S, X, starts=STARTS)
        both = np.isfinite(ref) & np.isfinite(d)
        assert both.mean() > 0.9
        np.testing.assert_allclose(d[both], ref[both], atol=1e-5)
        rows.append((label, rates[1000], rates[10000], padded, per_query))
    print("\n| set | JAX batched N=1000 (queries/s) | JAX batched N=10000 (queries/s) | padded "
          "kernel N=10000 (queries/s) | scipy per query, 100 points (queries/s) | ratio to "
          "scipy (N=10000) |\n|---|---|---|---|---|---|")
    for label, r1, r2, pad, s in rows:
        print(f"| {label} | {r1:.0f} | {r2:.0f} | {pad:.0f} | {s:.1f} | {r2 / s:.0f}x |")
