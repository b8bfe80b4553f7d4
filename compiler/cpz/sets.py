"""Constrained polynomial zonotopes and their closed-form operations, in numpy
(docs/math.md §C).

``CPZ = {c + G m(alpha, E) + GI beta | A m(alpha, R) = b, alpha in [-1,1]^p, beta in [-1,1]^d}``
with the monomial vector ``m(alpha, E)_i = prod_k alpha_k ** E[k, i]``. Every binary operation
treats the operands' factors as disjoint (block-diagonal stacking, §1), so no identifier vector
is kept. Nothing here solves anything: containment, distance and emptiness are in ``solve``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _f(x, shape=None) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    return a.reshape(shape) if shape is not None else a


@dataclass(frozen=True, eq=False)
class CPZ:
    """``c (n,)``, ``G (n, h)``, ``E (p, h)`` int, ``A (m, q)``, ``b (m,)``, ``R (p, q)`` int,
    ``GI (n, d)``. Row k of E and of R belong to the same dependent factor alpha_k."""

    c: np.ndarray
    G: np.ndarray
    E: np.ndarray
    A: np.ndarray
    b: np.ndarray
    R: np.ndarray
    GI: np.ndarray

    def __post_init__(self):
        for name in ("c", "G", "A", "b", "GI"):
            object.__setattr__(self, name, _f(getattr(self, name)))
        for name in ("E", "R"):
            v = np.asarray(getattr(self, name))
            if v.size and (not np.all(v == np.round(v)) or v.min() < 0):
                raise ValueError(f"CPZ.{name} must hold non-negative integers")
            object.__setattr__(self, name, v.astype(np.int64))
        for name, nd in (("c", 1), ("G", 2), ("E", 2), ("A", 2), ("b", 1), ("R", 2), ("GI", 2)):
            shape = getattr(self, name).shape
            if len(shape) != nd:
                raise ValueError(f"CPZ.{name} must be {nd}-D, got shape {shape}")
        n, p, h, m, q = (len(self.c), len(self.E), self.G.shape[1], len(self.b),
                         self.A.shape[1])
        want = {"G": (n, h), "E": (p, h), "A": (m, q), "R": (p, q), "GI": (n, self.GI.shape[1])}
        for name, shape in want.items():
            if getattr(self, name).shape != shape:
                raise ValueError(f"CPZ.{name} has shape {getattr(self, name).shape}, expected "
                                 f"{shape} (n={n} from c, h={h} from G, p={p} from E, m={m} from "
                                 f"b, q={q} from A)")

    n = property(lambda self: self.c.shape[0], doc="dimension of the space")
    p = property(lambda self: self.E.shape[0], doc="number of dependent factors")
    h = property(lambda self: self.G.shape[1], doc="number of dependent generators")
    m = property(lambda self: self.A.shape[0], doc="number of constraints")
    q = property(lambda self: self.A.shape[1], doc="number of constraint monomials")
    d = property(lambda self: self.GI.shape[1], doc="number of independent generators")

    @classmethod
    def make(cls, c, G, E, A=None, b=None, R=None, GI=None) -> CPZ:
        """A CPZ with the constraints and GI left out meaning none."""
        c = _f(c, (-1,))
        G = _f(G).reshape(len(c), -1)
        E = np.asarray(E).reshape(-1, G.shape[1])
        A = np.zeros((0, 0)) if A is None else _f(A).reshape(-1, np.shape(A)[-1])
        b = np.zeros(A.shape[0]) if b is None else _f(b, (-1,))
        R = np.zeros((E.shape[0], A.shape[1]), np.int64) if R is None else R
        GI = np.zeros((len(c), 0)) if GI is None else GI
        return cls(c, G, E, A, b, R, GI)

    @classmethod
    def zonotope(cls, c, G) -> CPZ:
        """The zonotope ``c + G alpha``: E = I, no constraints."""
        G = _f(G).reshape(len(_f(c, (-1,))), -1)
        return cls.make(c, G, np.eye(G.shape[1], dtype=np.int64))

    @classmethod
    def box(cls, lower, upper) -> CPZ:
        """The axis-aligned box [lower, upper] as a zonotope."""
        lo, hi = _f(lower, (-1,)), _f(upper, (-1,))
        if np.any(hi < lo):
            raise ValueError("CPZ.box needs lower <= upper")
        return cls.zonotope((lo + hi) / 2, np.diag((hi - lo) / 2))

    @classmethod
    def interval(cls, lo: float, hi: float) -> CPZ:
        """The 1-D box [lo, hi]."""
        return cls.box([lo], [hi])

    @classmethod
    def ball(cls, center, radius: float) -> CPZ:
        """The closed ball B(center, radius) in the thesis's Distance template (§4.2):
        ``sum_i alpha_i^2 = (1 + alpha_{n+1}) / 2`` with alpha_{n+1} in [-1, 1]."""
        c = _f(center, (-1,))
        n = len(c)
        E = np.vstack([np.eye(n, dtype=np.int64), np.zeros((1, n), np.int64)])
        A = np.append(np.ones(n), -0.5)[None]
        R = np.zeros((n + 1, n + 1), np.int64)
        R[:n, :n] = 2 * np.eye(n, dtype=np.int64)
        R[n, n] = 1
        return cls.make(c, radius * np.eye(n), E, A, [0.5], R)

    @classmethod
    def ellipsoid(cls, q, Q) -> CPZ:
        """The ellipsoid {x | (x-q)^T Q^-1 (x-q) <= 1} for a PSD ``Q`` (CORA's conversion:
        ``G = V sqrt(D)``; the ball's constraint with the slack column first)."""
        c = _f(q, (-1,))
        n = len(c)
        w, V = np.linalg.eigh(_f(Q).reshape(n, n))
        E = np.vstack([np.eye(n, dtype=np.int64), np.zeros((1, n), np.int64)])
        R = np.zeros((n + 1, n + 1), np.int64)
        R[n, 0] = 1
        R[:n, 1:] = 2 * np.eye(n, dtype=np.int64)
        A = np.append(-0.5, np.ones(n))[None]
        return cls.make(c, V * np.sqrt(np.clip(w, 0, None)), E, A, [0.5], R)

    @classmethod
    def constrained_zonotope(cls, c, G, A, b) -> CPZ:
        """``{c + G alpha | A alpha = b}``: E = R = I."""
        G = _f(G).reshape(len(_f(c, (-1,))), -1)
        eye = np.eye(G.shape[1], dtype=np.int64)
        return cls.make(c, G, eye, _f(A).reshape(-1, G.shape[1]), b, eye)


def _blkdiag(*ms) -> np.ndarray:
    rows = sum(m.shape[0] for m in ms)
    out = np.zeros((rows, sum(m.shape[1] for m in ms)), dtype=np.result_type(*ms))
    i = j = 0
    for m in ms:
        out[i:i + m.shape[0], j:j + m.shape[1]] = m
        i, j = i + m.shape[0], j + m.shape[1]
    return out


def affine(S: CPZ, M, t=None) -> CPZ:
    """The image ``{M x + t | x in S}`` for ``M (k, n)``, ``t (k,)``."""
    M = _f(M).reshape(-1, S.n)
    t = np.zeros(M.shape[0]) if t is None else _f(t, (-1,))
    return CPZ(M @ S.c + t, M @ S.G, S.E, S.A, S.b, S.R, M @ S.GI)


def translate(S: CPZ, t) -> CPZ:
    """``S + t`` for a point t."""
    return CPZ(S.c + _f(t, (-1,)), S.G, S.E, S.A, S.b, S.R, S.GI)


def minkowski_sum(S1: CPZ, S2: CPZ) -> CPZ:
    """``S1 (+) S2`` with independent factors."""
    return CPZ(S1.c + S2.c, np.hstack([S1.G, S2.G]), _blkdiag(S1.E, S2.E),
               _blkdiag(S1.A, S2.A), np.concatenate([S1.b, S2.b]), _blkdiag(S1.R, S2.R),
               np.hstack([S1.GI, S2.GI]))


def cartesian(S1: CPZ, S2: CPZ) -> CPZ:
    """``S1 x S2`` (coordinates of S1 first)."""
    return CPZ(np.concatenate([S1.c, S2.c]), _blkdiag(S1.G, S2.G), _blkdiag(S1.E, S2.E),
               _blkdiag(S1.A, S2.A), np.concatenate([S1.b, S2.b]), _blkdiag(S1.R, S2.R),
               _blkdiag(S1.GI, S2.GI))


def dependent(S: CPZ) -> CPZ:
    """The same set with GI turned into dependent factors (appended after alpha): exact Boolean
    operations need it."""
    if S.d == 0:
        return S
    return CPZ(S.c, np.hstack([S.G, S.GI]), _blkdiag(S.E, np.eye(S.d, dtype=np.int64)), S.A,
               S.b, np.vstack([S.R, np.zeros((S.d, S.q), np.int64)]), np.zeros((S.n, 0)))


def _merge(M: np.ndarray, Ex: np.ndarray):
    """Columns of ``Ex`` made unique with the matching columns of ``M`` summed, and the all-zero
    column (a constant monomial) split off: ``(M', Ex', M column of the constant)``."""
    if Ex.shape[1] == 0:
        return M, Ex, np.zeros(M.shape[0])
    cols, inv = np.unique(Ex.T, axis=0, return_inverse=True)
    summed = np.zeros((M.shape[0], len(cols)))
    np.add.at(summed.T, inv.ravel(), M.T)
    zero = ~cols.any(axis=1)
    const = summed[:, zero].sum(axis=1)
    return summed[:, ~zero], cols[~zero].T.reshape(Ex.shape[0], -1), const


def compact(S: CPZ) -> CPZ:
    """The regular form (§1): duplicate monomials of E and R merged, constant monomials moved
    into c and b, and factors that occur nowhere deleted. GI is kept as is."""
    G, E, dc = _merge(S.G, S.E)
    A, R, db = _merge(S.A, S.R)
    used = E.any(axis=1) | R.any(axis=1)
    return CPZ(S.c + dc, G, E[used], A, S.b - db, R[used], S.GI)


def intersect(S1: CPZ, S2: CPZ) -> CPZ:
    """The exact intersection of two sets in the same space ([KA]); GI is made dependent first.
    The last n constraints say ``c1 + G1 m(alpha1) = c2 + G2 m(alpha2)``."""
    if S1.n != S2.n:
        raise ValueError(f"intersect: dimensions {S1.n} and {S2.n} differ")
    S1, S2 = dependent(S1), dependent(S2)
    return _glue(S1, S2, S1.c, S1.G, np.arange(S1.n), np.arange(S2.n))


def _glue(S1: CPZ, S2: CPZ, c, G, rows1, rows2) -> CPZ:
    """S1 and S2 stacked with the equality ``x1[rows1] = x2[rows2]`` added; ``c``, ``G`` (over
    the factors of both) give the result's points. E of the result is ``blkdiag(E1, E2)`` cut to
    the columns of G."""
    A = _blkdiag(S1.A, S2.A, np.hstack([S1.G[rows1], -S2.G[rows2]]))
    b = np.concatenate([S1.b, S2.b, S2.c[rows2] - S1.c[rows1]])
    E12 = _blkdiag(S1.E, S2.E)
    R = np.hstack([_blkdiag(S1.R, S2.R), E12])
    return CPZ(c, G, E12[:, :G.shape[1]], A, b, R, np.zeros((len(c), 0)))


def intersect_halfspace(S: CPZ, a, beta: float) -> CPZ | None:
    """``S ∩ {x | a.x <= beta}``, exact, with one new factor and one new constraint; ``None`` when
    the interval bound shows the result empty. (A None from here certifies emptiness; a CPZ
    returned may still be empty.)"""
    a = _f(a, (-1,))
    S = dependent(S)
    aG = a @ S.G
    lo = a @ S.c - np.abs(aG).sum()
    if lo > beta:
        return None
    if a @ S.c + np.abs(aG).sum() <= beta:
        return S      # the whole set is in the half-space
    E = np.vstack([S.E, np.zeros((1, S.h), np.int64)])
    R = np.hstack([np.vstack([S.R, np.zeros((1, S.q), np.int64)]), E,
                   np.eye(S.p + 1, dtype=np.int64)[:, -1:]])
    A = _blkdiag(S.A, np.append(aG, -(beta - lo) / 2)[None])
    b = np.append(S.b, (beta + lo) / 2 - a @ S.c)
    return CPZ(S.c, S.G, E, A, b, R, S.GI)


def union(S1: CPZ, S2: CPZ, *, cross_term: bool = False) -> CPZ:
    """``S1 ∪ S2`` by the selector construction (§2): factors (lambda, mu, alpha1, alpha2), with
    ``lambda mu = 1`` choosing S1 (lambda = 1) or S2 (lambda = -1). Operands are made dependent
    and compact first (the selection needs m(0, E) = 0). The cross term of constraint (ii) is
    redundant once lambda = ±1 and is left out unless ``cross_term`` (CORA's layout: disk ∪ box
    has q = 29 with it, 17 without)."""
    S1, S2 = compact(dependent(S1)), compact(dependent(S2))
    p1, p2, n = S1.p, S2.p, S1.n
    if min(p1, p2) < 1 or S1.n != S2.n:
        raise ValueError("union: operands need the same dimension and at least one factor each")
    P = p1 + p2 + 2

    def col(k=None, sq1=None, sq2=None):
        e = np.zeros(P, np.int64)
        if k is not None:
            e[k] = 1
        if sq1 is not None:
            e[2 + sq1] = 2
        if sq2 is not None:
            e[2 + p1 + sq2] = 2
        return e[:, None]

    lam, mu = 0, 1
    blocks = [col(lam) + col(mu), col(lam), col(mu)]
    coef = [1.0, -1.0]
    blocks += [col(sq1=i) for i in range(p1)] + [col(lam, sq1=i) for i in range(p1)]
    coef += [1 / (2 * p1)] * p1 + [-1 / (2 * p1)] * p1
    blocks += [col(sq2=j) for j in range(p2)] + [col(lam, sq2=j) for j in range(p2)]
    coef += [-1 / (2 * p2)] * p2 * 2
    if cross_term:
        pairs = [(i, j) for i in range(p1) for j in range(p2)]
        blocks += [col(sq1=i, sq2=j) for i, j in pairs]
        blocks += [col(lam, sq1=i, sq2=j) for i, j in pairs]
        coef += [-1 / (4 * p1 * p2)] * len(pairs) + [1 / (4 * p1 * p2)] * len(pairs)
    sel = np.hstack(blocks)
    RR = np.vstack([np.zeros((2, S1.q + S2.q), np.int64), _blkdiag(S1.R, S2.R)])
    R = np.hstack([sel, RR, col(lam)])
    A = np.zeros((2 + S1.m + S2.m, R.shape[1]))
    A[0, 0] = 1
    A[1, 1:sel.shape[1]] = coef
    A[2:, sel.shape[1]:-1] = _blkdiag(S1.A, S2.A)
    A[2:, -1] = np.concatenate([-S1.b / 2, S2.b / 2])
    b = np.concatenate([[1.0, 0.0], S1.b / 2, S2.b / 2])
    G = np.hstack([(S1.c - S2.c)[:, None] / 2, np.zeros((n, 1)), S1.G, S2.G])
    E = np.hstack([col(lam), col(mu),
                   np.vstack([np.zeros((2, S1.h + S2.h), np.int64), _blkdiag(S1.E, S2.E)])])
    return CPZ((S1.c + S2.c) / 2, G, E, A, b, R, np.zeros((n, 0)))


def lift(S: CPZ, coords, N: int, lower, upper) -> CPZ:
    """S (on global coordinates ``coords``, in order) embedded in R^N with the missing coordinates
    ranging over the box [lower, upper] (length-N arrays or scalars; only the missing entries are
    read), each by one new dependent factor. Exact inside that box only."""
    J = np.asarray(coords, dtype=int)
    missing = np.setdiff1d(np.arange(N), J)
    lo, hi = np.broadcast_to(_f(lower), (N,)), np.broadcast_to(_f(upper), (N,))
    P = np.zeros((N, S.n))
    P[J, np.arange(S.n)] = 1
    pad = np.zeros((N, len(missing)))
    pad[missing, np.arange(len(missing))] = (hi[missing] - lo[missing]) / 2
    c = P @ S.c
    c[missing] = (lo[missing] + hi[missing]) / 2
    k = len(missing)
    return CPZ(c, np.hstack([P @ S.G, pad]), _blkdiag(S.E, np.eye(k, dtype=np.int64)), S.A, S.b,
               np.vstack([S.R, np.zeros((k, S.q), np.int64)]), P @ S.GI)


def intersect_sparse(S1: CPZ, J1, S2: CPZ, J2) -> tuple[CPZ, np.ndarray]:
    """``S1 ∩ S2`` for S1 on global coordinates J1 and S2 on J2, without box padding: the result
    and its coordinates ``U = sorted(J1 ∪ J2)``. Equal to :func:`intersect` when J1 = J2."""
    J1, J2 = list(np.asarray(J1, dtype=int)), list(np.asarray(J2, dtype=int))
    S1, S2 = dependent(S1), dependent(S2)
    U = np.array(sorted(set(J1) | set(J2)))
    c = np.zeros(len(U))
    G = np.zeros((len(U), S1.h + S2.h))
    for r, u in enumerate(U):
        if u in J1:
            c[r], G[r, :S1.h] = S1.c[J1.index(u)], S1.G[J1.index(u)]
        else:
            c[r], G[r, S1.h:] = S2.c[J2.index(u)], S2.G[J2.index(u)]
    shared = [u for u in U if u in J1 and u in J2]
    return (_glue(S1, S2, c, G, [J1.index(u) for u in shared], [J2.index(u) for u in shared]),
            U)


def interval_hull(S: CPZ) -> tuple[np.ndarray, np.ndarray]:
    """A box enclosing S: ``c -+ (|G| 1 + |GI| 1)``."""
    r = np.abs(S.G).sum(axis=1) + np.abs(S.GI).sum(axis=1)
    return S.c - r, S.c + r
