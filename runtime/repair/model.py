"""Predicate templates and the formulas repair edits (thesis §3.4; docs/repair.md).

A *template* is a constraint space of an action's arguments and a parameterised set in it. The
continuous templates of ``stdlib/templates.tmpc`` reduce each observation to one feature t >= 0
(the norm of the manipulator's offset from the object for ``dist``, the absolute relative angle
for the alignment bands), and their set is {t <= theta}: a ball or an interval, whose CPZ
(:meth:`Template.cpz`) is the one `tmpc.compiler.cpz` computes with. For these sets the distance
to the set and to its boundary have exact closed forms (docs/math.md §C.3b, "exact special cases"),
which is what the error uses; ``tests/runtime/test_repair.py`` checks them against the CPZ
solver and against the DSL predicate each template stands for.

A *discrete* template is a domain predicate over some of the action's parameters; its literal
holds or not in the observation's mode.

A :class:`Formula` is a conjunction of discrete literals with a DNF of continuous clauses. Its
signed distance (docs/math.md §C.2, "keep Boolean structure symbolic") is, for disjoint coordinates,
sqrt(sum of squares) over a clause's literals outside, the minimum over clauses, and the
minimum distance to a boundary inside; a violated discrete literal counts ``KAPPA``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from tmpc.compiler.cpz import CPZ

#: the distance a violated discrete literal contributes (and an inside point's cap), in the
#: units of the continuous templates (m, rad): one "unit" of being wrong about a discrete fact
KAPPA = 1.0


@dataclass(frozen=True)
class Template:
    """A continuous template: the stdlib helper ``name`` with parameter ``theta`` in ``bounds``."""

    name: str
    #: the stdlib helper giving its constraint-space coordinates, and their dimension
    coords: str
    dim: int
    unit: str
    bounds: tuple[float, float]
    #: how close a parameter must be to count as structurally correct (0.02 m / 0.05 rad)
    tolerance: float
    #: range of the naive sampler in each coordinate: offsets up to the workspace radius, angles
    #: over their full range
    span: float
    #: the largest value the feature can take (angles: their range); a parameter this large
    #: makes the literal hold everywhere
    full: float = math.inf

    def feature(self, g: np.ndarray) -> np.ndarray:
        """t(g) for coordinates g (N, dim): the set is {t <= theta}."""
        g = np.asarray(g, float).reshape(len(g), self.dim)
        return np.linalg.norm(g, axis=1) if self.dim > 1 else np.abs(g[:, 0])

    def cpz(self, theta: float):
        """The template's set as a constrained polynomial zonotope in its coordinates."""
        if self.dim > 1:
            return CPZ.ball(np.zeros(self.dim), theta)
        return CPZ.interval([-theta], [theta])


_ANGLE = dict(unit="rad", bounds=(0.0, math.pi), tolerance=0.05, span=math.pi, dim=1,
              full=math.pi)
TEMPLATES: dict[str, Template] = {
    "dist": Template("dist", "offset", 3, "m", (0.0, 2.0), 0.02, 0.8),
    "roll-aligned": Template("roll-aligned", "relative-roll", **_ANGLE),
    "pitch-aligned": Template("pitch-aligned", "relative-pitch",
                              **{**_ANGLE, "span": math.pi / 2, "full": math.pi / 2,
                                 "bounds": (0.0, math.pi / 2)}),
    "yaw-aligned": Template("yaw-aligned", "relative-yaw", **_ANGLE),
}


@dataclass(frozen=True, order=True)
class Instance:
    """A template applied to action parameters (``?c ?g``): continuous or a discrete predicate."""

    name: str
    args: tuple[str, ...]
    discrete: bool = False

    @property
    def template(self) -> Template | None:
        return None if self.discrete else TEMPLATES[self.name]

    def text(self, theta: float | None = None, rename: dict | None = None,
             precise: bool = False) -> str:
        args = " ".join((rename or {}).get(a, a) for a in self.args)
        if theta is None:
            return f"({self.name} {args})"
        return f"({self.name} {args} {_num(theta, precise)})"


def _num(x: float, precise: bool = False) -> str:
    """4 decimals (0.1 mm, 0.1 mrad) for people; every digit for the store, so that a resumed
    loop continues with exactly the formula it stopped with."""
    if precise:
        return repr(float(x))
    return f"{x:.4f}".rstrip("0").rstrip(".") if abs(x) >= 1e-4 else "0"


@dataclass(frozen=True, order=True)
class Literal:
    instance: Instance
    #: a continuous literal's parameter; None for a discrete one
    theta: float | None = None
    positive: bool = True

    def text(self, rename: dict | None = None, precise: bool = False) -> str:
        body = self.instance.text(self.theta, rename, precise)
        return body if self.positive else f"(not {body})"


@dataclass(frozen=True)
class Formula:
    """(and DISCRETE... (or CLAUSE...)) with each clause a conjunction of continuous literals."""

    discrete: tuple[Literal, ...] = ()
    clauses: tuple[tuple[Literal, ...], ...] = ((),)
    #: how this formula was reached (for reports): the edits from the loop's start formula
    history: tuple[str, ...] = field(default=(), compare=False)

    @property
    def size(self) -> int:
        return len(self.discrete) + sum(len(c) for c in self.clauses)

    def key(self) -> tuple:
        """The structure without parameters: candidates of one key differ only in theta."""
        return (tuple(sorted((lit.instance, lit.positive) for lit in self.discrete)),
                tuple(sorted(tuple(sorted(lit.instance for lit in c)) for c in self.clauses)))

    def thetas(self) -> np.ndarray:
        return np.array([lit.theta for c in self.clauses for lit in c], float)

    def with_thetas(self, thetas) -> "Formula":
        it = iter(float(t) for t in thetas)
        return replace(self, clauses=tuple(tuple(replace(lit, theta=next(it)) for lit in c)
                                           for c in self.clauses))

    def geometric_text(self, rename: dict | None = None, precise: bool = False) -> str:
        """The continuous part as DSL (for a geometric predicate's ``:semantics``)."""
        def conj(c):
            if not c:
                return "(and)"
            return c[0].text(rename, precise) if len(c) == 1 else \
                "(and " + " ".join(lit.text(rename, precise) for lit in c) + ")"
        if len(self.clauses) == 1:
            return conj(self.clauses[0])
        return "(or " + " ".join(conj(c) for c in self.clauses) + ")"

    def text(self, precise: bool = False) -> str:
        """The whole formula in DSL over the action's parameters."""
        parts = [lit.text() for lit in self.discrete]
        geo = self.geometric_text(precise=precise)
        if geo != "(and)":
            parts.append(geo)
        if not parts:
            return "(and)"
        return parts[0] if len(parts) == 1 else "(and " + " ".join(parts) + ")"

    def instances(self) -> set[Instance]:
        return {lit.instance for lit in self.discrete} | {lit.instance for c in self.clauses
                                                          for lit in c}


# ---------------------------------------------------------------------------------------------
# signed distance and error over observation features


@dataclass
class Features:
    """Per-observation values of every candidate instance: ``t[inst]`` (N,) for continuous ones
    (the template feature), ``truth[inst]`` (N,) bool for discrete ones, and the outcomes."""

    t: dict[Instance, np.ndarray]
    truth: dict[Instance, np.ndarray]
    success: np.ndarray

    def __len__(self) -> int:
        return len(self.success)

    def take(self, idx) -> "Features":
        idx = np.asarray(idx, int)
        return Features({k: v[idx] for k, v in self.t.items()},
                        {k: v[idx] for k, v in self.truth.items()}, self.success[idx])


def signed_distance(f: Formula, feats: Features, thetas=None, xp=np) -> tuple:
    """(squared outside distance, inside distance to the boundary), both >= 0 and one of them
    0, of each observation to ``f``'s set with the continuous parameters ``thetas`` (default:
    ``f``'s); ``xp`` is numpy or jax.numpy (the error is differentiated in theta)."""
    n = len(feats)
    thetas = f.thetas() if thetas is None else thetas
    viol = xp.zeros(n)
    for lit in f.discrete:
        holds = feats.truth[lit.instance] == lit.positive
        viol = viol + xp.where(holds, 0.0, 1.0)
    outs, ins = [], []
    k = 0
    for clause in f.clauses:
        sq, inner = xp.zeros(n), xp.full(n, KAPPA)
        for lit in clause:
            t = feats.t[lit.instance]
            sq = sq + xp.maximum(t - thetas[k], 0.0) ** 2
            inner = xp.minimum(inner, xp.maximum(thetas[k] - t, 0.0))
            k += 1
        outs.append(sq)
        ins.append(xp.where(sq > 0, 0.0, inner))
    geo_sq = outs[0] if len(outs) == 1 else xp.min(xp.stack(outs), axis=0)
    geo_in = ins[0] if len(ins) == 1 else xp.max(xp.stack(ins), axis=0)
    out_sq = geo_sq + KAPPA ** 2 * viol
    return out_sq, xp.where(out_sq > 0, 0.0, geo_in)


def predicts(f: Formula, feats: Features) -> np.ndarray:
    """Where ``f`` says the action succeeds."""
    return signed_distance(f, feats)[0] <= 0


def signed(f: Formula, feats: Features) -> np.ndarray:
    """sd: the distance to the set outside it, minus the distance to its boundary inside."""
    out_sq, inner = signed_distance(f, feats)
    return np.where(out_sq > 0, np.sqrt(out_sq), -inner)


def error(f: Formula, feats: Features, thetas=None, xp=np):
    """The repair error: squared distance to the boundary of each misclassified observation
    (outside ones that succeeded, inside ones that failed), summed."""
    out_sq, inner = signed_distance(f, feats, thetas, xp)
    return xp.sum(xp.where(feats.success, out_sq, inner ** 2))
