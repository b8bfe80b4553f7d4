"""A direct numpy interpreter of tmpc expressions at one world state.

It backs `tmpc eval --expr` and serves the compiler's tests as an independent reference: it walks
the AST and never touches the compiler's IR or kernels. Values: ``float``, ``np.ndarray`` (3,)
for vec3, :class:`Quat`, :class:`AABB`, ``np.ndarray`` (4, 4) for transforms, ``bool``, and
:class:`Obj` for objects/frames. Comparisons hold within ``tol`` (default 1e-3, docs/design.md §4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tmpc.compiler.robot import RobotModel, homogeneous
from tmpc.compiler.rotations import quat_from_matrix, quat_matrix, rpy_of
from tmpc.compiler.scene_data import scene_vectors
from tmpc.lang import ast as A
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.symbols import NUMBER_CONSTANTS
from tmpc.lang.world import Scene, dispatch_shape


@dataclass(frozen=True)
class Obj:
    """A named thing with a pose: a robot frame or a scene object."""

    name: str


@dataclass(frozen=True)
class Quat:
    xyzw: tuple[float, float, float, float]


@dataclass(frozen=True)
class AABB:
    lower: np.ndarray
    upper: np.ndarray


class EvalError(InputError):
    """An expression that cannot be evaluated at this state (unknown name, bad types)."""


def _fail(msg: str, node=None, hint: str | None = None) -> EvalError:
    return EvalError(error("E581", msg, getattr(node, "span", None), hint))


def _rot(T_or_R) -> np.ndarray:
    M = np.asarray(T_or_R)
    return M[:3, :3]


class Evaluator:
    """Evaluate expressions against: robot frames (FK output), object world poses, the scene."""

    def __init__(self, scene: Scene, model: RobotModel | None, q: np.ndarray | None,
                 frames, poses: dict[str, np.ndarray], scope=None, tol: float = 1e-3):
        self.scene, self.model, self.q, self.scope, self.tol = scene, model, q, scope, tol
        self.T_frames = homogeneous(frames) if frames is not None else None
        self.poses = {k.lower(): (k, v) for k, v in poses.items()}

    # ---- names ---------------------------------------------------------------------------
    def transform_of(self, o: Obj, node=None) -> np.ndarray:
        hit = self.poses.get(o.name.lower())
        if hit is not None:
            return hit[1]
        if self.model is not None and self.model.frame(o.name) is not None:
            return self.T_frames[self.model.frame(o.name)]
        raise _fail(f"`{o.name}` is neither a scene object nor a robot frame", node,
                    "robot frames are URDF link or joint names")

    def resolve(self, e: A.ExprName):
        key = e.name.key
        if key in NUMBER_CONSTANTS:
            return NUMBER_CONSTANTS[key]
        if key in self.poses or (self.model is not None and
                                 self.model.frame(e.name.text) is not None):
            return Obj(self.poses[key][0] if key in self.poses else e.name.text)
        if self.scope is not None and key in self.scope.objects:
            return Obj(self.scope.objects[key].name.text)
        raise _fail(f"unknown name `{e.name.text}`", e,
                    "names are scene objects, robot links/joints, or `pi`")

    # ---- expressions ---------------------------------------------------------------------
    def value(self, e: A.Expr, env: dict | None = None):
        env = env or {}
        if isinstance(e, A.Num):
            return e.value
        if isinstance(e, A.ExprVar):
            if e.name.key not in env:
                raise _fail(f"unbound variable `{e.name.text}`", e)
            return env[e.name.key]
        if isinstance(e, A.ExprName):
            return self.resolve(e)
        if isinstance(e, A.Let):
            inner = dict(env)
            for b in e.bindings:
                inner[b.name.key] = self.value(b.value, inner)
            return self.value(e.body, inner)
        if isinstance(e, A.If):
            return self.value(e.then if self.value(e.cond, env) else e.orelse, env)
        if isinstance(e, A.ExprQuant):
            results = [self.value(e.body, {**env, **binding})
                       for binding in self._bindings(e.params, e)]
            return all(results) if e.kind == "forall" else any(results)
        return self.call(e, env)

    # ---- unsatisfaction distance (docs/math.md §A), straight from the AST ------------------
    def distance(self, e: A.Expr, env: dict | None = None, neg: bool = False,
                 and_mode: str = "l2") -> float:
        """W of a condition (of its negation when ``neg``): 0 exactly where it holds."""
        env = env or {}
        d = lambda x, n=neg, v=env: self.distance(x, v, n, and_mode)   # noqa: E731
        conj = (lambda ws: math.sqrt(sum(max(w, 0.0) ** 2 for w in ws))) if and_mode == "l2" \
            else (lambda ws: max(max(w, 0.0) for w in ws))
        if isinstance(e, A.Let):
            inner = dict(env)
            for b in e.bindings:
                inner[b.name.key] = self.value(b.value, inner)
            return self.distance(e.body, inner, neg, and_mode)
        if isinstance(e, A.If):
            return d(e.then if self.value(e.cond, env) else e.orelse)
        if isinstance(e, A.ExprQuant):
            ws = [self.distance(e.body, {**env, **b}, neg, and_mode)
                  for b in self._bindings(e.params, e)]
            all_of = (e.kind == "forall") != neg
            if not ws:
                return 0.0 if all_of else 1e6
            return conj(ws) if all_of else min(ws)
        if not isinstance(e, A.Call):
            raise _fail("not a condition", e)
        op, args = e.op.key, e.args
        if op in ("and", "or"):
            ws = [d(a) for a in args]
            return conj(ws) if (op == "and") != neg else min(ws)
        if op == "not":
            return d(args[0], not neg)
        if op == "implies":
            ws = [d(args[0], not neg), d(args[1])]
            return conj(ws) if neg else min(ws)
        if op in ("<", "<=", ">", ">=", "="):
            a, b = self.value(args[0], env), self.value(args[1], env)
            if isinstance(a, Obj):
                same = a.name.lower() == b.name.lower()
                return 0.0 if same != neg else 1e6
            if op == "=":
                return max(self.tol - abs(a - b), 0.0) if neg else abs(a - b)
            if op in (">", ">="):
                a, b = b, a
            return max(b - a, 0.0) if neg else max(a - b, 0.0)
        if op == "inside":
            p, box = _vec(self.value(args[0], env)), self.value(args[1], env)
            below = [box.lower[i] - p[i] for i in range(3)] + [p[i] - box.upper[i] for i in range(3)]
            if neg:
                return min(max(-x, 0.0) for x in below)
            return conj(below)
        if self.scope is not None:
            target = self.scope.helper(op) or self.scope.predicates.get(op)
            body = getattr(target, "body", None) or getattr(target, "semantics", None)
            if body is not None:
                vals = [self.value(a, env) for a in args]
                return self.distance(body, {q.name.key: v for q, v in zip(target.params, vals)},
                                     neg, and_mode)
        raise _fail(f"`{e.op.text}` is not a condition", e)

    def _bindings(self, params, node):
        if self.scope is None:
            raise _fail("`forall`/`exists` need the problem's objects; pass a domain and problem",
                        node)
        from itertools import product
        domains = []
        for p in params:
            want = [n.key for n in p.type.names] if p.type else ["object"]
            objs = [Obj(info.name.text) for info in self.scope.objects.values()
                    if self.scope.compatible(info.types, tuple(want))]
            domains.append(objs)
        for combo in product(*domains):
            yield {p.name.key: o for p, o in zip(params, combo)}

    def call(self, e: A.Call, env: dict):
        op = e.op.key
        if op == "joint":
            return self.joint(e)
        fn = _OPS.get(op)
        if fn is not None:
            args = [self.value(a, env) for a in e.args]
            try:
                return fn(self, e, *args)
            except (TypeError, ValueError, ZeroDivisionError) as exc:
                raise _fail(f"`{e.op.text}`: {exc}", e) from None
        if self.scope is not None:
            helper = self.scope.helper(op)
            if helper is not None:
                args = [self.value(a, env) for a in e.args]
                return self.value(helper.body, {q.name.key: a for q, a in zip(helper.params, args)})
            pred = self.scope.predicates.get(op)
            if pred is not None and pred.semantics is not None:
                args = [self.value(a, env) for a in e.args]
                return self.value(pred.semantics, {q.name.key: a
                                                   for q, a in zip(pred.params, args)})
        raise _fail(f"unknown operator `{e.op.text}`", e)

    def joint(self, e: A.Call) -> float:
        name = e.args[0].name.text if e.args and isinstance(e.args[0], A.ExprName) else "?"
        m = self.model
        if m is not None and name in m.q_names:
            return float(self.q[m.q_names.index(name)])
        if m is not None and name in m.fixed:
            return float(m.fixed[name])
        raise _fail(f"unknown joint `{name}`", e)

    # ---- geometry helpers --------------------------------------------------------------------
    def T(self, v, e) -> np.ndarray:
        if isinstance(v, Obj):
            return self.transform_of(v, e)
        if isinstance(v, np.ndarray) and v.shape == (4, 4):
            return v
        raise TypeError(f"expected an object or a transform, got {_show(v)}")

    def R(self, v, e) -> np.ndarray:
        return quat_matrix(v.xyzw) if isinstance(v, Quat) else _rot(self.T(v, e))

    def extent(self, o: Obj, e) -> np.ndarray:
        obj = self.scene.object(o.name)
        if obj is None or obj.shape is None:
            raise _fail(f"`{o.name}` has no shape in the scene", e)
        return dispatch_shape(_EXTENT, obj.shape, "extent")(obj.shape)

    def support(self, o: Obj, e) -> AABB:
        obj = self.scene.object(o.name)
        if obj is None or obj.support is None:
            raise _fail(f"`{o.name}` has no support region in the scene", e,
                        "surfaces declare `support` (tmit-star: `surface_bounds`, planet: `sssp`)")
        T = self.transform_of(Obj(obj.name), e)
        lo, hi = np.array(obj.support.lower), np.array(obj.support.upper)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        world = corners @ T[:3, :3].T + T[:3, 3]
        return AABB(world.min(0), world.max(0))

    def local_support(self, o: Obj, e) -> AABB:
        obj = self.scene.object(o.name)
        if obj is None or obj.support is None:
            raise _fail(f"`{o.name}` has no support region in the scene", e,
                        "surfaces declare `support` (tmit-star: `surface_bounds`, planet: `sssp`)")
        return AABB(np.array(obj.support.lower, float), np.array(obj.support.upper, float))

    def scene_vector(self, key: str, o: Obj, e) -> np.ndarray:
        obj = self.scene.object(o.name)
        v = scene_vectors(obj)[key] if obj is not None else np.full(3, np.nan)
        if np.isnan(v).any():
            what = "grasp set (<grasps>)" if key.startswith("grasp") else "stable pose (<sop>)"
            raise _fail(f"`{o.name}` has no {what} in the scene", e)
        return v


def _show(v) -> str:
    if isinstance(v, Obj):
        return f"object `{v.name}`"
    if isinstance(v, bool):
        return "a condition"
    if isinstance(v, float):
        return "a scalar"
    if isinstance(v, np.ndarray):
        return "a vec3" if v.shape == (3,) else "a transform"
    return type(v).__name__


def _num(v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise TypeError(f"expected a scalar, got {_show(v)}")
    return float(v)


def _vec(v) -> np.ndarray:
    if not (isinstance(v, np.ndarray) and v.shape == (3,)):
        raise TypeError(f"expected a vec3, got {_show(v)}")
    return v


def _divide(x, y):
    """IEEE division, as the kernels compute it: x/0 is +-inf, 0/0 nan (docs/language.md)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.divide(np.asarray(x, float), np.asarray(y, float))
    return float(out) if np.ndim(out) == 0 else out


def _arith(op):
    def f(ev, e, *args):
        if len(args) == 1 and op == "-":
            return -args[0]
        acc = args[0]
        for a in args[1:]:
            acc = {"+": lambda x, y: x + y, "-": lambda x, y: x - y,
                   "*": lambda x, y: x * y, "/": _divide}[op](acc, a)
        return acc
    return f


def _cmp(op):
    def f(ev, e, a, b):
        if isinstance(a, Obj) or isinstance(b, Obj):
            if op != "=":
                raise TypeError("objects compare only with `=`")
            return isinstance(a, Obj) and isinstance(b, Obj) and a.name.lower() == b.name.lower()
        a, b, t = _num(a), _num(b), ev.tol
        return {"<": a < b + t, "<=": a <= b + t, ">": a > b - t, ">=": a >= b - t,
                "=": abs(a - b) <= t}[op]
    return f


def _axis(i):
    return lambda ev, e, v: ev.R(v, e)[:, i].copy()


def _component(i):
    def f(ev, e, v):
        if isinstance(v, Obj):
            return float(ev.T(v, e)[i, 3])
        return float(_vec(v)[i])
    return f


def _grow(ev, e, b, *d):
    d = [_num(x) for x in d]
    dx, dy, dz = d if len(d) == 3 else (d[0], d[0], d[0])
    return AABB(b.lower - np.array([dx, dy, 0.0]), b.upper + np.array([dx, dy, dz]))


def _inside(ev, e, p, b):
    p, t = _vec(p), ev.tol
    return bool(np.all(p >= b.lower - t) and np.all(p <= b.upper + t))


def _scalar1(fn):
    return lambda ev, e, a: float(fn(_num(a)))


_OPS = {
    "+": _arith("+"), "-": _arith("-"), "*": _arith("*"), "/": _arith("/"),
    "abs": _scalar1(abs), "sqrt": _scalar1(math.sqrt), "exp": _scalar1(math.exp),
    "log": _scalar1(math.log), "sin": _scalar1(math.sin), "cos": _scalar1(math.cos),
    "tan": _scalar1(math.tan), "asin": _scalar1(math.asin), "acos": _scalar1(math.acos),
    "pow": lambda ev, e, a, b: float(_num(a) ** _num(b)),
    "atan2": lambda ev, e, a, b: math.atan2(_num(a), _num(b)),
    "min": lambda ev, e, *a: min(_num(x) for x in a),
    "max": lambda ev, e, *a: max(_num(x) for x in a),
    "clamp": lambda ev, e, v, lo, hi: min(max(_num(v), _num(lo)), _num(hi)),
    "vec3": lambda ev, e, x, y, z: np.array([_num(x), _num(y), _num(z)]),
    "norm": lambda ev, e, v: float(np.linalg.norm(_vec(v))),
    "norm1": lambda ev, e, v: float(np.abs(_vec(v)).sum()),
    "dot": lambda ev, e, a, b: float(_vec(a) @ _vec(b)),
    "cross": lambda ev, e, a, b: np.cross(_vec(a), _vec(b)),
    "distance": lambda ev, e, a, b: float(np.linalg.norm(_vec(a) - _vec(b))),
    "x": _component(0), "y": _component(1), "z": _component(2),
    "position": lambda ev, e, o: ev.T(o, e)[:3, 3].copy(),
    "orientation": lambda ev, e, o: Quat(tuple(quat_from_matrix(ev.T(o, e)[:3, :3]).tolist())),
    "transform": lambda ev, e, o: ev.T(o, e).copy(),
    "rpy": lambda ev, e, o: rpy_of(ev.R(o, e)),
    "roll": lambda ev, e, o: float(rpy_of(ev.R(o, e))[0]),
    "pitch": lambda ev, e, o: float(rpy_of(ev.R(o, e))[1]),
    "yaw": lambda ev, e, o: float(rpy_of(ev.R(o, e))[2]),
    "x-axis": _axis(0), "y-axis": _axis(1), "z-axis": _axis(2),
    "rotate": lambda ev, e, q, v: quat_matrix(q.xyzw) @ _vec(v),
    "relative": lambda ev, e, a, b: (np.linalg.inv(ev.T(b, e)) @ np.append(ev.T(a, e)[:3, 3],
                                                                           1.0))[:3],
    "extent": lambda ev, e, o: ev.extent(o, e),
    "support-region": lambda ev, e, o: ev.support(o, e),
    "local-support": lambda ev, e, o: ev.local_support(o, e),
    "grasp-point": lambda ev, e, o: ev.scene_vector("grasp_point", o, e),
    "grasp-axis": lambda ev, e, o: ev.scene_vector("grasp_axis", o, e),
    "grasp-hand-axis": lambda ev, e, o: ev.scene_vector("grasp_hand_axis", o, e),
    "stable-up": lambda ev, e, o: ev.scene_vector("stable_up", o, e),
    "base": lambda ev, e: ev.T_frames[ev.model.frame(ev.model.tree.root)].copy(),
    "box": lambda ev, e, lo, hi: AABB(_vec(lo), _vec(hi)),
    "grow": _grow,
    "lower": lambda ev, e, b: b.lower.copy(), "upper": lambda ev, e, b: b.upper.copy(),
    "center": lambda ev, e, b: (b.lower + b.upper) / 2,
    "inside": _inside,
    "<": _cmp("<"), "<=": _cmp("<="), ">": _cmp(">"), ">=": _cmp(">="), "=": _cmp("="),
    "and": lambda ev, e, *a: all(bool(x) for x in a),
    "or": lambda ev, e, *a: any(bool(x) for x in a),
    "not": lambda ev, e, a: not a,
    "implies": lambda ev, e, a, b: (not a) or bool(b),
}


def to_json_value(v):
    """A JSON-friendly form of an evaluated value."""
    if isinstance(v, Obj):
        return {"object": v.name}
    if isinstance(v, Quat):
        return list(v.xyzw)
    if isinstance(v, AABB):
        return {"lower": v.lower.tolist(), "upper": v.upper.tolist()}
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


def _mesh_extent(s) -> np.ndarray:
    import trimesh
    mesh = trimesh.load(str(s.mesh), force="mesh")
    return np.asarray(mesh.extents) * np.asarray(s.scale) / 2


#: half-extents of a shape's box (its frame), per kind
_EXTENT = {
    "box": lambda s: np.array(s.size, float),
    "sphere": lambda s: np.full(3, s.radius),
    "cylinder": lambda s: np.array([s.radius, s.radius, s.length / 2]),
    "mesh": _mesh_extent,
}

