"""Containment, distance, sampling, support and emptiness of CPZs (docs/math.md §C.3), in JAX
with x64.

Every query is one jitted solve over points x starts. The Levenberg-Marquardt solve behind
containment and distance is specialised to the set's structure when it is small (its exponent
matrices are static, so each lane is an unrolled scalar program XLA fuses, well above the
padded kernel's rate); other sets and the other solves use vmapped kernels whose shapes are
padded to power-of-two buckets (at least 4; padded factors, generators and constraints are zero
and change nothing), so calls with other sets reuse compiled code. Points go in batches of
``SMALL`` or ``CHUNK``. JAX is configured and loaded on the first query
(:mod:`tmpc.compiler.jaxcfg`), not at import; z3 is loaded by :func:`is_empty` only.
"""

from __future__ import annotations

from fractions import Fraction
from functools import lru_cache

import numpy as np

from tmpc.compiler.cpz.sets import CPZ, dependent, interval_hull
from tmpc.compiler.jaxcfg import configured

#: penalty weights of the continuation, 1, 10, ..., 1e8 (§3b)
RHOS = 10.0 ** np.arange(9)
#: Levenberg-Marquardt iterations per penalty weight (warm-started from the previous weight)
ITERS = 10
#: a start is feasible when its final ||h|| is at most this (§3b)
H_FEASIBLE = 1e-7
#: the two batch sizes of a compiled call (few sizes, few compiles): small queries, and chunks
SMALL, CHUNK = 8, 256
#: coarse grid and bisection steps per ray of :func:`inner_distance`; the exit is located to
#: diameter / 16 / 2**13 (the midpoint of the last interval), ~1e-5 of the set's size; a gap
#: narrower than diameter / 16 can be stepped over
GRID, BISECT = 16, 12


def _bucket(k: int, least: int = 4) -> int:
    return max(least, 1 << max(0, int(k) - 1).bit_length())


def monomials(alpha, E):
    """``m(alpha, E) (..., h)`` for ``alpha (..., p)`` and an integer ``E (p, h)``. An integer E
    keeps jacfwd finite at alpha_k = 0 (a float exponent 0 gives 0 * inf)."""
    jnp = configured().numpy
    return jnp.prod(jnp.asarray(alpha)[..., :, None] ** jnp.asarray(E), axis=-2)


def f(S: CPZ, alpha):
    """``c + G m(alpha, E)`` for ``alpha (..., p)`` (GI not included: pass ``dependent(S)`` and
    alpha with the GI factors appended to include it)."""
    return monomials(alpha, S.E) @ S.G.T + S.c


def h(S: CPZ, alpha):
    """The constraint residual ``A m(alpha, R) - b (..., m)``."""
    return monomials(alpha, S.R) @ S.A.T - S.b


def _padded(S: CPZ, G=None, c=None, A=None, b=None):
    """The arrays ``(c, G, E, A, b, R)`` of a GI-free S padded to the buckets; ``G``, ``c``,
    ``A`` and ``b`` may be replaced by same-shaped arrays."""
    n, p, hh, m, q = map(_bucket, (S.n, S.p, S.h, S.m, S.q))
    out = []
    for v, shape, dtype in ((S.c if c is None else c, (n,), float),
                            (S.G if G is None else G, (n, hh), float), (S.E, (p, hh), np.int64),
                            (S.A if A is None else A, (m, q), float),
                            (S.b if b is None else b, (m,), float), (S.R, (p, q), np.int64)):
        z = np.zeros(shape, dtype)
        z[tuple(slice(0, k) for k in v.shape)] = v
        out.append(z)
    return tuple(out)


def _starts(S: CPZ, starts: int, seed: int) -> np.ndarray:
    """``(starts, p_bucket)``: alpha = 0, then uniform draws in the box from ``seed``."""
    out = np.zeros((starts, _bucket(S.p)))
    out[1:, :S.p] = np.random.default_rng(seed).uniform(-1, 1, (starts - 1, S.p))
    return out


def _chunked(fn, rows: np.ndarray, *args):
    """``fn(rows_chunk, *args)`` over chunks of ``rows`` padded (with zeros) to a bucket; the
    outputs (tuples of arrays with a leading chunk axis) concatenated and cut to ``len(rows)``."""
    size = SMALL if len(rows) <= SMALL else CHUNK
    parts = []
    for i in range(0, max(len(rows), 1), size):
        chunk = np.zeros((size, *rows.shape[1:]))
        piece = rows[i:i + size]
        chunk[:len(piece)] = piece
        parts.append([np.asarray(o)[:len(piece)] for o in fn(chunk, *args)])
    return tuple(np.concatenate(col) for col in zip(*parts))


def _degree(S: CPZ) -> int:
    """The largest exponent of S, bucketed (a static argument of the kernels)."""
    return _bucket(max(S.E.max(initial=0), S.R.max(initial=0)), 2)


def _powers(jnp, a, E, degree: int):
    """``(P, dP) (p, h)``: ``P[k, i] = a_k ** E[k, i]`` and its derivative in a_k, by selecting
    among a_k ** 0..degree (cheaper under vmap than a pow with an array exponent)."""
    P, dP, ak = jnp.ones(E.shape), jnp.zeros(E.shape), jnp.ones_like(a)
    for k in range(1, degree + 1):
        dP = jnp.where(E == k, (k * ak)[:, None], dP)
        ak = ak * a
        P = jnp.where(E == k, ak[:, None], P)
    return P, dP


def _mono_jac(jnp, a, E, degree: int):
    """``(m (h,), dm/da (h, p))``; the product over the other factors from prefix and suffix
    products (no division, so exact at a_k = 0)."""
    P, dP = _powers(jnp, a, E, degree)
    pre, suf = [jnp.ones(P.shape[1])], [jnp.ones(P.shape[1])]
    for k in range(len(P) - 1):
        pre.append(pre[-1] * P[k])
        suf.append(suf[-1] * P[len(P) - 1 - k])
    J = jnp.stack([dP[k] * pre[k] * suf[len(P) - 1 - k] for k in range(len(P))], 1)
    return pre[-1] * P[-1], J


def _cholesky_solve(jnp, M, r) -> list:
    """``M^-1 r`` for a small symmetric positive definite M given by entries (``M[i][j]`` and
    ``r[i]`` arrays of the same lanes): an unrolled Cholesky, elementwise work under vmap."""
    p = len(r)
    L = [[None] * p for _ in range(p)]
    for j in range(p):
        L[j][j] = jnp.sqrt(M[j][j] - sum((L[j][k] ** 2 for k in range(j)), 0.0))
        for i in range(j + 1, p):
            L[i][j] = (M[i][j] - sum((L[i][k] * L[j][k] for k in range(j)), 0.0)) / L[j][j]
    y = []
    for i in range(p):
        y.append((r[i] - sum((L[i][k] * y[k] for k in range(i)), 0.0)) / L[i][i])
    x = [None] * p
    for i in reversed(range(p)):
        x[i] = (y[i] - sum((L[k][i] * x[k] for k in range(i + 1, p)), 0.0)) / L[i][i]
    return x


def _spd_solve(jnp, M, r):
    """``M^-1 r`` for a small symmetric positive definite matrix M: :func:`_cholesky_solve` up
    to 8 x 8 (``jnp.linalg.solve`` is slow for tiny matrices under vmap), ``jnp.linalg.solve``
    above (an unrolled factorisation of a larger matrix takes long to compile)."""
    p = len(r)
    if p > 8:
        return jnp.linalg.solve(M, r)
    return jnp.stack(_cholesky_solve(jnp, [[M[i, j] for j in range(p)] for i in range(p)],
                                     [r[i] for i in range(p)]))


@lru_cache(maxsize=None)
def _lm_kernel(degree: int):
    """The jitted ``(X (B, n), A0 (K, p), rhos (L,), c, G, E, A, b, R) -> (alpha (B, K, p),
    ||f - x|| (B, K), ||h|| (B, K))``: penalty continuation over ``rhos`` of
    ``||f(alpha) - x||^2 + rho ||h(alpha)||^2`` by projected Levenberg-Marquardt in the box."""
    jax = configured()
    jnp = jax.numpy

    def residual(a, x, w, c, G, E, A, b, R):
        mE = jnp.prod(_powers(jnp, a, E, degree)[0], 0)
        mR = jnp.prod(_powers(jnp, a, R, degree)[0], 0)
        return jnp.concatenate([c + G @ mE - x, w * (A @ mR - b)])

    def iterate(a, mu, x, w, P):
        c, G, E, A, b, R = P
        mE, JE = _mono_jac(jnp, a, E, degree)
        mR, JR = _mono_jac(jnp, a, R, degree)
        r = jnp.concatenate([c + G @ mE - x, w * (A @ mR - b)])
        J = jnp.concatenate([G @ JE, w * (A @ JR)])
        g = J.T @ r
        # Active set: a factor at a bound whose descent would leave the box is frozen.
        frozen = ((a <= -1) & (g > 0)) | ((a >= 1) & (g < 0))
        J = jnp.where(frozen, 0.0, J)
        H = J.T @ J
        D = jnp.diag(H)
        # Marquardt scaling; zero columns (padding, frozen) get 1 so the system stays regular.
        D = jnp.where(D > 0, D, 1.0)
        step = _spd_solve(jnp, H + jnp.diag(mu * D), -J.T @ r)
        trial = jnp.clip(a + step, -1.0, 1.0)
        rt = residual(trial, x, w, *P)
        better = rt @ rt < r @ r
        mu = jnp.clip(jnp.where(better, mu * 0.3, mu * 10.0), 1e-12, 1e12)
        return jnp.where(better, trial, a), mu

    def one(a0, x, rhos, P):
        def level(a, rho):
            w = jnp.sqrt(rho)
            body = lambda _, st: iterate(*st, x, w, P)  # noqa: E731
            a, _ = jax.lax.fori_loop(0, ITERS, body, (a, jnp.asarray(1e-3)))
            return a, None

        a, _ = jax.lax.scan(level, a0, rhos)
        r = residual(a, x, 1.0, *P)
        n = len(x)
        return a, jnp.linalg.norm(r[:n]), jnp.linalg.norm(r[n:])

    over_starts = jax.vmap(one, (0, None, None, None))
    batched = jax.vmap(over_starts, (None, 0, None, None))
    return jax.jit(lambda X, A0, rhos, *P: batched(A0, X, rhos, P))


#: the structure-specialised kernel (:func:`_lm_unrolled`) is used up to this many factors; its
#: Cholesky is unrolled (p^3 / 6 scalar ops), and its compile time grows with p
UNROLL_P = 8


def unrolled_ok(S: CPZ) -> bool:
    """Whether S's queries go through :func:`_lm_unrolled`: a few factors and a small model."""
    return 0 < S.p <= UNROLL_P and S.n * S.h + S.m * S.q <= 256


def _monomials_of(a, E, with_jac: bool):
    """``(m, dm)`` of a static integer ``E (p, h)`` at the factor lanes ``a`` (a list of p
    arrays): ``m[i]`` is a lane array or the Python float 1.0 (a constant monomial), ``dm[i][k]``
    a lane array, a Python float (a constant derivative) or None (a structural zero), so only
    E's non-zero entries cost anything."""
    powers = {}

    def power(k, e):
        if e == 0:
            return 1.0
        if (k, e) not in powers:
            powers[k, e] = a[k] if e == 1 else power(k, e - 1) * a[k]
        return powers[k, e]

    def product(factors):
        out = 1.0
        for v in factors:
            out = v if isinstance(out, float) else (out if isinstance(v, float) else out * v)
        return out

    m, dm = [], []
    for i in range(E.shape[1]):
        col = [(k, int(E[k, i])) for k in range(E.shape[0]) if E[k, i] > 0]
        m.append(product(power(k, e) for k, e in col))
        if with_jac:
            row = [None] * len(a)
            for k, e in col:
                rest = product(power(j, f) for j, f in col if j != k)
                row[k] = e * product([power(k, e - 1), rest])
            dm.append(row)
    return m, dm


def _combine(coef, terms, empty=None):
    """``sum_i coef[i] * terms[i]`` over the pairs where neither is None (``coef`` a traced row
    or a list of lane arrays); ``empty`` when there are none."""
    out = empty
    for i, t in enumerate(terms):
        if t is None or coef[i] is None:
            continue
        v = coef[i] * t
        out = v if out is None or (isinstance(out, float) and out == 0.0) else out + v
    return out


def _static(E: np.ndarray) -> tuple:
    """A hashable copy of an integer exponent matrix: ``(shape, entries)``."""
    return E.shape, tuple(int(v) for v in E.ravel())


def _matrix(key: tuple) -> np.ndarray:
    return np.array(key[1], dtype=np.int64).reshape(key[0])


@lru_cache(maxsize=32)
def _lm_unrolled(n: int, E_key: tuple, R_key: tuple):
    """The LM kernel of :func:`_lm_kernel` specialised to one set structure (``E``, ``R`` and
    the dimensions are static; ``c, G, A, b`` are arguments): every lane (point x start) is a
    scalar program unrolled over E's and R's non-zero entries, so XLA fuses an iteration into a
    few elementwise loops instead of batched small matrix products over padded shapes. Same
    iteration, same results up to rounding."""
    jax = configured()
    jnp = jax.numpy
    E, R = _matrix(E_key), _matrix(R_key)
    p = E.shape[0]

    def residual(a, x, w, c, G, A, b, jac: bool):
        mE, dE = _monomials_of(a, E, jac)
        mR, dR = _monomials_of(a, R, jac)
        r, J = [], []
        for j in range(n):
            r.append(_combine(G[j], mE, 0.0) + c[j] - x[j])
            if jac:
                J.append([_combine(G[j], [row[k] for row in dE]) for k in range(p)])
        for j in range(len(b)):
            r.append(w * (_combine(A[j], mR, 0.0) - b[j]))
            if jac:
                J.append([None if t is None else w * t
                          for t in (_combine(A[j], [row[k] for row in dR]) for k in range(p))])
        return r, J

    def iterate(a, mu, x, w, P):
        r, J = residual(a, x, w, *P, True)
        g = [_combine(r, [J[j][k] for j in range(len(r))]) for k in range(p)]
        free = []
        for k in range(p):
            gk = jnp.zeros_like(a[k]) if g[k] is None else g[k]
            # Active set: a factor at a bound whose descent would leave the box is frozen.
            free.append(~(((a[k] <= -1) & (gk > 0)) | ((a[k] >= 1) & (gk < 0))))
        Jf = [[None if J[j][k] is None else jnp.where(free[k], J[j][k], 0.0) for k in range(p)]
              for j in range(len(r))]
        H = [[None] * p for _ in range(p)]
        for k in range(p):
            for l in range(k + 1):
                H[k][l] = H[l][k] = _combine([Jf[j][k] for j in range(len(r))],
                                             [Jf[j][l] for j in range(len(r))],
                                             jnp.zeros_like(mu))
        rhs = [-_combine(r, [Jf[j][k] for j in range(len(r))], jnp.zeros_like(mu))
               for k in range(p)]
        # Marquardt scaling; zero columns (frozen) get 1 so the system stays regular.
        M = [[H[k][l] if k != l else H[k][k] + mu * jnp.where(H[k][k] > 0, H[k][k], 1.0)
              for l in range(p)] for k in range(p)]
        step = _cholesky_solve(jnp, M, rhs)
        trial = [jnp.clip(a[k] + step[k], -1.0, 1.0) for k in range(p)]
        rt, _ = residual(trial, x, w, *P, False)
        better = sum(v * v for v in rt) < sum(v * v for v in r)
        mu = jnp.clip(jnp.where(better, mu * 0.3, mu * 10.0), 1e-12, 1e12)
        return [jnp.where(better, t, v) for t, v in zip(trial, a)], mu

    def run(X, A0, rhos, c, G, A, b):
        B, K = X.shape[0], A0.shape[0]
        x = [jnp.broadcast_to(X[:, j][:, None], (B, K)) for j in range(n)]
        a = [jnp.broadcast_to(A0[:, k][None, :], (B, K)) for k in range(p)]
        P = (c, G, A, b)

        def level(a, rho):
            w = jnp.sqrt(rho)
            body = lambda _, s: iterate(*s, x, w, P)  # noqa: E731
            return jax.lax.fori_loop(0, ITERS, body, (a, jnp.full((B, K), 1e-3)))[0], None

        a, _ = jax.lax.scan(level, a, rhos)
        r, _ = residual(a, x, 1.0, *P, False)
        nf = jnp.sqrt(sum(v * v for v in r[:n]))
        nh = jnp.sqrt(sum((v * v for v in r[n:]), jnp.zeros((B, K))))
        return jnp.stack(a, -1), nf, nh

    return jax.jit(run)


def _solve(S: CPZ, P, X: np.ndarray, A0: np.ndarray, rhos: np.ndarray):
    """The LM kernel for S (padded to ``P``) over the rows of ``X (N, n)``: the specialised
    :func:`_lm_unrolled` for small sets, the padded :func:`_lm_kernel` otherwise."""
    if unrolled_ok(S):
        n, h, m, q = S.n, S.h, S.m, S.q
        c, G, _, A, b, _ = P
        kernel = _lm_unrolled(n, _static(S.E), _static(S.R))
        return _chunked(kernel, X, A0[:, :S.p], rhos, c[:n], G[:n, :h], A[:m, :q], b[:m])
    Xp = np.zeros((len(X), len(P[0])))
    Xp[:, :X.shape[1]] = X
    return _chunked(_lm_kernel(_degree(S)), Xp, A0, rhos, *P)


def _points(S: CPZ, X) -> np.ndarray:
    X = np.asarray(X, dtype=float)
    X = X.reshape(-1, S.n) if X.ndim != 2 else X
    if X.shape[1] != S.n:
        raise ValueError(f"points of dimension {X.shape[1]} for a set in R^{S.n}")
    return X


def nearest(S: CPZ, X, *, starts: int = 16, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``(d (N,), alpha (N, p'))``: the distance from each row of ``X (N, n)`` to S (about 0
    inside) and the minimising factors of ``D = dependent(S)`` (p' = p + d, GI factors last).

    Penalty continuation (``RHOS``) with bounded Levenberg-Marquardt, alpha = 0 plus
    ``starts - 1`` random starts; starts ending with ||h|| > ``H_FEASIBLE`` are rejected, and
    d = inf where every start was (alpha is then the least infeasible one).
    ``d**2 = ||D.c + D.G m(alpha, D.E) - x||**2``, so by Danskin the gradient of d**2 with
    respect to c or G is that expression's gradient at ``stop_gradient(alpha)`` (add
    ``lambda . h`` only when A or b depend on the parameters)."""
    D = dependent(S)
    X = _points(S, X)
    alpha, nf, nh = _solve(D, _padded(D), X, _starts(D, starts, seed), RHOS)
    score = np.where(nh <= H_FEASIBLE, nf, np.inf)
    best = np.where(np.isfinite(score).any(axis=1), score.argmin(axis=1), nh.argmin(axis=1))
    rows = np.arange(len(X))
    return score[rows, best], alpha[rows, best, :D.p]


def distance(S: CPZ, X, **kw) -> np.ndarray:
    """``d (N,)`` of :func:`nearest`."""
    return nearest(S, X, **kw)[0]


def _scale(S: CPZ) -> float:
    lo, hi = interval_hull(S)
    return max(float(np.max(hi - lo, initial=0.0)) / 2, 1e-12)


def contains(S: CPZ, X, *, tol: float = 1e-6, starts: int = 16, seed: int = 0,
             rounds: int = 1) -> np.ndarray:
    """``(N,)`` bool: x in S up to ``tol`` times the set's scale s (the interval hull's largest
    half-width). Minimises ``||[f(alpha) - x; s h_hat(alpha)]||`` in the box (§3a: the point is
    padded with zeros for the constraint rows) with h_hat's rows scaled to max |coefficient| 1;
    multi-start as :func:`nearest`, ``rounds`` times the iterations of one distance query
    (unions converge sublinearly where a selector forces factors to 0: nested unions need ~16).
    Where a constraint is quadratic in a factor that must vanish (the union's selector), the
    tolerance in x is ~sqrt(tol): points ~1e-3 outside a union may count as inside.
    False is "not found", not a certificate."""
    D = dependent(S)
    X = _points(S, X)
    s = _scale(D)
    norm = np.maximum(np.abs(np.column_stack([D.A, D.b])).max(axis=1, initial=0.0), 1e-300)
    P = _padded(D, A=D.A / norm[:, None], b=D.b / norm)
    weights = np.full(len(RHOS) * rounds, s * s)
    _, nf, nh = _solve(D, P, X, _starts(D, starts, seed), weights)
    return np.sqrt(nf ** 2 + (s * nh) ** 2).min(axis=1) <= tol * s


def _directions(n: int, k: int, seed: int) -> np.ndarray:
    """``(k', n)`` unit directions: +-1 in 1-D, k evenly spaced angles in 2-D, else +-e_i then
    seeded Gaussian directions up to k."""
    if n == 1:
        return np.array([[1.0], [-1.0]])
    if n == 2:
        t = 2 * np.pi * np.arange(k) / k
        return np.column_stack([np.cos(t), np.sin(t)])
    axes = np.vstack([np.eye(n), -np.eye(n)])
    extra = np.random.default_rng(seed).normal(size=(max(k - 2 * n, 0), n))
    return np.vstack([axes, extra / np.linalg.norm(extra, axis=1, keepdims=True)])


def inner_distance(S: CPZ, X, *, directions: int = 24, seed: int = 0, **kw) -> np.ndarray:
    """``(N,)``: for points in S, the distance to the boundary by ray casting (§3b: the first exit
    along each direction by a coarse grid then bisection on :func:`contains`, minimised over the
    directions; an upper bound, off by about delta theta^2 / 2 for spacing theta); 0 outside.
    ``kw`` goes to :func:`contains`."""
    X = _points(S, X)
    out = np.zeros(len(X))
    inside = contains(S, X, **kw)
    if not inside.any():
        return out
    P, U = X[inside], _directions(S.n, directions, seed)
    lo, hi = interval_hull(S)
    ts = np.linalg.norm(hi - lo) * np.arange(1, GRID + 1) / GRID

    def along(t):
        """Containment of ``P + t U`` for ``t (len(P), len(U), k)``."""
        pts = P[:, None, None, :] + t[..., None] * U[None, :, None, :]
        return contains(S, pts.reshape(-1, S.n), **kw).reshape(t.shape)

    ins = along(np.broadcast_to(ts, (len(P), len(U), GRID)))
    first = np.argmax(~ins, axis=2)
    never = ins.all(axis=2)
    t_hi = np.where(never, ts[-1], ts[first])
    t_lo = np.where(never, ts[-1], np.where(first > 0, ts[np.maximum(first - 1, 0)], 0.0))
    for _ in range(BISECT):
        mid = (t_lo + t_hi) / 2
        ok = along(mid[..., None])[..., 0]
        t_lo, t_hi = np.where(ok, mid, t_lo), np.where(ok, t_hi, mid)
    out[inside] = ((t_lo + t_hi) / 2).min(axis=1)
    return out


def signed_distance(S: CPZ, X, **kw) -> np.ndarray:
    """``(N,)``: d(x, S) outside, minus :func:`inner_distance` inside."""
    X = _points(S, X)
    return np.where(contains(S, X), -inner_distance(S, X), distance(S, X, **kw))


@lru_cache(maxsize=1)
def _projection_kernel():
    """The jitted ``(alpha0 (B, p), c, G, E, A, b, R) -> (x (B, n), ||h|| (B,))``: minimum-norm
    Newton steps onto h = 0 clipped to the box (§3c)."""
    jax = configured()
    jnp = jax.numpy

    def one(a, P):
        c, G, E, A, b, R = P
        hfun = lambda a: A @ monomials(a, R) - b  # noqa: E731

        def body(_, a):
            J = jax.jacfwd(hfun)(a)
            # 1e-12: a regulariser for rows of J that vanish (padding, singular points).
            step = J.T @ jnp.linalg.solve(J @ J.T + 1e-12 * jnp.eye(len(b)), hfun(a))
            return jnp.clip(a - step, -1.0, 1.0)

        a = jax.lax.fori_loop(0, 30, body, a)
        return c + G @ monomials(a, E), jnp.linalg.norm(hfun(a))

    return jax.jit(jax.vmap(one, (0, None)))


def sample(S: CPZ, n: int, rng: np.random.Generator, *, rounds: int = 10) -> np.ndarray:
    """Up to ``n`` points ``(k, dim)`` of S: alpha drawn uniformly in the box, projected onto
    h = 0, kept when ||h|| < 1e-9, GI factors drawn uniformly (they are in no constraint). Not
    uniform in x (§3c). Gives up after ``rounds`` batches of n draws."""
    D = dependent(S)
    P = _padded(D)
    kept = []
    for _ in range(rounds):
        a0 = np.zeros((n, len(P[2])))
        a0[:, :D.p] = rng.uniform(-1, 1, (n, D.p))
        x, nh = _chunked(lambda a: _projection_kernel()(a, P), a0)
        kept.append(x[nh < 1e-9, :S.n])
        if sum(map(len, kept)) >= n:
            break
    return np.concatenate(kept)[:n]


def sample_uniform(S: CPZ, n: int, rng: np.random.Generator, *, rounds: int = 20) -> np.ndarray:
    """Up to ``n`` points ``(k, dim)`` uniform in S, by rejection from the interval hull with
    :func:`contains` (acceptance vol(S)/vol(hull): poor for thin sets). Gives up after ``rounds``
    batches of max(n, 256) draws."""
    lo, hi = interval_hull(S)
    kept = []
    for _ in range(rounds):
        X = rng.uniform(lo, hi, (max(n, 256), S.n))
        kept.append(X[contains(S, X)])
        if sum(map(len, kept)) >= n:
            break
    return np.concatenate(kept)[:n]


def witness(S: CPZ, *, starts: int = 32, seed: int = 0) -> tuple[float, np.ndarray]:
    """``(min ||h||, alpha (p,))`` over the box by bounded least squares with multi-start; a value
    below ~1e-7 shows S non-empty, a larger one proves nothing."""
    if S.m == 0:
        return 0.0, np.zeros(S.p)
    P = _padded(S, G=np.zeros((S.n, S.h)), c=np.zeros(S.n))
    alpha, _, nh = _solve(S, P, np.zeros((1, S.n)), _starts(S, starts, seed), np.ones(len(RHOS)))
    k = int(nh[0].argmin())
    return float(nh[0, k]), alpha[0, k, :S.p]


def _z3_polys(S: CPZ, z3, ctx):
    """The constraints as z3 terms over factors in the box, with exactly rationalised data."""
    a = [z3.Real(f"a{k}", ctx) for k in range(S.p)]
    box = [z3.And(x >= -1, x <= 1) for x in a]

    def q(v):
        r = Fraction(float(v))
        return z3.RatVal(r.numerator, r.denominator, ctx)

    def mono(col):
        terms = [a[k] for k in range(S.p) for _ in range(int(col[k]))]
        out = q(1)
        for t in terms:
            out = out * t
        return out

    monos = [mono(S.R[:, j]) for j in range(S.q)]
    rows = [z3.Sum([q(S.A[i, j]) * monos[j] for j in range(S.q) if S.A[i, j] != 0] or [q(0)])
            == q(S.b[i]) for i in range(S.m)]
    return box + rows


def is_empty(S: CPZ, *, timeout_ms: int = 2000, starts: int = 32, seed: int = 0) -> bool | None:
    """True when S is certainly empty (z3 nlsat says the constraints are unsat in the box),
    False when a witness with ||h|| < 1e-7 exists (or there are no constraints), None when z3
    answers unknown or times out."""
    if S.m == 0 or witness(S, starts=starts, seed=seed)[0] < H_FEASIBLE:
        return False
    import z3

    ctx = z3.Context()
    solver = z3.SolverFor("QF_NRA", ctx=ctx)
    solver.set("timeout", int(timeout_ms))
    solver.add(*_z3_polys(S, z3, ctx))
    verdict = solver.check()
    if verdict == z3.unsat:
        return True
    return False if verdict == z3.sat else None


@lru_cache(maxsize=1)
def _support_kernel():
    """The jitted ``(dirs (B, n), A0 (K, p), rhos, c, G, E, A, b, R) -> (alpha (B, K, p),
    dir . G m (B, K), ||h|| (B, K))``: penalty continuation of ``dir . G m(alpha) + rho ||h||^2``
    by projected Newton steps, shifted to be a descent direction."""
    jax = configured()
    jnp = jax.numpy

    def one(a0, s, rhos, P):
        c, G, E, A, b, R = P
        lin = lambda a: s @ (G @ monomials(a, E))  # noqa: E731

        def level(a, rho):
            phi = lambda a: lin(a) + rho * jnp.sum((A @ monomials(a, R) - b) ** 2)  # noqa: E731

            def body(_, st):
                a, mu = st
                g, H = jax.grad(phi)(a), jax.hessian(phi)(a)
                frozen = ((a <= -1) & (g > 0)) | ((a >= 1) & (g < 0))
                keep = (~frozen)[:, None] & (~frozen)[None, :]
                H = jnp.where(keep, H, 0.0) + jnp.diag(frozen.astype(float))
                g = jnp.where(frozen, 0.0, g)
                # Shift by the most negative eigenvalue so the step is a descent direction.
                shift = jnp.maximum(-jnp.linalg.eigvalsh(H)[0], 0.0) + mu * (1 + jnp.abs(H).max())
                trial = jnp.clip(a - jnp.linalg.solve(H + shift * jnp.eye(len(a)), g), -1.0, 1.0)
                better = phi(trial) < phi(a)
                mu = jnp.clip(jnp.where(better, mu * 0.3, mu * 10.0), 1e-14, 1e6)
                return jnp.where(better, trial, a), mu

            a, _ = jax.lax.fori_loop(0, 2 * ITERS, body, (a, jnp.asarray(1e-6)))
            return a, None

        a, _ = jax.lax.scan(level, a0, rhos)
        return a, lin(a), jnp.linalg.norm(A @ monomials(a, R) - b)

    batched = jax.vmap(jax.vmap(one, (0, None, None, None)), (None, 0, None, None))
    return jax.jit(lambda dirs, A0, rhos, *P: batched(A0, dirs, rhos, P))


def support(S: CPZ, direction, *, starts: int = 16, seed: int = 0) -> tuple[float, float]:
    """``(lower, upper)`` = (min, max) of ``direction . x`` over S, by bounded optimisation with
    a penalty on h (the best feasible start; local, so a bound from inside the true range)."""
    D = dependent(S)
    s = np.asarray(direction, dtype=float).reshape(S.n)
    P = _padded(D)
    dirs = np.zeros((2, len(P[0])))
    dirs[:, :S.n] = [s, -s]
    _, val, nh = _chunked(_support_kernel(), dirs, _starts(D, starts, seed), RHOS, *P)
    val = np.where(nh <= H_FEASIBLE, val, np.inf).min(axis=1) + dirs[:, :S.n] @ D.c
    return float(val[0]), float(-val[1])
