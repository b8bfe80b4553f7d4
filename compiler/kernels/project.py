"""Projection: from batches of start configurations, find configurations where a condition holds.

Minimizes the condition's unsatisfaction distance ``D(q)`` over the robot configuration inside its
bounds, all starts at once (``vmap``), for at most a given number of iterations (one jitted loop,
which a start leaves once its distance is 0, and a batch once all its starts have). Each
iteration takes the Newton step toward ``D = 0`` of the linearized distance (the minimum-norm
``dq`` with ``D + grad(D) . dq = 0``, i.e. ``dq = -D grad(D) / |grad(D)|^2``) over the coordinates
not pinned at a bound, scaled by ``step`` and clipped into the joint bounds (a coordinate that wraps
around, a continuous joint or the base's yaw, is never pinned: it is taken modulo its period
instead): for a distance built from comparisons this is a Gauss-Newton
step on the violated constraints, which converges in a few iterations where a plain gradient
step needs many more (``tests/bench`` compares them). A start is *converged* when its truth test
holds; callers add their own acceptance (collision-free) and report why the rest were rejected.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tmpc.compiler.jaxcfg import configured


@dataclass(frozen=True)
class ProjectionResult:
    q: np.ndarray          # (B, n) final configurations
    holds: np.ndarray      # (B,) truth test at q
    distance: np.ndarray   # (B,) distance at q
    iterations: int


def make_projector(kernel, lower, upper, iterations: int = 40, step: float = 1.0,
                   eps: float = 1e-12, wraps=None):
    """A jitted ``project(Q0, obj_T, obj_parent, args) -> (Q, holds, distance)`` for ``kernel``
    (``kernel(q, obj_T, obj_parent, args) -> (truth, distance)``)."""
    jax = configured()
    batched = projector_fn(kernel, lower, upper, step, eps, wraps)
    n = np.int64(iterations)
    return jax.jit(lambda Q0, T, par, args: batched(Q0, T, par, args, n))


def projector_fn(kernel, lower, upper, step: float = 1.0, eps: float = 1e-12, wraps=None):
    """The traceable ``project(Q0 (B, n), obj_T, obj_parent, args, iterations ()) -> (Q, holds,
    distance)``; the iteration count is an argument, so one compiled projector serves every
    caller (the planner's 15 iterations, ``tmpc sample --iterations``). ``wraps`` (n,) bool:
    the coordinates whose [lower, upper] is one period (continuous joints, the base's yaw).

    Those are wrapped into their period, not clipped: clipping pins a Newton step at +-pi (a
    continuous joint such as the PR2's forearm roll stalls there instead of going round)."""
    jax = configured()
    jnp = jax.numpy
    lo, hi = jnp.asarray(lower), jnp.asarray(upper)
    wrap = jnp.asarray(np.zeros(len(lower), bool) if wraps is None else np.asarray(wraps, bool))

    def into_bounds(q):
        return jnp.where(wrap, lo + jnp.mod(q - lo, hi - lo), jnp.clip(q, lo, hi))

    def dist(q, T, par, args):
        return kernel(q, T, par, args)[1]

    value_and_grad = jax.value_and_grad(dist)

    def one(q0, T, par, args, iterations):
        def body(carry):
            i, q, _ = carry
            d, g = value_and_grad(q, T, par, args)
            # Active set: a coordinate at a bound whose step would leave the box is frozen, so
            # the step is spent on the coordinates that can move (clipping alone stalls).
            stuck = ~wrap & (((q <= lo + 1e-9) & (g > 0)) | ((q >= hi - 1e-9) & (g < 0)))
            g = jnp.where(stuck, 0.0, g)
            gg = (g * g).sum()
            dq = jnp.where(gg > eps, -d * g / jnp.where(gg > eps, gg, 1.0), 0.0)
            return i + 1, into_bounds(q + step * dq), d

        # The carry's distance is the one at the step's start: a step from distance 0 is 0, so
        # a start stops right after it (the fixed loop's result: its later steps would all be
        # 0), and a batch (vmap) once all its starts have. One distance-and-gradient in the
        # loop's body and none outside it: a second copy doubled the executable and its load.
        n = jnp.asarray(iterations)
        start = (jnp.zeros((), n.dtype), into_bounds(q0), jnp.asarray(jnp.inf, q0.dtype))
        _, q, _ = jax.lax.while_loop(lambda c: (c[0] < n) & (c[2] > 0), body, start)
        truth, d = kernel(q, T, par, args)
        return q, truth, d

    return jax.vmap(one, in_axes=(0, None, None, None, None))


def make_gn_projector(kernel, residuals, lower, upper, iterations: int = 10,
                      damping: float = 1e-6):
    """Gauss-Newton on the residual vector ``r`` (``|r| = D``): ``dq = -J^T (J J^T + lambda I)^-1
    r``, the minimum-norm step that zeroes the linearized violations, clipped into the bounds."""
    jax = configured()
    jnp = jax.numpy
    lo, hi = jnp.asarray(lower), jnp.asarray(upper)
    jac = jax.jacfwd(residuals)

    def one(q0, T, par, args):
        def body(_, q):
            r = residuals(q, T, par, args)
            J = jac(q, T, par, args)
            A = J @ J.T + damping * jnp.eye(r.shape[0])
            dq = -J.T @ jnp.linalg.solve(A, r)
            return jnp.clip(q + dq, lo, hi)

        q = jax.lax.fori_loop(0, iterations, body, jnp.clip(q0, lo, hi))
        truth, d = kernel(q, T, par, args)
        return q, truth, d

    return jax.jit(jax.vmap(one, in_axes=(0, None, None, None)))


def project(projector, Q0, obj_T, obj_parent, args, iterations: int) -> ProjectionResult:
    Q, holds, d = projector(np.asarray(Q0, dtype=np.float64), obj_T, obj_parent, args)
    return ProjectionResult(np.asarray(Q), np.asarray(holds), np.asarray(d), iterations)


def uniform_starts(rng: np.random.Generator, lower, upper, n: int) -> np.ndarray:
    """``n`` configurations uniform in the bounds (every random choice comes from ``rng``)."""
    lower, upper = np.asarray(lower), np.asarray(upper)
    return rng.uniform(lower, upper, (n, len(lower)))
