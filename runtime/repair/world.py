"""States for repair: their constraint-space features (through the templates' DSL helpers and
the compiled forward kinematics), a sampler of states, and the controllers that execute the
action (docs/repair.md, "Controllers").

The sampler draws a robot configuration uniformly within the joint limits, then places each
object at a drawn pose *relative to its manipulator*: the constraint space is the relative pose,
so drawing there and composing with FK gives every relative pose without inverse kinematics.
The features of the state are then computed from its world poses by the stdlib helpers
(``offset``, ``relative-roll``, ...), as a user's own state would be.
"""

from __future__ import annotations

import importlib
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tmpc.compiler.cpz import sample
from tmpc.compiler.robot import homogeneous
from tmpc.compiler.rotations import quat_from_matrix
from tmpc.compiler.state import initial_state, state_from_json, world_poses
from tmpc.lang import ast as A
from tmpc.lang.diagnostics import InputError, error
from tmpc.runtime.evaluate import Evaluator, Obj
from tmpc.runtime.repair.domain import Target
from tmpc.runtime.repair.model import TEMPLATES, Features, Formula, Instance, predicts
from tmpc.runtime.repair.store import Observation


def _rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), \
        math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _pose_json(T: np.ndarray) -> dict:
    return {"translation": [float(v) for v in T[:3, 3]],
            "rotation": quat_from_matrix(T[:3, :3]).tolist()}


class RepairWorld:
    """A loaded world and its repair target: features of states, and states drawn in the
    constraint space."""

    def __init__(self, world, compiled, target: Target):
        self.world, self.compiled, self.target = world, compiled, target
        self.model = compiled.model
        self.scope = world.program.scope
        self.cont = [i for i in target.instances if not i.discrete]
        self.disc = [i for i in target.instances if i.discrete]
        # object -> manipulator it is placed relative to (the first pair that names it)
        self.pairs: dict[str, str] = {}
        for inst in self.cont:
            self.pairs.setdefault(inst.args[0], inst.args[1])
        self._base = None
        self._helpers = {name: self._call(t.coords) for name, t in TEMPLATES.items()}

    @staticmethod
    def _call(helper: str) -> A.Call:
        return A.Call(A.Name(helper), (A.ExprVar(A.Name("?o")), A.ExprVar(A.Name("?m"))))

    # ---- features ----------------------------------------------------------------------------
    def features(self, state_json: dict, where: str = "state") -> dict:
        """Instance text -> coordinates (continuous) or truth (discrete) at a state JSON."""
        base = self.world_state_base()
        state = state_from_json(state_json, self.world.scene, self.model, base, where)
        frames = self.compiled.fk(state.q) if self.compiled.fk is not None else None
        poses = world_poses(state, self.model, frames)
        ev = Evaluator(self.world.scene, self.model, state.q, frames, poses, self.scope)
        b = self.target.binding
        out: dict = {}
        for inst in self.cont:
            env = {"?o": Obj(b[inst.args[0]]), "?m": Obj(b[inst.args[1]])}
            val = ev.value(self._helpers[inst.name], env)
            out[inst.text()] = [float(x) for x in np.atleast_1d(val)]
        atoms = {a.lower() for a in state.atoms}
        for inst in self.disc:
            out[inst.text()] = self.target.ground_atom(inst).lower() in atoms
        return out

    def world_state_base(self):
        if self._base is None:
            self._base = initial_state(self.world.scene, self.model)
        return self._base

    def features_of(self, observations: list[Observation]) -> Features:
        t = {i: np.array([TEMPLATES[i.name].feature(np.array([o.features[i.text()]]))[0]
                          for o in observations]) for i in self.cont}
        truth = {i: np.array([bool(o.features[i.text()]) for o in observations], bool)
                 for i in self.disc}
        return Features(t, truth, np.array([o.success for o in observations], bool))

    # ---- sampling ----------------------------------------------------------------------------
    def naive_coords(self, rng: np.random.Generator) -> dict:
        """Relative coordinates of every (object, manipulator) pair, and discrete truths: offsets
        with a uniform distance up to the workspace radius and a uniform direction, angles
        uniform over their range, each discrete atom true with probability 1/2."""
        out = {}
        for o, m in self.pairs.items():
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            out[(o, m)] = {"offset": u * rng.uniform(0, TEMPLATES["dist"].span),
                           "relative-roll": rng.uniform(-math.pi, math.pi),
                           "relative-pitch": rng.uniform(-math.pi / 2, math.pi / 2),
                           "relative-yaw": rng.uniform(-math.pi, math.pi)}
        for inst in self.disc:
            out[inst] = bool(rng.random() < 0.5)
        return out

    def clause_coords(self, f: Formula, rng: np.random.Generator, k: int = 32) -> list[dict]:
        """``k`` draws inside one clause of ``f`` (drawn uniformly among its clauses): the
        template sets sampled by the CPZ sampler (one batched call each), the rest naive."""
        out = [self.naive_coords(rng) for _ in range(k)]
        clause = f.clauses[int(rng.integers(len(f.clauses)))]
        for lit in clause:
            tpl = TEMPLATES[lit.instance.name]
            o, m = lit.instance.args
            if self.pairs.get(o) != m:
                continue
            xs = np.asarray(sample(tpl.cpz(max(lit.theta, 1e-9)), k, rng))
            for c, x in zip(out, xs):
                c[(o, m)][tpl.coords] = x if tpl.dim > 1 else float(x[0])
        for c in out:
            for lit in f.discrete:
                c[lit.instance] = lit.positive
        return out

    def state(self, coords: dict, rng: np.random.Generator) -> dict:
        """A state JSON realising ``coords``: a uniform configuration, objects placed relative to
        their manipulators, discrete atoms set."""
        m = self.model
        q = rng.uniform(m.lower, m.upper)
        T = self.compiled.fk(q)
        H = homogeneous(T)
        b = self.target.binding
        base = self.world_state_base()
        poses = world_poses(base, m, T)
        object_poses = {k: _pose_json(v) for k, v in poses.items()}
        for (o, man), c in ((k, v) for k, v in coords.items() if isinstance(k, tuple)):
            Tm = H[m.frame(b[man])]
            R_rel = _rpy_matrix(c["relative-roll"], c["relative-pitch"], c["relative-yaw"])
            R_o = Tm[:3, :3] @ R_rel.T
            To = np.eye(4)
            To[:3, :3] = R_o
            To[:3, 3] = Tm[:3, 3] - R_o @ np.asarray(c["offset"], float)
            object_poses[b[o]] = _pose_json(To)
        atoms = sorted(self.target.ground_atom(k) for k, v in coords.items()
                       if isinstance(k, Instance) and v)
        return {"joints": dict(zip(m.q_names, (float(v) for v in q))),
                "object_poses": object_poses, "mode": {"atoms": atoms}}

    def ground_effects(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """The action's modelled discrete effects, ground: (atoms added, atoms deleted)."""
        b = self.target.binding
        adds, dels = [], []

        def ground(atom: A.Atom) -> str:
            return "(" + " ".join([atom.pred.text, *(b.get(t.name.text, t.name.text)
                                                     for t in atom.args)]) + ")"

        def walk(e):
            if isinstance(e, A.AndEffect):
                for p in e.parts:
                    walk(p)
            elif isinstance(e, A.AddEffect):
                adds.append(ground(e.atom))
            elif isinstance(e, A.DelEffect):
                dels.append(ground(e.atom))
        walk(self.target.action.effect)
        return tuple(sorted(adds)), tuple(sorted(dels))

    def effects(self, state_json: dict) -> dict:
        """The state after the action's discrete effects (a success of the model's action)."""
        adds, dels = self.ground_effects()
        atoms = (set(state_json.get("mode", {}).get("atoms", [])) - set(dels)) | set(adds)
        return {**state_json, "mode": {**state_json.get("mode", {}), "atoms": sorted(atoms)}}


# ---------------------------------------------------------------------------------------------
# controllers


@dataclass
class Outcome:
    success: bool
    result: dict


class SimController:
    """Succeeds where a hidden truth formula holds (``--controller sim:TRUTH``)."""

    def __init__(self, rw: RepairWorld, truth: Formula):
        self.rw, self.truth = rw, truth

    def __call__(self, state: dict, feats: dict) -> Outcome:
        ok = bool(predicts(self.truth, self.rw.features_of([Observation(
            "", (), state, False, {}, feats)]))[0])
        return Outcome(ok, self.rw.effects(state) if ok else state)


class PyController:
    """A user's function ``fn(state: dict, action: str, arguments: list) -> {"success": bool,
    "result": state dict}`` (``--controller py:MODULE:FUNCTION``)."""

    def __init__(self, rw: RepairWorld, spec: str):
        self.rw = rw
        mod, _, fn = spec.partition(":")
        try:
            self.fn = getattr(importlib.import_module(mod), fn)
        except (ImportError, AttributeError) as exc:
            raise InputError(error("E846", f"--controller py:{spec}: {exc}", None,
                                   "give py:MODULE:FUNCTION importable from the current "
                                   "directory or PYTHONPATH")) from None

    def __call__(self, state: dict, feats: dict) -> Outcome:
        t = self.rw.target
        got = self.fn(state, t.action.name.text, list(t.binding.values()))
        if not isinstance(got, dict) or not isinstance(got.get("success"), bool):
            raise InputError(error("E846", "the controller must return {\"success\": bool, "
                                   "\"result\": state}", None))
        return Outcome(got["success"], got.get("result") or state)


def read_observations(path: str, rw: RepairWorld):
    """Yield (line number, state, success, result) from a JSON-lines observations file, each
    checked: {"state", "action", "arguments", "outcome": "success"|"failure", "result"}."""
    t = rw.target
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise InputError(error("E010", f"cannot read {path}: {exc.strerror}", None)) from None
    for n, line in enumerate(lines, 1):
        if not line.strip():
            continue

        def bad(msg: str) -> InputError:
            return InputError(error("E843", f"{path}:{n}: {msg}", None,
                                    'each line is {"state": {...}, "action": "pick", '
                                    '"arguments": [...], "outcome": "success" | "failure", '
                                    '"result": {...}}'))
        try:
            rec = json.loads(line)
        except json.JSONDecodeError as exc:
            raise bad(f"not valid JSON: {exc.msg} (column {exc.colno})") from None
        if not isinstance(rec, dict):
            raise bad("an observation is a JSON object")
        missing = [k for k in ("state", "action", "arguments", "outcome") if k not in rec]
        if missing:
            raise bad("missing " + ", ".join(f"`{k}`" for k in missing))
        if rec["outcome"] not in ("success", "failure"):
            raise bad(f"`outcome` is \"success\" or \"failure\", not {json.dumps(rec['outcome'])}")
        if str(rec["action"]).lower() != t.action.name.key or \
                [str(a).lower() for a in rec.get("arguments") or []] != \
                [a.lower() for a in t.binding.values()]:
            continue      # another action's execution: not evidence about this one
        if not isinstance(rec["state"], dict):
            raise bad("`state` is a state object")
        yield n, rec["state"], rec["outcome"] == "success", rec.get("result") or rec["state"], bad
