"""The collision checker's compiled loops: the forward kinematics of a batch and the first pass's candidate search.

:func:`kinematics` runs every batch the checker sees through the robot model's program;
:func:`candidates` runs :meth:`tmpc.runtime.collision.first_pass.FirstPass.candidates`'s stages
(bounding balls, boxes against balls, covers, convex hulls) for every state in one call. One
compiled loop visits each state and stops testing a pair at the first stage that rules it out,
so a call has no fixed cost per stage and no intermediate array (the optimal planner checks a
few states per mode and call).

The tests, in order (:mod:`tmpc.runtime.collision.spheres` says why each is sound): a candidate
pair survives (1) its two bounding balls meeting, or, for an obstacle, the robot's box of balls
meeting the obstacle's world box and then the ball meeting the (rounded) obstacle box; (2) for
two moving geometries, each one's oriented box meeting the other's ball; (3) a ball of one's
cover meeting a ball of the other's cover (only the cover balls that meet the other's bounding
ball take part), or a cover ball meeting the obstacle box; (4) the convex stage: GJK on the two
convex hulls finding no plane that separates them by more than :data:`HULL_GAP` (:func:`apart`;
the plane it finds is checked directly on the points, so the stage rests on no tolerance of
GJK's). Pairs whose :class:`tmpc.runtime.collision.pair_table.PairTable` proves them free skip
the stages (the tables are read before the call, by :func:`table_free`).

The module is built without numba's reference counting (the scratch arrays come from the
caller): with it, each call of a helper taking arrays (~40 per GJK) takes an atomic incref and
decref of each, and the counts keep LLVM from hoisting loads out of the loops. The GJK helpers
are not inlined into the search: that would lengthen the machine's one-time build, which a
cold run waits for.

A run loads these kernels built ahead of time
(:data:`tmpc.runtime.collision.kernel.PASS_KERNEL`, :mod:`tmpc.compiler.aot`: an extension
module, no numba in the process); this module is its source, and numba's JIT of it is the
fallback when that build fails (its machine code cached under ``$NUMBA_CACHE_DIR``,
:mod:`tmpc.compiler.numbacfg`). Importing this module imports numba: only the build's child
process and that fallback do. docs/collision.md has the measured costs.
"""

from __future__ import annotations

import math

import numpy as np

from tmpc.compiler.numbacfg import numba


@numba.njit(cache=True, nogil=True, inline="always")
def _box_d2(Rb, hb, k, x0, x1, x2):
    """Squared distance from box k (axes the columns of Rb[k], half-extents hb[k]) of the
    point at (x0, x1, x2) from its center, in the axes Rb[k] is expressed in."""
    d2 = 0.0
    for j in range(3):
        e = abs(Rb[k, 0, j] * x0 + Rb[k, 1, j] * x1 + Rb[k, 2, j] * x2) - hb[k, j]
        if e > 0.0:
            d2 += e * e
    return d2


@numba.njit(cache=True, nogil=True, inline="always")
def _box_meets_ball(R, p, s, fm, obb_c, obb_R, obb_h, m, cx, cy, cz, r):
    """Whether the oriented box of moving geometry m (frame fm) meets the ball (cx, cy, cz; r)."""
    x0, x1, x2 = cx - p[fm, 0, s], cy - p[fm, 1, s], cz - p[fm, 2, s]
    y0 = R[fm, 0, 0, s] * x0 + R[fm, 1, 0, s] * x1 + R[fm, 2, 0, s] * x2 - obb_c[m, 0]
    y1 = R[fm, 0, 1, s] * x0 + R[fm, 1, 1, s] * x1 + R[fm, 2, 1, s] * x2 - obb_c[m, 1]
    y2 = R[fm, 0, 2, s] * x0 + R[fm, 1, 2, s] * x1 + R[fm, 2, 2, s] * x2 - obb_c[m, 2]
    return _box_d2(obb_R, obb_h, m, y0, y1, y2) <= r * r


@numba.njit(cache=True, nogil=True, inline="always")
def _near_cover(R, p, s, fm, cov, cov_r, ncov, m, cx, cy, cz, r, out):
    """Indices (into ``out``; their count returned) of m's cover balls that meet the ball
    (cx, cy, cz; r): the ball's center in m's frame, no per-ball transform."""
    x0, x1, x2 = cx - p[fm, 0, s], cy - p[fm, 1, s], cz - p[fm, 2, s]
    o0 = R[fm, 0, 0, s] * x0 + R[fm, 1, 0, s] * x1 + R[fm, 2, 0, s] * x2
    o1 = R[fm, 0, 1, s] * x0 + R[fm, 1, 1, s] * x1 + R[fm, 2, 1, s] * x2
    o2 = R[fm, 0, 2, s] * x0 + R[fm, 1, 2, s] * x1 + R[fm, 2, 2, s] * x2
    n = 0
    for i in range(ncov[m]):
        d0, d1, d2 = cov[m, i, 0] - o0, cov[m, i, 1] - o1, cov[m, i, 2] - o2
        rr = cov_r[m, i] + r
        if d0 * d0 + d1 * d1 + d2 * d2 <= rr * rr:
            out[n] = i
            n += 1
    return n


@numba.njit(cache=True, nogil=True, inline="always")
def _world_balls(R, p, s, fm, cov, m, idx, n, W):
    """World centers (rows of W) of m's cover balls idx[:n]."""
    for k in range(n):
        i = idx[k]
        for a in range(3):
            W[k, a] = (R[fm, a, 0, s] * cov[m, i, 0] + R[fm, a, 1, s] * cov[m, i, 1]
                       + R[fm, a, 2, s] * cov[m, i, 2] + p[fm, a, s])


@numba.njit(cache=True, nogil=True, inline="always")
def _emit(out_s, out_a, out_b, out_f, n, s, ga, gb, sure):
    """Write candidate (state s, geometries ga, gb; ``sure``: certain to collide) at n; returns
    the next free position, or -1 when the outputs are full."""
    if n == len(out_s):
        return -1
    out_s[n], out_a[n], out_b[n], out_f[n] = s, ga, gb, sure
    return n + 1


@numba.njit(cache=True, nogil=True, inline="always")
def _deep(pts, lo, hi, R, p, f, s, box_R, box_t, box_x, w, need):
    """Whether a point of pts[lo:hi] (coordinates of frame f) lies deeper than ``need`` inside
    box w (world rotation box_R[w], center box_t[w], half-extents box_x[w])."""
    for i in range(lo, hi):
        x0, x1, x2 = pts[i, 0], pts[i, 1], pts[i, 2]
        w0 = R[f, 0, 0, s] * x0 + R[f, 0, 1, s] * x1 + R[f, 0, 2, s] * x2 + p[f, 0, s] - box_t[w, 0]
        w1 = R[f, 1, 0, s] * x0 + R[f, 1, 1, s] * x1 + R[f, 1, 2, s] * x2 + p[f, 1, s] - box_t[w, 1]
        w2 = R[f, 2, 0, s] * x0 + R[f, 2, 1, s] * x1 + R[f, 2, 2, s] * x2 + p[f, 2, s] - box_t[w, 2]
        depth = math.inf
        for j in range(3):
            depth = min(depth, box_x[w, j] - abs(box_R[w, 0, j] * w0 + box_R[w, 1, j] * w1
                                                 + box_R[w, 2, j] * w2))
        if depth > need:
            return True
    return False


#: the convex stage rules a pair out only when its two convex hulls are this far apart (m)
HULL_GAP = 1e-6
#: GJK iterations before the convex stage gives up on a pair (it then stays a candidate)
GJK_STEPS = 32


@numba.njit(cache=True, nogil=True, inline="always")
def _dir(R, f, s, d0, d1, d2):
    """World direction d in the coordinates of frame f (f < 0: the world)."""
    if f < 0:
        return d0, d1, d2
    return (R[f, 0, 0, s] * d0 + R[f, 1, 0, s] * d1 + R[f, 2, 0, s] * d2,
            R[f, 0, 1, s] * d0 + R[f, 1, 1, s] * d1 + R[f, 2, 1, s] * d2,
            R[f, 0, 2, s] * d0 + R[f, 1, 2, s] * d1 + R[f, 2, 2, s] * d2)


@numba.njit(cache=True, nogil=True)
def _support(pts, lo, hi, R, p, f, s, d0, d1, d2):
    """The world position of the point of pts[lo:hi] (coordinates of frame f, f < 0: the
    world) farthest along the world direction d."""
    l0, l1, l2 = _dir(R, f, s, d0, d1, d2)
    k, best = lo, -np.inf
    for i in range(lo, hi):
        v = pts[i, 0] * l0 + pts[i, 1] * l1 + pts[i, 2] * l2
        if v > best:
            k, best = i, v
    x0, x1, x2 = pts[k, 0], pts[k, 1], pts[k, 2]
    if f < 0:
        return x0, x1, x2
    return (R[f, 0, 0, s] * x0 + R[f, 0, 1, s] * x1 + R[f, 0, 2, s] * x2 + p[f, 0, s],
            R[f, 1, 0, s] * x0 + R[f, 1, 1, s] * x1 + R[f, 1, 2, s] * x2 + p[f, 1, s],
            R[f, 2, 0, s] * x0 + R[f, 2, 1, s] * x1 + R[f, 2, 2, s] * x2 + p[f, 2, s])


@numba.njit(cache=True, nogil=True, inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(cache=True, nogil=True)
def _line(S, d):
    """The simplex S[0] (older), S[1] (newest) of GJK: keep the part nearest the origin and
    point d at the origin from it; returns the new simplex size."""
    a0, a1, a2 = S[1, 0], S[1, 1], S[1, 2]
    b0, b1, b2 = S[0, 0] - a0, S[0, 1] - a1, S[0, 2] - a2
    if -(b0 * a0 + b1 * a1 + b2 * a2) > 0.0:
        c0, c1, c2 = _cross(b0, b1, b2, -a0, -a1, -a2)
        d[0], d[1], d[2] = _cross(c0, c1, c2, b0, b1, b2)
        return 2
    S[0, 0], S[0, 1], S[0, 2] = a0, a1, a2
    d[0], d[1], d[2] = -a0, -a1, -a2
    return 1


@numba.njit(cache=True, nogil=True)
def _triangle(S, d):
    """GJK's triangle case: S[0], S[1], S[2] (newest)."""
    a0, a1, a2 = S[2, 0], S[2, 1], S[2, 2]
    b0, b1, b2 = S[1, 0] - a0, S[1, 1] - a1, S[1, 2] - a2          # ab
    c0, c1, c2 = S[0, 0] - a0, S[0, 1] - a1, S[0, 2] - a2          # ac
    n0, n1, n2 = _cross(b0, b1, b2, c0, c1, c2)                    # abc
    e0, e1, e2 = _cross(n0, n1, n2, c0, c1, c2)                    # abc x ac
    if -(e0 * a0 + e1 * a1 + e2 * a2) > 0.0:
        if -(c0 * a0 + c1 * a1 + c2 * a2) > 0.0:                   # the edge ac
            S[1, 0], S[1, 1], S[1, 2] = a0, a1, a2
            return _line(S, d)
        S[0, 0], S[0, 1], S[0, 2] = S[1, 0], S[1, 1], S[1, 2]       # the edge ab
        S[1, 0], S[1, 1], S[1, 2] = a0, a1, a2
        return _line(S, d)
    f0, f1, f2 = _cross(b0, b1, b2, n0, n1, n2)                    # ab x abc
    if -(f0 * a0 + f1 * a1 + f2 * a2) > 0.0:
        S[0, 0], S[0, 1], S[0, 2] = S[1, 0], S[1, 1], S[1, 2]
        S[1, 0], S[1, 1], S[1, 2] = a0, a1, a2
        return _line(S, d)
    if -(n0 * a0 + n1 * a1 + n2 * a2) >= 0.0:
        d[0], d[1], d[2] = n0, n1, n2
    else:
        d[0], d[1], d[2] = -n0, -n1, -n2
    return 3


@numba.njit(cache=True, nogil=True)
def _tetrahedron(S, d):
    """GJK's tetrahedron case: S[0..2], S[3] (newest). Returns 4 when the tetrahedron holds the
    origin, else reduces to the face the origin lies beyond (its normal oriented away from the
    fourth vertex, whatever the winding)."""
    a0, a1, a2 = S[3, 0], S[3, 1], S[3, 2]
    for face in range(3):
        i, j, k = (0, 1, 2) if face == 0 else ((1, 2, 0) if face == 1 else (2, 0, 1))
        # the face (S[i], S[j], a), opposite S[k]
        u0, u1, u2 = S[i, 0] - a0, S[i, 1] - a1, S[i, 2] - a2
        v0, v1, v2 = S[j, 0] - a0, S[j, 1] - a1, S[j, 2] - a2
        n0, n1, n2 = _cross(u0, u1, u2, v0, v1, v2)
        w = n0 * (S[k, 0] - a0) + n1 * (S[k, 1] - a1) + n2 * (S[k, 2] - a2)
        if w > 0.0:
            n0, n1, n2 = -n0, -n1, -n2
        if -(n0 * a0 + n1 * a1 + n2 * a2) > 0.0:
            x0, x1, x2 = S[i, 0], S[i, 1], S[i, 2]
            y0, y1, y2 = S[j, 0], S[j, 1], S[j, 2]
            S[0, 0], S[0, 1], S[0, 2] = x0, x1, x2
            S[1, 0], S[1, 1], S[1, 2] = y0, y1, y2
            S[2, 0], S[2, 1], S[2, 2] = a0, a1, a2
            return _triangle(S, d)
    return 4


@numba.njit(cache=True, nogil=True)
def apart(pts, allp, sa, ea, va, wa, ra, fa, sb, eb, vb, wb, rb, fb, R, p, s,
           d0, d1, d2, S, d):
    """Whether two convex sets are certainly more than :data:`HULL_GAP` apart: A the hull of
    pts[sa:ea] (coordinates of frame fa; f < 0: the world) grown by radius ra, B likewise.

    GJK on the difference A - B finds a direction d with every point of A - B farther than the
    gap on the far side of the origin along -d. The answer is a separating plane checked
    directly: on every point of a geometry whose hull points are not all of it
    (``allp[va:wa]``, ``allp[vb:wb]``: a mesh's vertices, whose hull holds its triangles), so
    it rests neither on GJK's arithmetic nor on the hull being exact. False (keep the pair)
    when GJK finds them touching or runs out of steps."""
    n = 0
    d[0], d[1], d[2] = d0, d1, d2
    for _ in range(GJK_STEPS):
        e0, e1, e2 = d[0], d[1], d[2]
        nd = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        if nd < 1e-12:
            return False
        x0, x1, x2 = _support(pts, sa, ea, R, p, fa, s, e0, e1, e2)
        y0, y1, y2 = _support(pts, sb, eb, R, p, fb, s, -e0, -e1, -e2)
        g = (ra + rb) / nd
        w0, w1, w2 = x0 - y0 + g * e0, x1 - y1 + g * e1, x2 - y2 + g * e2
        if w0 * e0 + w1 * e1 + w2 * e2 < -HULL_GAP * nd:
            # the certificate on every point: max over A of x.d + ra|d| < min over B - gap (a
            # set with no points of its own: its hull points are all, and GJK just did that)
            if wa > va:
                x0, x1, x2 = _support(allp, va, wa, R, p, fa, s, e0, e1, e2)
            if wb > vb:
                y0, y1, y2 = _support(allp, vb, wb, R, p, fb, s, -e0, -e1, -e2)
            ha = x0 * e0 + x1 * e1 + x2 * e2
            hb = y0 * e0 + y1 * e1 + y2 * e2
            return ha + ra * nd < hb - rb * nd - HULL_GAP * nd
        S[n, 0], S[n, 1], S[n, 2] = w0, w1, w2
        n += 1
        if n == 2:
            n = _line(S, d)
        elif n == 3:
            n = _triangle(S, d)
        elif n == 4:
            n = _tetrahedron(S, d)
            if n == 4:
                return False
        else:
            d[0], d[1], d[2] = -w0, -w1, -w2
    return False


@numba.njit(cache=True, nogil=True)
def candidates(R, p, fpos, ball_c, ball_r, obb_c, obb_R, obb_h, cov, cov_r, ncov,
               mm, table_of, table_free, bb_start, bb_m, box_R, box_t, box_h, box_r, box_half,
               mv, box_geom, hull_p, hull_s, all_p, all_s, hull_r, sure_ok, box_x, need,
               out_s, out_a, out_b, out_f, c, Wa, Wb, S, dv, ia, ib, every):
    """The candidate pairs of states 0..B-1 (R (U, 3, 3, B), p (U, 3, B): kinematics of the
    plan's frames, batch-last), written to out_s/out_a/out_b (global geometry ids) in state
    order; returns (pairs written, pairs left after the coarse stages, pairs left after the
    covers), or (-1, 0, 0) when the outputs are too short. Convex stage: geometry i (moving
    ones 0..M-1, then the obstacles) is the hull of hull_p[hull_s[i]:hull_s[i + 1]] (its
    frame's coordinates; the world's for obstacles) grown by hull_r[i], every point of it in
    the hull of all_p[all_s[i]:all_s[i + 1]] grown likewise (none there: of its hull points);
    no hull points: no convex stage. ``out_f`` marks the pairs certain to collide: moving
    geometry m with ``sure_ok[m]`` (a mesh with a convex hull, its hull points the hull's
    vertices) one of whose hull points lies deeper than ``need`` inside obstacle w, a box
    primitive of half-extents ``box_x[w]`` (``box_x[w, 0] < 0``: no box; world pose box_R[w],
    box_t[w]); such a pair is its state's last (the obstacles come first). Scratch space,
    passed in (the function allocates nothing: its module is built without numba's reference
    counting, :data:`tmpc.runtime.collision.kernel.PASS_KERNEL`): c (M, 3), Wa and Wb
    (K, 3), S (4, 3), dv (3,) floats, ia, ib and every (K,) integers (K: cover balls a
    geometry may have)."""
    B = R.shape[3]
    M = len(fpos)
    K = cov.shape[1]
    covers = 0
    for i in range(K):
        every[i] = i
    n_out = 0
    coarse = 0
    for s in range(B):
        # bounding-ball centers in the world, and the box of them all
        lo0 = lo1 = lo2 = np.inf
        hi0 = hi1 = hi2 = -np.inf
        for m in range(M):
            f = fpos[m]
            for a in range(3):
                c[m, a] = (R[f, a, 0, s] * ball_c[m, 0] + R[f, a, 1, s] * ball_c[m, 1]
                           + R[f, a, 2, s] * ball_c[m, 2] + p[f, a, s])
            r = ball_r[m]
            lo0, hi0 = min(lo0, c[m, 0] - r), max(hi0, c[m, 0] + r)
            lo1, hi1 = min(lo1, c[m, 1] - r), max(hi1, c[m, 1] + r)
            lo2, hi2 = min(lo2, c[m, 2] - r), max(hi2, c[m, 2] + r)
        # moving geometries against obstacle boxes, grouped by box (first: a pair found
        # colliding for sure there settles the state)
        sure = False
        for w in range(len(box_t)):
            h0, h1, h2 = box_half[w, 0], box_half[w, 1], box_half[w, 2]
            t0, t1, t2 = box_t[w, 0], box_t[w, 1], box_t[w, 2]
            if lo0 > t0 + h0 or hi0 < t0 - h0 or lo1 > t1 + h1 or hi1 < t1 - h1 \
                    or lo2 > t2 + h2 or hi2 < t2 - h2:
                continue
            for k in range(bb_start[w], bb_start[w + 1]):
                m = bb_m[k]
                rr = ball_r[m] + box_r[w]
                if _box_d2(box_R, box_h, w, c[m, 0] - t0, c[m, 1] - t1, c[m, 2] - t2) > rr * rr:
                    continue
                coarse += 1
                _world_balls(R, p, s, fpos[m], cov, m, every, ncov[m], Wa)
                hit = False
                for i in range(ncov[m]):
                    rr = cov_r[m, i] + box_r[w]
                    if _box_d2(box_R, box_h, w, Wa[i, 0] - t0, Wa[i, 1] - t1,
                               Wa[i, 2] - t2) <= rr * rr:
                        hit = True
                        break
                if not hit:
                    continue
                covers += 1
                o = M + w
                if hull_s[m + 1] > hull_s[m] and hull_s[o + 1] > hull_s[o] and apart(
                        hull_p, all_p, hull_s[m], hull_s[m + 1], all_s[m], all_s[m + 1],
                        hull_r[m], fpos[m], hull_s[o], hull_s[o + 1], all_s[o], all_s[o + 1],
                        hull_r[o], -1, R, p, s, t0 - c[m, 0], t1 - c[m, 1], t2 - c[m, 2], S, dv):
                    continue
                # a hull vertex of a mesh deep inside a box primitive: colliding for sure
                # (CollisionWorld._confirm says why); the state's other pairs are not needed
                sure = sure_ok[m] and box_x[w, 0] >= 0.0 and _deep(
                    hull_p, hull_s[m], hull_s[m + 1], R, p, fpos[m], s, box_R, box_t, box_x, w,
                    need)
                n_out = _emit(out_s, out_a, out_b, out_f, n_out, s, mv[m], box_geom[w], sure)
                if n_out < 0:
                    return -1, 0, 0
                if sure:
                    break
            if sure:
                break
        if sure:
            continue                    # a pair below collides for sure: done
        # pairs of moving geometries
        for k in range(len(mm)):
            a, b = mm[k, 0], mm[k, 1]
            d0, d1, d2 = c[a, 0] - c[b, 0], c[a, 1] - c[b, 1], c[a, 2] - c[b, 2]
            rab = ball_r[a] + ball_r[b]
            if d0 * d0 + d1 * d1 + d2 * d2 > rab * rab:
                continue
            t = table_of[k]
            if t >= 0 and table_free[t, s]:
                continue
            fa, fb = fpos[a], fpos[b]
            if not _box_meets_ball(R, p, s, fa, obb_c, obb_R, obb_h, a,
                                   c[b, 0], c[b, 1], c[b, 2], ball_r[b]):
                continue
            if not _box_meets_ball(R, p, s, fb, obb_c, obb_R, obb_h, b,
                                   c[a, 0], c[a, 1], c[a, 2], ball_r[a]):
                continue
            coarse += 1
            na = _near_cover(R, p, s, fa, cov, cov_r, ncov, a, c[b, 0], c[b, 1], c[b, 2],
                             ball_r[b], ia)
            if na == 0:
                continue
            nb = _near_cover(R, p, s, fb, cov, cov_r, ncov, b, c[a, 0], c[a, 1], c[a, 2],
                             ball_r[a], ib)
            if nb == 0:
                continue
            _world_balls(R, p, s, fa, cov, a, ia, na, Wa)
            _world_balls(R, p, s, fb, cov, b, ib, nb, Wb)
            hit = False
            for i in range(na):
                ra = cov_r[a, ia[i]]
                for j in range(nb):
                    e0, e1, e2 = Wa[i, 0] - Wb[j, 0], Wa[i, 1] - Wb[j, 1], Wa[i, 2] - Wb[j, 2]
                    rr = ra + cov_r[b, ib[j]]
                    if e0 * e0 + e1 * e1 + e2 * e2 <= rr * rr:
                        hit = True
                        break
                if hit:
                    break
            if not hit:
                continue
            covers += 1
            if hull_s[a + 1] > hull_s[a] and hull_s[b + 1] > hull_s[b] and apart(
                    hull_p, all_p, hull_s[a], hull_s[a + 1], all_s[a], all_s[a + 1], hull_r[a],
                    fa, hull_s[b], hull_s[b + 1], all_s[b], all_s[b + 1], hull_r[b], fb, R, p,
                    s, c[b, 0] - c[a, 0], c[b, 1] - c[a, 1], c[b, 2] - c[a, 2], S, dv):
                continue
            n_out = _emit(out_s, out_a, out_b, out_f, n_out, s, mv[a], mv[b], False)
            if n_out < 0:
                return -1, 0, 0
    return n_out, coarse, covers


@numba.njit(cache=True, nogil=True)
def kinematics(Q, parent, child, origin_R, origin_p, kind, axis, source, scale, offset, root,
               mobile, base_R, base_p, tilt, z0, missing, R, p):
    """Forward kinematics of states Q (B, n) into R (F, 3, 3, B) and p (F, 3, B), batch-last:
    the program of :class:`~tmpc.compiler.robot.FkTables` (its fields are the arguments between
    Q and R), the same products and the same Rodrigues formula as the JAX
    :func:`~tmpc.compiler.robot.make_fk` (a test holds the two within 1e-12). One loop over
    the steps, the states innermost: no dispatch, no transposes and no executable to load."""
    B = Q.shape[0]
    for f in missing:
        for i in range(3):
            for b in range(B):
                p[f, i, b] = np.nan
                for j in range(3):
                    R[f, i, j, b] = np.nan
    for b in range(B):
        if mobile:
            c, s = math.cos(Q[b, 2]), math.sin(Q[b, 2])
            for j in range(3):
                R[root, 0, j, b] = c * tilt[0, j] - s * tilt[1, j]
                R[root, 1, j, b] = s * tilt[0, j] + c * tilt[1, j]
                R[root, 2, j, b] = tilt[2, j]
            p[root, 0, b], p[root, 1, b], p[root, 2, b] = Q[b, 0], Q[b, 1], z0
        else:
            for i in range(3):
                p[root, i, b] = base_p[i]
                for j in range(3):
                    R[root, i, j, b] = base_R[i, j]
    for k in range(parent.shape[0]):
        a, c_, kd = parent[k], child[k], kind[k]
        k0, k1, k2 = axis[k, 0], axis[k, 1], axis[k, 2]
        for b in range(B):
            for i in range(3):
                r0, r1, r2 = R[a, i, 0, b], R[a, i, 1, b], R[a, i, 2, b]
                for j in range(3):
                    R[c_, i, j, b] = (r0 * origin_R[k, 0, j] + r1 * origin_R[k, 1, j]
                                      + r2 * origin_R[k, 2, j])
                p[c_, i, b] = p[a, i, b] + (r0 * origin_p[k, 0] + r1 * origin_p[k, 1]
                                            + r2 * origin_p[k, 2])
            if kd == 0:
                continue
            v = offset[k]
            if source[k] >= 0:
                v += scale[k] * Q[b, source[k]]
            if kd == 2:
                for i in range(3):
                    p[c_, i, b] += (R[c_, i, 0, b] * k0 + R[c_, i, 1, b] * k1
                                    + R[c_, i, 2, b] * k2) * v
                continue
            sv, cv = math.sin(v), 1.0 - math.cos(v)
            for i in range(3):
                x0, x1, x2 = R[c_, i, 0, b], R[c_, i, 1, b], R[c_, i, 2, b]
                # the row of R K (K: the cross-product matrix of the axis), then of R K^2
                y0, y1, y2 = x1 * k2 - x2 * k1, x2 * k0 - x0 * k2, x0 * k1 - x1 * k0
                z0_, z1, z2 = y1 * k2 - y2 * k1, y2 * k0 - y0 * k2, y0 * k1 - y1 * k0
                R[c_, i, 0, b] = x0 + y0 * sv + z0_ * cv
                R[c_, i, 1, b] = x1 + y1 * sv + z1 * cv
                R[c_, i, 2, b] = x2 + y2 * sv + z2 * cv


@numba.njit(cache=True, nogil=True)
def table_free(Q, cols, lo, step, n, wrap, rate, start, dist, out):
    """:meth:`tmpc.runtime.collision.pair_table.PairTables.free` of states Q (B, n) into out
    (T, B): table t's pair certainly does not touch in state b. Table t reads coordinates
    cols[t] (two; a one-coordinate table is padded with a coordinate of one cell and rate 0)
    on a grid from lo[t] by step[t], n[t] cells a side, wrapping where wrap[t] (2 pi); its
    distance bounds are dist[start[t]:], row-major. The numbers are the numpy formula's, one
    state and table at a time (a one-state call costs a microsecond, not a dozen numpy
    calls)."""
    two_pi = 2.0 * math.pi
    for t in range(len(start)):
        for b in range(Q.shape[0]):
            flat = start[t]
            bound = 0.0
            for k in range(2):
                x = Q[b, cols[t, k]]
                lo_k, step_k = lo[t, k], step[t, k]
                if wrap[t, k]:
                    x = (x - lo_k) % two_pi + lo_k
                i = np.int64(np.rint((x - lo_k) / step_k))
                if wrap[t, k]:
                    i = i % n[t, k]
                else:
                    i = min(max(i, 0), n[t, k] - 1)
                dev = abs(x - (lo_k + i * step_k))
                if wrap[t, k]:
                    dev = min(dev, two_pi - dev)
                bound += rate[t, k] * dev
                flat += i * n[t, 1] if k == 0 else i
            out[t, b] = dist[flat] > bound
