"""JAX backend: IR -> lifted kernels giving a condition's truth and unsatisfaction distance.

A kernel is ``kernel(q, obj_T, obj_parent, args) -> (truth, distance)``:

* ``q`` (n,): the robot configuration (layout of :class:`~tmpc.compiler.robot.RobotModel`);
* ``obj_T`` (M, 4, 4): each scene object's world pose, or, for a held object, its pose in the
  holding frame; ``obj_parent`` (M,) int: -1 for a free object, else the holding frame's id;
* ``args`` (k,) int: entity ids of the predicate's arguments (the grounding, bound late).

Batch with ``jax.vmap`` over any of them. Distances follow docs/math.md §A: comparisons
``a <= b -> max(a - b, 0)``, ``a = b -> |a - b|``; ``and`` -> sqrt of the sum of squares ("l2",
the thesis) or the maximum ("max", tmit-star's outer combinator); ``or`` -> min; ``not`` is pushed
to the comparisons. ``smooth > 0`` replaces max/min of the combinators by log-sum-exp with that
temperature, for optimizers. Every operation with a singular point (sqrt, norms, atan2, acos, log)
uses the double-``where`` idiom so gradients are finite everywhere, at zero distance included.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from tmpc.compiler import ir
from tmpc.compiler.jaxcfg import configured
from tmpc.compiler.kernels.tables import KernelTables
from tmpc.compiler.robot import Frames, make_fk
from tmpc.compiler.rotations import quat_matrix

BIG = 1e6      # distance of a statically false condition (no gradient flows through it)


@dataclass(frozen=True)
class Options:
    tol: float = 1e-3
    and_mode: str = "l2"        # l2 | max
    smooth: float = 0.0         # temperature of smooth min/max; 0 = exact


class KernelError(ValueError):
    """An IR node cannot be compiled against this world (unknown entity or joint)."""


def _safe_sqrt(jnp, x):
    # sqrt'(0) is infinite; masking the input keeps the unused branch's gradient finite.
    ok = x > 0
    return jnp.where(ok, jnp.sqrt(jnp.where(ok, x, 1.0)), 0.0)


class _Emitter:
    """Evaluates IR for one state inside a traced JAX function."""

    def __init__(self, world: KernelTables, opts: Options, frames, q, obj_T, obj_parent, args,
                 lua=None):
        self.jax = configured()
        self.jnp = self.jax.numpy
        self.world, self.opts, self.q, self.args = world, opts, q, args
        #: key -> host function of a `lua` node (see :func:`lua_host_call`)
        self.lua = lua or {}
        self.cache: dict = {}
        self.R, self.p = self._pose_table(frames, obj_T, obj_parent)

    # ---- the pose table ------------------------------------------------------------------
    def _pose_table(self, frames, obj_T, obj_parent):
        jnp = self.jnp
        R_obj, p_obj = obj_T[:, :3, :3], obj_T[:, :3, 3]
        if frames is None:
            return R_obj, p_obj
        Rf, pf = frames.R, frames.p
        held = obj_parent >= 0
        k = jnp.where(held, obj_parent, 0)
        R_link, p_link = Rf[k], pf[k]
        R_w = jnp.einsum("mij,mjk->mik", R_link, R_obj)
        p_w = jnp.einsum("mij,mj->mi", R_link, p_obj) + p_link
        R_all = jnp.concatenate([Rf, jnp.where(held[:, None, None], R_w, R_obj)], 0)
        p_all = jnp.concatenate([pf, jnp.where(held[:, None], p_w, p_obj)], 0)
        return R_all, p_all

    # ---- values ----------------------------------------------------------------------------
    def val(self, n: ir.Node, env: dict):
        key = (n, tuple(sorted(env.items())))
        if key not in self.cache:
            self.cache[key] = self._val(n, env)
        return self.cache[key]

    def _val(self, n, env):
        jnp = self.jnp
        if isinstance(n, ir.Const):
            return jnp.asarray(n.value, dtype=jnp.float64) if n.vtype != ir.BOOL else n.value
        if isinstance(n, ir.Arg):
            return self.args[n.index]
        if isinstance(n, ir.Var):
            return env[n.slot]
        if isinstance(n, ir.Entity):
            e = self.world.entity(n.name)
            if e is None:
                raise KernelError(f"`{n.name}` is neither a robot frame nor a scene object")
            return e            # a static Python int: gathers with it are static
        if isinstance(n, ir.Joint):
            return self.joint(n.name)
        if isinstance(n, ir.If):
            c = self.truth(n.cond, env)
            a, b = self.val(n.then, env), self.val(n.orelse, env)
            return self.jax.tree_util.tree_map(lambda x, y: jnp.where(c, x, y), a, b)
        if isinstance(n, ir.Op):
            return _VALUE_OPS[n.op](self, n, env)
        raise KernelError(f"cannot compute the value of {ir.show(n)}")

    def joint(self, name: str):
        m = self.world.model
        if m is not None and name in m.q_names:
            return self.q[m.q_names.index(name)]
        if m is not None and name in m.fixed:
            return self.jnp.asarray(m.fixed[name])
        raise KernelError(f"the robot has no joint `{name}`")

    # ---- conditions --------------------------------------------------------------------------
    def truth(self, n: ir.Node, env: dict):
        jnp, tol = self.jnp, self.opts.tol
        if isinstance(n, ir.Const):
            return jnp.asarray(bool(n.value))
        if isinstance(n, ir.If):
            return jnp.where(self.truth(n.cond, env), self.truth(n.then, env),
                             self.truth(n.orelse, env))
        if isinstance(n, ir.Quant):
            parts = [self.truth(n.body, {**env, n.slot: e}) for e in self._domain(n)]
            if not parts:
                return jnp.asarray(n.kind == "forall")
            stack = jnp.stack(parts)
            return stack.all() if n.kind == "forall" else stack.any()
        o, a = n.op, n.args
        if o in ("le", "lt"):
            return self.val(a[0], env) <= self.val(a[1], env) + tol
        if o in ("ge", "gt"):
            return self.val(a[0], env) >= self.val(a[1], env) - tol
        if o == "eq":
            return jnp.abs(self.val(a[0], env) - self.val(a[1], env)) <= tol
        if o == "same":
            return self.val(a[0], env) == self.val(a[1], env)
        if o == "holds":
            return self.val(a[0], env) <= tol
        if o == "lua":
            return self.val(n, env) <= tol
        if o == "inside":
            p, (lo, hi) = self.val(a[0], env), self.val(a[1], env)
            return jnp.all(p >= lo - tol) & jnp.all(p <= hi + tol)
        if o == "and":
            return jnp.stack([self.truth(x, env) for x in a]).all()
        if o == "or":
            return jnp.stack([self.truth(x, env) for x in a]).any()
        if o == "not":
            return ~self.truth(a[0], env)
        if o == "implies":
            return ~self.truth(a[0], env) | self.truth(a[1], env)
        raise KernelError(f"{ir.show(n)} is not a condition")

    def _domain(self, n: ir.Quant) -> tuple[int, ...]:
        ids: set[int] = set()
        for t in n.domain:
            ids.update(self.world.domains.get(t, ()))
        return tuple(sorted(ids))

    # ---- distances ---------------------------------------------------------------------------
    def dist(self, n: ir.Node, env: dict, neg: bool = False):
        """Unsatisfaction distance of ``n`` (of ``not n`` when ``neg``): 0 where it holds."""
        jnp, tol = self.jnp, self.opts.tol
        if isinstance(n, ir.Const):
            holds = bool(n.value) != neg
            return jnp.asarray(0.0 if holds else BIG)
        if isinstance(n, ir.If):
            return jnp.where(self.truth(n.cond, env), self.dist(n.then, env, neg),
                             self.dist(n.orelse, env, neg))
        if isinstance(n, ir.Quant):
            parts = [self.dist(n.body, {**env, n.slot: e}, neg) for e in self._domain(n)]
            conj = (n.kind == "forall") != neg
            if not parts:
                return jnp.asarray(0.0 if conj else BIG)
            return self.conj(parts) if conj else self.disj(parts)
        o, a = n.op, n.args
        if o in ("le", "lt", "ge", "gt"):
            x, y = self.val(a[0], env), self.val(a[1], env)
            if o in ("ge", "gt"):
                x, y = y, x                       # now: x <= y wanted
            return jnp.maximum(y - x, 0.0) if neg else jnp.maximum(x - y, 0.0)
        if o == "eq":
            d = jnp.abs(self.val(a[0], env) - self.val(a[1], env))
            return jnp.maximum(tol - d, 0.0) if neg else d
        if o == "same":
            same = self.val(a[0], env) == self.val(a[1], env)
            return jnp.where(same != neg, 0.0, BIG)
        if o in ("holds", "lua"):
            d = self.val(a[0] if o == "holds" else n, env)
            return jnp.maximum(tol - d, 0.0) if neg else jnp.maximum(d, 0.0)
        if o == "inside":
            p, (lo, hi) = self.val(a[0], env), self.val(a[1], env)
            if neg:   # outside: the point beyond some face
                return self.disj([jnp.maximum(p[i] - lo[i], 0.0) for i in range(3)] +
                                 [jnp.maximum(hi[i] - p[i], 0.0) for i in range(3)])
            return self.conj([jnp.maximum(lo[i] - p[i], 0.0) for i in range(3)] +
                             [jnp.maximum(p[i] - hi[i], 0.0) for i in range(3)])
        if o in ("and", "or"):
            parts = [self.dist(x, env, neg) for x in a]
            return self.conj(parts) if (o == "and") != neg else self.disj(parts)
        if o == "not":
            return self.dist(a[0], env, not neg)
        if o == "implies":    # (not a) or b
            parts = [self.dist(a[0], env, not neg), self.dist(a[1], env, neg)]
            return self.conj(parts) if neg else self.disj(parts)
        raise KernelError(f"{ir.show(n)} is not a condition")

    # ---- residual vectors (for Gauss-Newton projection) --------------------------------------
    def residuals(self, n: ir.Node, env: dict, neg: bool = False):
        """A vector r with ``D = |r|`` for l2 conjunctions: one entry per violated leaf of the
        conjunctive structure; a disjunction contributes its closest branch (padded to the
        longest branch, selected with ``where``, so shapes are static)."""
        jnp = self.jnp
        if isinstance(n, ir.Op) and n.op == "not":
            return self.residuals(n.args[0], env, not neg)
        if isinstance(n, ir.Op) and n.op in ("and", "or", "implies"):
            if n.op == "implies":
                parts = [(n.args[0], not neg), (n.args[1], neg)]
                conj = neg
            else:
                parts = [(x, neg) for x in n.args]
                conj = (n.op == "and") != neg
            vecs = [self.residuals(x, env, ng) for x, ng in parts]
            return jnp.concatenate(vecs) if conj else self._closest(vecs, parts, env)
        if isinstance(n, ir.Quant):
            conj = (n.kind == "forall") != neg
            vecs = [self.residuals(n.body, {**env, n.slot: e}, neg) for e in self._domain(n)]
            if not vecs:
                return jnp.zeros(1)
            if conj:
                return jnp.concatenate(vecs)
            return self._closest(vecs, [(n.body, neg)] * len(vecs), env,
                                 envs=[{**env, n.slot: e} for e in self._domain(n)])
        if isinstance(n, ir.Op) and n.op == "inside" and not neg:
            p, (lo, hi) = self.val(n.args[0], env), self.val(n.args[1], env)
            return jnp.concatenate([jnp.maximum(lo - p, 0.0), jnp.maximum(p - hi, 0.0)])
        return jnp.reshape(self.dist(n, env, neg), (1,))

    def _closest(self, vecs, parts, env, envs=None):
        jnp = self.jnp
        envs = envs or [env] * len(vecs)
        size = max(v.shape[0] for v in vecs)
        padded = jnp.stack([jnp.pad(v, (0, size - v.shape[0])) for v in vecs])
        d = jnp.stack([self.dist(x, e, ng) for (x, ng), e in zip(parts, envs)])
        return padded[jnp.argmin(d)]

    def conj(self, parts):
        jnp = self.jnp
        w = jnp.stack([jnp.maximum(x, 0.0) for x in parts])
        if self.opts.and_mode == "max":
            t = self.opts.smooth
            return t * self.jax.nn.logsumexp(w / t) if t > 0 else w.max()
        return _safe_sqrt(jnp, (w * w).sum())

    def disj(self, parts):
        jnp = self.jnp
        w = jnp.stack(parts)
        t = self.opts.smooth
        return -t * self.jax.nn.logsumexp(-w / t) if t > 0 else w.min()


# ---------------------------------------------------------------------------------------------
# value operators


def _a(em, n, env, i=0):
    return em.val(n.args[i], env)


def _matrix_from_quat(jnp, q):
    # the code base's one quaternion -> matrix formula, in a jax.numpy array (same traced ops)
    return quat_matrix((q[0], q[1], q[2], q[3]), jnp)


def _rot_of(em, n, env):
    v = _a(em, n, env)
    return _matrix_from_quat(em.jnp, v) if n.args[0].type == ir.QUAT else v[0]


def _quat_from_matrix(jnp, R):
    """Rotation matrix -> unit quaternion (x, y, z, w), w >= 0 (NaN-free gradients)."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    w = 0.5 * _safe_sqrt(jnp, 1.0 + tr)
    x = 0.5 * _safe_sqrt(jnp, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])
    y = 0.5 * _safe_sqrt(jnp, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])
    z = 0.5 * _safe_sqrt(jnp, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])
    x = jnp.where(R[2, 1] - R[1, 2] < 0, -x, x)
    y = jnp.where(R[0, 2] - R[2, 0] < 0, -y, y)
    z = jnp.where(R[1, 0] - R[0, 1] < 0, -z, z)
    return jnp.stack([x, y, z, w])


def _atan2(jnp, y, x):
    zero = (x == 0) & (y == 0)
    return jnp.where(zero, 0.0, jnp.arctan2(jnp.where(zero, 1.0, y), jnp.where(zero, 1.0, x)))


def _arc(jnp, fn, x):
    inside = jnp.abs(x) < 1
    return jnp.where(inside, fn(jnp.where(inside, x, 0.0)), fn(jnp.clip(x, -1.0, 1.0)))


def _rpy(jnp, R):
    pitch = _arc(jnp, jnp.arcsin, -R[2, 0])
    return jnp.stack([_atan2(jnp, R[2, 1], R[2, 2]), pitch, _atan2(jnp, R[1, 0], R[0, 0])])


def _support_world(em, e):
    """World-frame box enclosing an entity's support region (its 8 corners, rotated)."""
    jnp = em.jnp
    box = jnp.asarray(em.world.support_local)[e]           # (2, 3)
    lo, hi = box[0], box[1]
    corners = jnp.stack([jnp.stack([sx, sy, sz]) for sx in (lo[0], hi[0])
                         for sy in (lo[1], hi[1]) for sz in (lo[2], hi[2])])
    world = corners @ em.R[e].T + em.p[e]
    return world.min(0), world.max(0)


def _log(jnp, x):
    ok = x > 0
    return jnp.where(ok, jnp.log(jnp.where(ok, x, 1.0)), -BIG)


_VALUE_OPS = {
    "add": lambda em, n, e: _a(em, n, e, 0) + _a(em, n, e, 1),
    "sub": lambda em, n, e: _a(em, n, e, 0) - _a(em, n, e, 1),
    "mul": lambda em, n, e: _a(em, n, e, 0) * _a(em, n, e, 1),
    "div": lambda em, n, e: _a(em, n, e, 0) / _a(em, n, e, 1),
    "neg": lambda em, n, e: -_a(em, n, e),
    "abs": lambda em, n, e: em.jnp.abs(_a(em, n, e)),
    "sqrt": lambda em, n, e: _safe_sqrt(em.jnp, _a(em, n, e)),
    "exp": lambda em, n, e: em.jnp.exp(_a(em, n, e)),
    "log": lambda em, n, e: _log(em.jnp, _a(em, n, e)),
    "sin": lambda em, n, e: em.jnp.sin(_a(em, n, e)),
    "cos": lambda em, n, e: em.jnp.cos(_a(em, n, e)),
    "tan": lambda em, n, e: em.jnp.tan(_a(em, n, e)),
    "asin": lambda em, n, e: _arc(em.jnp, em.jnp.arcsin, _a(em, n, e)),
    "acos": lambda em, n, e: _arc(em.jnp, em.jnp.arccos, _a(em, n, e)),
    "pow": lambda em, n, e: em.jnp.power(_a(em, n, e, 0), _a(em, n, e, 1)),
    "atan2": lambda em, n, e: _atan2(em.jnp, _a(em, n, e, 0), _a(em, n, e, 1)),
    "min": lambda em, n, e: em.jnp.minimum(_a(em, n, e, 0), _a(em, n, e, 1)),
    "max": lambda em, n, e: em.jnp.maximum(_a(em, n, e, 0), _a(em, n, e, 1)),
    "clamp": lambda em, n, e: em.jnp.clip(_a(em, n, e, 0), _a(em, n, e, 1), _a(em, n, e, 2)),
    "vec3": lambda em, n, e: em.jnp.stack([_a(em, n, e, i) for i in range(3)]),
    "norm": lambda em, n, e: _safe_sqrt(em.jnp, (_a(em, n, e) ** 2).sum()),
    "norm1": lambda em, n, e: em.jnp.abs(_a(em, n, e)).sum(),
    "dot": lambda em, n, e: (_a(em, n, e, 0) * _a(em, n, e, 1)).sum(),
    "cross": lambda em, n, e: em.jnp.cross(_a(em, n, e, 0), _a(em, n, e, 1)),
    "distance": lambda em, n, e: _safe_sqrt(em.jnp, ((_a(em, n, e, 0) - _a(em, n, e, 1)) ** 2)
                                            .sum()),
    "component": lambda em, n, e: _a(em, n, e)[int(n.args[1].value)],
    "pose": lambda em, n, e: (em.R[_a(em, n, e)], em.p[_a(em, n, e)]),
    "position": lambda em, n, e: _a(em, n, e)[1],
    "orientation": lambda em, n, e: _quat_from_matrix(em.jnp, _a(em, n, e)[0]),
    "rotation_axis": lambda em, n, e: _rot_of(em, n, e)[:, int(n.args[1].value)],
    "rotate": lambda em, n, e: _matrix_from_quat(em.jnp, _a(em, n, e, 0)) @ _a(em, n, e, 1),
    "relative": lambda em, n, e: _a(em, n, e, 1)[0].T @ (_a(em, n, e, 0)[1] - _a(em, n, e, 1)[1]),
    "rpy": lambda em, n, e: _rpy(em.jnp, _rot_of(em, n, e)),
    "extent": lambda em, n, e: em.jnp.asarray(em.world.extents)[_a(em, n, e)],
    "support": lambda em, n, e: _support_world(em, _a(em, n, e)),
    "support_local": lambda em, n, e: tuple(em.jnp.asarray(em.world.support_local)[_a(em, n, e)]),
    "grasp_point": lambda em, n, e: em.jnp.asarray(em.world.scene_vectors["grasp_point"])[
        _a(em, n, e)],
    "grasp_axis": lambda em, n, e: em.jnp.asarray(em.world.scene_vectors["grasp_axis"])[
        _a(em, n, e)],
    "grasp_hand_axis": lambda em, n, e: em.jnp.asarray(em.world.scene_vectors["grasp_hand_axis"])[
        _a(em, n, e)],
    "stable_up": lambda em, n, e: em.jnp.asarray(em.world.scene_vectors["stable_up"])[
        _a(em, n, e)],
    "base": lambda em, n, e: (em.R[em.world.entity(em.world.model.tree.root)],
                              em.p[em.world.entity(em.world.model.tree.root)]),
    "box": lambda em, n, e: (_a(em, n, e, 0), _a(em, n, e, 1)),
    "grow": lambda em, n, e: _grow(em, n, e),
    "lower": lambda em, n, e: _a(em, n, e)[0],
    "upper": lambda em, n, e: _a(em, n, e)[1],
    "center": lambda em, n, e: (_a(em, n, e)[0] + _a(em, n, e)[1]) / 2,
    "lua": lambda em, n, e: _lua_distance(em, n, e),
}


def _lua_distance(em, n, env):
    """The distance of a `lua` node: its arguments' world poses (k, 7) from the pose table, the
    host function called through ``jax.pure_callback`` (see :func:`lua_host_call`)."""
    jnp = em.jnp
    key = n.args[0].value
    call = em.lua.get(key)
    if call is None:
        raise KernelError(f"no Lua function registered for {ir.show(n)}")
    ids = [em.val(a, env) for a in n.args[1:]]
    poses = jnp.stack([jnp.concatenate([em.p[e], _quat_from_matrix(jnp, em.R[e])]) for e in ids])
    return call(poses, jnp.stack([jnp.asarray(e, dtype=jnp.int64) for e in ids]))


def lua_host_call(fallback, world: KernelTables):
    """A JAX function ``call(poses (k, 7), ids (k,)) -> distance`` evaluating a
    :class:`~tmpc.compiler.lua_trace.LuaFallback` on the host.

    ``jax.pure_callback`` (``vmap_method="broadcast_all"``: one host call per batch, looping over
    its rows in Python) wrapped in ``jax.custom_jvp``: the callback returns the distance and its
    gradient with respect to the poses (dual numbers in Lua), and the JVP is that gradient dotted
    with the poses' tangent, so derivatives with respect to ``q`` compose with JAX's own through
    the forward kinematics. Names and support boxes (own frame, NaN rows = none) are looked up
    from the ids on the host. Kernels containing it cannot be serialized by ``jax.export``.
    """
    jax = configured()
    jnp = jax.numpy
    names, support = world.names, np.asarray(world.support_local)
    lock = threading.Lock()            # one Lua state per module: not thread-safe

    def host(poses, ids, gradient=True):
        poses, ids = np.asarray(poses, dtype=np.float64), np.asarray(ids, dtype=np.int64)
        batch = poses.shape[:-2]
        k = poses.shape[-2]
        P, I = poses.reshape(-1, k, 7), ids.reshape(-1, k)
        d, g = np.empty(len(P)), np.empty((len(P), k, 7))
        with lock:
            for r in range(len(P)):
                sup = [None if np.isnan(support[e]).any() else support[e] for e in I[r]]
                d[r], g[r] = fallback(P[r], sup, [names[e] for e in I[r]], gradient=gradient)
        return (d.reshape(batch), g.reshape(*batch, k, 7)) if gradient else d.reshape(batch)

    def both(poses, ids):
        shapes = (jax.ShapeDtypeStruct(poses.shape[:-2], jnp.float64),
                  jax.ShapeDtypeStruct(poses.shape, jnp.float64))
        return jax.pure_callback(host, shapes, poses, ids, vmap_method="broadcast_all")

    @jax.custom_jvp
    def call(poses, ids):           # undifferentiated: the distance alone (no dual numbers)
        return jax.pure_callback(lambda p, i: host(p, i, False),
                                 jax.ShapeDtypeStruct(poses.shape[:-2], jnp.float64), poses, ids,
                                 vmap_method="broadcast_all")

    @call.defjvp
    def _jvp(primals, tangents):
        poses, ids = primals
        d, g = both(poses, ids)
        return d, (g * tangents[0]).sum((-2, -1))

    return call


def _grow(em, n, env):
    jnp = em.jnp
    lo, hi = _a(em, n, env, 0)
    dx, dy, dz = (_a(em, n, env, i) for i in (1, 2, 3))
    return lo - jnp.stack([dx, dy, jnp.zeros_like(dz)]), hi + jnp.stack([dx, dy, dz])


# ---------------------------------------------------------------------------------------------
# kernels


def _needs_frames(node: ir.Node) -> bool:
    return any(isinstance(n, (ir.Joint,)) or (isinstance(n, ir.Op) and n.op in
                                              ("pose", "base", "lua"))
               for n in ir.walk(node))


def has_lua_calls(node: ir.Node) -> bool:
    """Whether a formula calls a Lua function on the host (then ``jax.export`` cannot
    serialize its kernel)."""
    return any(isinstance(n, ir.Op) and n.op == "lua" for n in ir.walk(node))


def condition_kernel(node: ir.Node, world: KernelTables, opts: Options = Options(),
                     frames=None, lua=None, dist_node: ir.Node | None = None):
    """``kernel(q, obj_T, obj_parent, args) -> (truth, distance)`` (not jitted).

    ``frames``: the robot frame ids this kernel may read (its possible arguments, the constants it
    names and the frames that may hold objects); forward kinematics is limited to their chains.
    ``lua``: key -> :func:`lua_host_call` of the formula's `lua` nodes. ``dist_node``: the
    condition whose distance is returned, when not ``node`` (a projector's inner bands,
    :mod:`tmpc.compiler.kernels.bands`); the truth is always ``node``'s.
    """
    fk = make_fk(world.model, frames) if world.model is not None else None
    frames_needed = fk is not None and _needs_frames(node)
    measured = node if dist_node is None else dist_node

    def kernel(q, obj_T, obj_parent, args):
        frames = fk(q) if frames_needed else None
        if frames is None and world.model is not None:
            frames = _static_frames(world)
        em = _Emitter(world, opts, frames, q, obj_T, obj_parent, args, lua)
        return em.truth(node, {}), em.dist(measured, {})

    _check_buildable(node, world)
    return kernel


def residual_kernel(node: ir.Node, world: KernelTables, opts: Options = Options(),
                    frames=None, lua=None):
    """``kernel(q, obj_T, obj_parent, args) -> r`` with ``|r| = D`` (l2), for Gauss-Newton."""
    fk = make_fk(world.model, frames) if world.model is not None else None

    def kernel(q, obj_T, obj_parent, args):
        frames = fk(q) if fk is not None else None
        return _Emitter(world, opts, frames, q, obj_T, obj_parent, args,
                        lua).residuals(node, {})

    _check_buildable(node, world)
    return kernel


def value_kernel(node: ir.Node, world: KernelTables):
    """``kernel(q, obj_T, obj_parent, args) -> value`` of a non-condition expression."""
    fk = make_fk(world.model) if world.model is not None else None

    def kernel(q, obj_T, obj_parent, args):
        frames = fk(q) if fk is not None else None
        return _Emitter(world, Options(), frames, q, obj_T, obj_parent, args).val(node, {})

    _check_buildable(node, world)
    return kernel


def _static_frames(world: KernelTables):
    """Frames are only gathered from when a formula reads no robot pose; zeros are enough."""
    jnp = configured().numpy
    F = world.n_frames
    return Frames(jnp.zeros((F, 3, 3)), jnp.zeros((F, 3)))


def _check_buildable(node: ir.Node, world: KernelTables) -> None:
    for name in ir.entities_used(node):
        if world.entity(name) is None:
            raise KernelError(f"`{name}` is neither a robot frame nor a scene object")
    m = world.model
    for name in ir.joints_used(node):
        if m is None or (name not in m.q_names and name not in m.fixed):
            raise KernelError(f"the robot has no joint `{name}`")


def state_inputs(world: KernelTables, state) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, obj_T, obj_parent) kernel inputs from a :class:`~tmpc.compiler.state.WorldState`."""
    M = world.n_objects
    obj_T = np.tile(np.eye(4), (M, 1, 1))
    parent = np.full(M, -1, dtype=np.int64)
    for k, o in enumerate(world.scene.objects):
        if o.name in state.held:
            frame, T = state.held[o.name]
            obj_T[k], parent[k] = T, world.entity(frame)
        elif o.name in state.poses:
            obj_T[k] = state.poses[o.name]
    q = np.asarray(state.q, dtype=np.float64)
    return q, obj_T, parent
